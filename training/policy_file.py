"""The policy file format, and loading weights into a runner.

``policy_payload`` and ``save_policy`` write a trained actor as a self-contained
``policy.pt``: only tensors and plain Python values (it loads with
``torch.load(weights_only=True)``), with the actor's config and the env and training configs
it was trained with, under the ``format`` key ``POLICY_FORMAT``. ``h2h_racing.policies.trained``
reads it back as a driver. ``load_init`` starts a runner's actor from a policy file
(``TrainConfig.init``); ``load_runner_state`` loads an rsl-rl runner state weights-only (a
league learner's ``runner.pt``).
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython

from h2h_racing.common.extras import missing_extra  # noqa: E402

try:
    import torch  # noqa: E402
except ImportError as _error:
    raise missing_extra("train", "training", _error) from None

# trained_alone: re-exported (it reads a policy dict, and lives beside the format).
from h2h_racing.policies.trained import POLICY_FORMAT, trained_alone  # noqa: E402,F401
from h2h_racing.training.ppo import project_std  # noqa: E402

if TYPE_CHECKING:
    from h2h_racing.training.config import TrainConfig

def policy_payload(runner: Any, config: TrainConfig,
                   training: dict[str, float] | None = None) -> dict[str, Any]:
    """The policy dict of ``runner``'s actor: weights (copied, so later training does not
    change them, onto the CPU whatever device trained them, in PyTorch's default layout), the
    actor's config and the configs it was trained with. It holds only tensors and plain Python
    values (see ``save_policy``; ``TrainedPolicy.from_payload`` drives with it directly)."""
    return {
        "format": POLICY_FORMAT,
        "actor_state_dict": {key: value.detach().to("cpu").contiguous().clone()
                             for key, value in runner.alg.get_policy().state_dict().items()},
        "actor_cfg": config.actor_dict(),
        "obs_groups": config.actor_groups(),
        "observations": config.observations,
        "env_config": _plain(config.env_config().to_dict()),
        "train_config": _plain(dataclasses.asdict(config)),
        "training": dict(training or {}),
        "racing": racing_record(config),
    }


def racing_record(config: TrainConfig) -> dict[str, Any]:
    """How the policy was trained to meet other cars, the ``racing`` key of a policy file:
    ``alone`` (no other car in its env copies: a time trial, or boxes and bot cars only),
    ``cars`` per copy, ``learners`` among them, and the ``opponents`` driving the others (empty
    in self-play). A policy trained alone has never seen another car: ``race`` and
    ``evaluate`` warn when it races one (``trained_alone``)."""
    learners = config.num_cars if config.learners is None else config.learners
    return {"alone": config.num_cars == 1, "cars": config.num_cars, "learners": learners,
            "opponents": config.opponents() if learners < config.num_cars else []}


def save_policy(runner: Any, config: TrainConfig, path: str | Path,
                training: dict[str, float] | None = None) -> Path:
    """Write the actor of ``runner`` and the configs it was trained with to ``path``, with
    ``training`` figures.

    The file holds only tensors and plain Python values, so it loads with
    ``torch.load(path, weights_only=True)``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(policy_payload(runner, config, training), path)
    return path


def _plain(value: Any) -> Any:
    """Tuples to lists, recursively, so that the dict is plain JSON-like data."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


FRESH_SLOTS_COUNT = 2 * 512 * 32
"""Sample count an ``init_fresh_slots`` init's observation normaliser restarts from: two
rollouts of 512 copies x 32 steps."""


def load_init(runner: Any, init: str, fresh_slots: bool = False) -> None:
    """Load the actor weights of policy ``init`` (shipped name or path) into ``runner``'s
    actor (the student when distilling), its std projected into this run's range (an init
    trained without ``max_std`` may have a std of 10).

    With ``fresh_slots`` (``TrainConfig.init_fresh_slots``) the state vector's opponent and
    obstacle slots (features ``BASE_FEATURES`` on) get first-layer weights of 0, and the
    observation normaliser's sample count restarts from ``FRESH_SLOTS_COUNT``. A policy that
    raced alone saw those slots at 0 all its life: its normaliser holds std 0 for them (a box
    in view would be an input of 1 / 0.01 = 100) and their weights are still random. So
    loaded, it drives exactly as before until training gives the slots weight, and its
    normaliser follows the states with boxes and cars within a few iterations instead of
    being outweighed by the millions of samples it was fitted on.

    Raises:
        FileNotFoundError, ValueError: ``init`` is not a policy, or its actor does not fit
            (or, with ``fresh_slots``, is not a state-observation MLP).
    """
    from h2h_racing.policies.trained import load_policy_payload

    payload = load_policy_payload(init)
    if fresh_slots:
        freshen_slots(payload, init)
    load_actor(runner.alg.get_policy(), payload, f"init policy {init!r}")
    project_std(runner.alg.get_policy())


def freshen_slots(payload: dict[str, Any], source: str) -> None:
    """Set, in policy dict ``payload`` (in place), the first-layer weights of the state
    vector's opponent and obstacle slots to 0 and its observation normaliser's sample count
    to ``FRESH_SLOTS_COUNT`` (``load_init``'s ``fresh_slots``).

    Raises:
        ValueError: ``payload`` (named ``source``) is not a state-observation MLP policy.
    """
    from h2h_racing.sensors.state import BASE_FEATURES

    actor = payload["actor_state_dict"]
    if payload["observations"] != "state" or "mlp.0.weight" not in actor:
        raise ValueError(f"init_fresh_slots needs a state-observation policy as init, got "
                         f"{source!r} with observations={payload['observations']!r}; drop "
                         f"init_fresh_slots or start from a state policy")
    actor["mlp.0.weight"][:, BASE_FEATURES:] = 0.0
    count = actor["obs_normalizer.count"]
    actor["obs_normalizer.count"] = torch.full_like(count, FRESH_SLOTS_COUNT)


def load_actor(model: Any, payload: dict[str, Any], what: str) -> None:
    """Load policy dict ``payload``'s actor weights into ``model`` (strictly), or raise a
    ``ValueError`` that says ``what`` does not fit and which tensors differ."""
    try:
        model.load_state_dict(payload["actor_state_dict"])
    except (RuntimeError, TypeError, ValueError) as err:
        raise ValueError(f"{what} does not fit the actor being trained (hidden sizes or "
                         f"observations differ): {' '.join(str(err).split())}") from None


def load_checkpoint(runner: Any, path: str | Path) -> None:
    """Load one of ``train``'s checkpoints (rsl-rl's ``model_<i>.pt``: PPO's actor, critic and
    optimizer, or distillation's student, teacher and optimizer, and the iteration) into
    ``runner`` weights-only, for ``train --resume``; rsl-rl's own ``load`` unpickles with
    ``weights_only=False``, which runs whatever code the file holds.

    Raises:
        FileNotFoundError, ValueError: The file is missing, unreadable, unsafe, lacks a key, or
            its tensors do not fit ``runner``'s networks; the message names the file.
    """
    from h2h_racing.policies.weights import WeightsFileError, check_keys, load_weights

    distilling = hasattr(runner.alg, "teacher_loaded")
    expected = ("a checkpoint of `h2h-racing train` (rsl-rl's model_<i>.pt: "
                + ("student, teacher" if distilling else "actor, critic")
                + " and optimizer state dicts and the iteration)")
    keys = DISTILL_STATE_KEYS if distilling else RUNNER_STATE_KEYS
    state = check_keys(load_weights(path, expected), keys, str(path), expected)
    try:
        runner.alg.load(state, None, True)
    except (RuntimeError, TypeError, ValueError, KeyError) as err:
        raise WeightsFileError(f"{path}: does not fit this run's networks (resume with the "
                               f"settings that trained it): {type(err).__name__}: "
                               f"{' '.join(str(err).split())}") from None
    runner.current_learning_iteration = state["iter"]


DISTILL_STATE_KEYS = {"student_state_dict": dict, "teacher_state_dict": dict,
                      "optimizer_state_dict": dict, "iter": int}
"""What rsl-rl's ``DistillationRunner.save`` writes (``Distillation.save()`` plus ``iter``)."""

RUNNER_STATE_KEYS = {"actor_state_dict": dict, "critic_state_dict": dict,
                     "optimizer_state_dict": dict, "iter": int}
"""What rsl-rl's ``OnPolicyRunner.save`` writes (``PPO.save()`` plus ``iter`` and ``infos``)
and ``load_runner_state`` needs."""


def load_runner_state(runner: Any, path: str | Path) -> None:
    """Load a ``runner.pt`` written by rsl-rl's ``OnPolicyRunner.save`` into ``runner``, as
    its ``load`` does (actor, critic, optimizer, iteration), but weights-only: rsl-rl's own
    ``load`` unpickles with ``weights_only=False``, which runs whatever code the file holds.

    Raises:
        FileNotFoundError, ValueError: The file is missing, unreadable, unsafe, lacks a key, or
            its tensors do not fit ``runner``'s networks; the message names the file.
    """
    from h2h_racing.policies.weights import WeightsFileError, check_keys, load_weights

    expected = ("a league learner's rsl-rl runner state (runner.pt: actor, critic and "
                "optimizer state dicts and the iteration, as `league train` writes it)")
    state = check_keys(load_weights(path, expected), RUNNER_STATE_KEYS, str(path), expected)
    try:
        runner.alg.load(state, None, True)
    except (RuntimeError, TypeError, ValueError, KeyError) as err:
        raise WeightsFileError(f"{path}: does not fit this league's learner (its network "
                               f"sizes or observations differ): {type(err).__name__}: "
                               f"{' '.join(str(err).split())}") from None
    runner.current_learning_iteration = state["iter"]
