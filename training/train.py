"""Train racing policies with rsl-rl PPO on the batched core, and save them as policy files.

``TrainConfig`` (frozen) builds a fresh rsl-rl config dict for every runner (rsl-rl mutates the
dict it is given). ``train`` runs PPO with rsl-rl's tensorboard logs and checkpoints in the
output folder, then writes ``policy.pt``: a self-contained policy file that loads with
``torch.load(weights_only=True)`` and carries the env and observation config it was trained
with (see ``h2h_racing.policies.trained``). Every ``eval_every`` iterations it evaluates the
current actor (``evaluate_during_training``): figures into the tensorboard log under ``Eval/``
and a rerun recording of a race to ``<out>/eval/iter_<n>.rrd``.

Instead of PPO, ``TrainConfig.teacher`` imitates a teacher with rsl-rl's ``Distillation``
(DAgger: the student drives, the teacher labels the states it reaches): a state policy
distilled into a camera policy, or a scripted driver (``racing_line``) whose actions the env
computes in the learner's place (``RacingVecEnv``'s ``expert`` group, ``ScriptedTeacher``).
Procedural runs can hold out random tracks (``validation_tracks``) and keep the actor that
laps them best. ``TrainConfig.from_toml`` reads a config file (``h2h-racing train --config``).
"""

from __future__ import annotations

import copy
import dataclasses
import importlib.util
import os
import time
import tomllib
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

os.environ.setdefault("GIT_PYTHON_REFRESH", "quiet")  # rsl-rl imports GitPython

import numpy as np  # noqa: E402

from h2h_racing.extras import missing_extra  # noqa: E402

try:
    import torch  # noqa: E402
    from rsl_rl.algorithms import PPO  # noqa: E402
    from rsl_rl.models import MLPModel  # noqa: E402
    from rsl_rl.modules.distribution import GaussianDistribution  # noqa: E402
except ImportError as _error:
    raise missing_extra("train", "training", _error) from None

from h2h_racing.config import EnvConfig, RaceRules, RewardConfig  # noqa: E402
from h2h_racing.training.toml_types import check_fields  # noqa: E402
from h2h_racing.training.vec_env import OBSERVATIONS, PoolOpponent, RacingVecEnv  # noqa: E402
from h2h_racing.policies.scripted import TEACHERS  # noqa: E402
from h2h_racing.track import Track  # noqa: E402
from h2h_racing.track_gen import random_track  # noqa: E402

SCRIPTED_TEACHERS = TEACHERS
"""Scripted drivers a ``TrainConfig.teacher`` or ``imitation_driver`` can name (their actions
reach the learner through the env's ``expert`` observation group)."""
POLICY_FORMAT = "h2h-racing-policy/1"
"""Value of the ``format`` key of a policy file."""
STD_FLOOR = 1e-6
"""Smallest policy standard deviation (rsl-rl's own floor) when ``TrainConfig.max_std`` is set."""
PROCEDURAL = "procedural"
"""``TrainConfig.track`` value that trains on a new random track every ``track_every``
iterations."""


@dataclass(frozen=True, kw_only=True)
class PPOConfig:
    """PPO hyper-parameters (rsl-rl's ``algorithm`` section)."""

    learning_rate: float = 1e-3
    """Adam learning rate (adapted by the KL schedule)."""
    num_learning_epochs: int = 4
    """Passes over each rollout."""
    num_mini_batches: int = 4
    """Mini-batches per pass."""
    clip_param: float = 0.2
    """PPO ratio clip."""
    gamma: float = 0.995
    """Discount per step (1/15 s): a horizon of about 13 s."""
    lam: float = 0.95
    """GAE lambda."""
    entropy_coef: float = 0.003
    """Entropy bonus (0 turns it off)."""
    desired_kl: float = 0.01
    """Target KL of the adaptive learning-rate schedule."""
    max_grad_norm: float = 1.0
    """Gradient clipping."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "entropy_coef":
                if not isinstance(value, (int, float)) or value < 0:
                    raise ValueError(f"PPOConfig.entropy_coef must be a number >= 0, got "
                                     f"{value!r}")
            elif not isinstance(value, (int, float)) or value <= 0:
                raise ValueError(f"PPOConfig.{f.name} must be a number > 0, got {value!r}")


@dataclass(frozen=True, kw_only=True)
class DistillConfig:
    """Distillation hyper-parameters (rsl-rl's ``Distillation`` ``algorithm`` section)."""

    learning_rate: float = 1e-3
    """Adam learning rate (fixed)."""
    num_learning_epochs: int = 1
    """Passes over each rollout."""
    gradient_length: int = 1
    """Rollout steps whose losses are summed per gradient step (a divisor of
    ``num_steps_per_env``, or the last steps of each pass are never learned from). Summing
    only matters for recurrent students (backpropagation through time); for these
    feed-forward ones 1 gives a gradient step per rollout step (a batch of ``num_envs``
    samples) for the same compute."""
    max_grad_norm: float = 1.0
    """Gradient clipping."""
    student_std: float = 0.1
    """Standard deviation of the student's driving noise during rollouts (actions in
    [-1, 1]; not learned): it visits states a little off the teacher's line, so that the
    student learns to come back."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if not isinstance(value, (int, float)) or value <= 0:
                raise ValueError(f"DistillConfig.{f.name} must be a number > 0, got {value!r}")
        for name in ("num_learning_epochs", "gradient_length"):
            if not isinstance(getattr(self, name), int):
                raise ValueError(f"DistillConfig.{name} must be an int, got "
                                 f"{getattr(self, name)!r}")


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """What to train, on what, against whom."""

    track: str = "speedway"
    """Catalogue name, track file, ``random:<seed>``, or ``"procedural"``: a new random track
    (``random_training_track`` with the ``procedural_*`` settings) every ``track_every``
    iterations."""
    track_every: int = 10
    """Iterations between track changes with ``track="procedural"``."""
    procedural_varying_share: float = 0.0
    """Share of procedural tracks whose width varies along the lap (``random_training_track``).
    0 (as ``ppo_procedural``): three 10-15 minute runs with 0.3, corners down to 0.45 m and
    laps from 15 m generalised worse (53-69 % of laps on the shipped tracks against 79 %)."""
    procedural_length: tuple[float, float] = (20.0, 45.0)
    """Lap-length range of procedural tracks [m] (shorter laps of the same shapes have
    tighter corners)."""
    procedural_min_radius: float = 0.6
    """Smallest corner radius of procedural tracks [m], raised to 1.2 x the widest half-width
    on wider tracks (``technical`` has 0.5 m corners)."""
    procedural_reverse_share: float = 0.0
    """Share of procedural tracks driven clockwise (``Track.reversed``). The generator's loops
    are star-shaped and run anticlockwise: their right-hand bends are gentle (tightest radius
    1.2 m or more, median 4.9 m over 60 tracks), while ``technical`` turns right at 0.53 m,
    ``hairpin_valley`` at 0.75 m; driven the other way, every tight left-hander is a tight
    right-hander. 0 (as ``ppo_procedural``): a 1,020-iteration run with 0.5 lapped 75.0 % of
    the shipped tracks' attempts against 79.3 %, still 0 % on ``technical`` (its card)."""
    procedural_chicanes: tuple[int, int] = (0, 0)
    """``(fewest, most)`` chicanes added to each procedural track (``random_track``'s
    ``chicanes``): S-bends as on ``technical``'s start straight, which smooth loops lack.
    (0, 0) (as ``ppo_procedural``): (1, 4) with half the tracks reversed and corners down to
    0.5 m lapped 72.1 %, 0 % on ``technical``."""
    procedural_tight_share: float = 0.0
    """Share of procedural tracks that are short, narrow and twisty like ``technical``
    (``random_training_track``'s ``tight_share``): the other generated tracks spend 0-5 % of
    their lap in corners under 1 m radius, ``technical`` 40 %. 0.3 (with imitation of the
    racing line, then PPO) trained ``ppo_generalist``, the first procedural policy to lap
    ``technical``."""
    observations: Literal["state", "camera", "camera_only"] = "state"
    """Actor input: the state vector; the camera plus the state vector; or the camera plus the
    car's own speed and steering angle (``camera_only``: DeepRacer's setting, no track geometry
    and no other car's state). The critic always gets the privileged state."""
    num_cars: int = 1
    """Cars per env copy."""
    opponent: str | None = None
    """Driver of the cars that are not learners: a ``h2h_racing.policies`` driver name or a
    ``policy.pt``, or several separated by commas, which share the env copies (copy ``e``
    races the ``e mod k``-th of the ``k`` names; ``PoolOpponent``)."""
    learners: int | None = None
    """Learner cars per copy; None means every car (self-play with parameter sharing)."""
    num_envs: int = 256
    """Env copies."""
    num_steps_per_env: int = 32
    """Rollout length per iteration [steps]."""
    hidden_dims: tuple[int, ...] = (128, 128)
    """Hidden layer sizes of the actor and critic MLPs."""
    init_std: float = 0.5
    """Initial standard deviation of the Gaussian policy (actions in [-1, 1])."""
    max_std: float | None = None
    """Upper bound of the policy's standard deviation, held after every PPO update
    (``BoundedStdPPO``); None leaves it unbounded, as the shipped policies were trained. The
    env clips actions to [-1, 1], so once a mean sits past a bound, a wider Gaussian costs the
    return nothing and the entropy bonus widens it for ever: the league mains of runs 5-7 went
    from 0.3 to 2-4 in 30 minutes (league/README.md). A larger ``init_std`` (or
    an ``init`` policy's std) is clamped to it."""
    reward: RewardConfig = field(default_factory=RewardConfig)
    """Reward weights."""
    camera_size: tuple[int, int] = (64, 48)
    """(width, height) of the camera image for camera policies [px]."""
    seed: int = 0
    """Seeds torch and the env."""
    torch_threads: int = 1
    """Torch intra-op threads. One is fastest for these small networks on a small machine:
    with more threads than free cores, OpenMP's spinning threads slow the update ~10x."""
    ppo: PPOConfig = field(default_factory=PPOConfig)
    """PPO hyper-parameters."""
    reward_function: str | None = None
    """A DeepRacer reward file (``reward_function(params)``) replacing the built-in reward;
    loaded once per learner car and env copy."""
    model_metadata: str | None = None
    """A DeepRacer ``model_metadata.json`` whose action space (discrete list or continuous
    ranges) the cars use; its sensors are not used (``observations`` chooses the inputs)."""
    simtrace_envs: int = 0
    """Env copies whose DeepRacer simtrace + metrics logs ``train`` writes to
    ``OUT/simtrace`` (0-10; 0 writes none)."""
    eval_every: int = 50
    """Iterations between evaluations of the current actor [iterations]; 0 turns them off.
    Evaluations need an output folder (``train(out=...)``)."""
    eval_episodes: int = 8
    """Lap attempts per evaluation, from start points spread evenly round the lap."""
    eval_race_seconds: float = 60.0
    """Cap on the length of the recorded evaluation race [simulated s]."""
    init: str | None = None
    """A policy (shipped name or ``policy.pt``) whose actor weights training starts from
    (fine-tuning; its observations and hidden sizes must be this run's); None starts from
    random weights. The critic always starts fresh."""
    teacher: str | None = None
    """What to imitate with rsl-rl's ``Distillation`` instead of training with PPO: a
    state-observation policy (shipped name or ``policy.pt``) distilled into a camera actor,
    or a scripted driver (``SCRIPTED_TEACHERS``, e.g. ``"racing_line"``) imitated by any
    actor. The student drives (DAgger: it learns on the states its own driving reaches) and is
    regressed onto the teacher's actions there. The fast way to a camera policy on a CPU (no
    critic, one pass per rollout), and a scripted teacher brings what it knows of every track
    (``racing_line`` laps every shipped and generated track) to a state policy before PPO
    fine-tunes it (``init``), as AlphaStar's agents start from supervised learning. None
    trains with PPO."""
    teacher_options: dict[str, float] = field(default_factory=dict)
    """Constructor arguments of the scripted driver that labels actions (a scripted
    ``teacher`` or the ``imitation_driver``), e.g. ``{"grip_factor": 0.6, "margin": 0.2}`` for
    a ``RacingLine`` that corners at 60 % of the grip and keeps 0.2 m from the borders."""
    imitation_driver: str | None = None
    """A scripted driver (``SCRIPTED_TEACHERS``) that PPO's actor is kept near with
    ``imitation_coef``."""
    imitation_coef: float = 0.0
    """Weight of a behaviour-cloning term in PPO (``ImitationPPO``): after each PPO update the
    actor's mean actions in the rollout's states are regressed (MSE, one pass over the
    mini-batches) onto the ``imitation_driver``'s actions in those states, as AlphaStar's
    agents are kept near the supervised policy by a KL term (for Gaussians of equal std, a
    squared distance of the means): reinforcement learning improves on the driver without
    forgetting what it does well. 0 turns it off."""
    validation_tracks: int = 0
    """Procedural runs: held-out random tracks (drawn like the training tracks, from their own
    seed, never trained on) on which every evaluation (``eval_every``) also makes
    ``eval_episodes`` lap attempts each. With any, ``policy.pt`` holds the actor of the
    evaluation with the highest lap completion on them (the later one on ties; the final
    actor is evaluated too) rather than the last actor: one update can cost a policy a corner
    type that the next track does not have."""
    distill: DistillConfig = field(default_factory=DistillConfig)
    """Distillation hyper-parameters (used with ``teacher``)."""
    rules: Literal["training", "race"] = "training"
    """``"training"``: DeepRacer's training rules, an infraction ends the car's episode;
    ``"race"``: race rules, an infraction costs a time penalty (the car is frozen, the clock
    runs) and the car goes on, as in the races a policy is judged in. One lap per episode,
    at most 120 s, either way."""

    def __post_init__(self) -> None:
        if self.rules not in ("training", "race"):
            raise ValueError(f"TrainConfig.rules must be 'training' or 'race', got "
                             f"{self.rules!r}")
        if self.observations not in OBSERVATIONS:
            raise ValueError(f"TrainConfig.observations must be one of {OBSERVATIONS}, got "
                             f"{self.observations!r}")
        if not (isinstance(self.imitation_coef, (int, float)) and self.imitation_coef >= 0):
            raise ValueError(f"TrainConfig.imitation_coef must be a number >= 0, got "
                             f"{self.imitation_coef!r}")
        if self.imitation_driver is not None and self.imitation_driver not in SCRIPTED_TEACHERS:
            raise ValueError(f"TrainConfig.imitation_driver must be one of {SCRIPTED_TEACHERS}, "
                             f"got {self.imitation_driver!r}")
        if self.imitation_coef and (self.imitation_driver is None or self.teacher is not None):
            raise ValueError("TrainConfig.imitation_coef keeps PPO's actor near a scripted "
                             "driver: name it in imitation_driver (and leave teacher unset: a "
                             "teacher replaces PPO by imitation)")
        if self.teacher_options:
            if not self.scripted_teacher and self.imitation_driver is None:
                raise ValueError(f"TrainConfig.teacher_options are arguments of a scripted "
                                 f"teacher or imitation_driver ({', '.join(SCRIPTED_TEACHERS)}), "
                                 f"but teacher is {self.teacher!r}")
            self.expert()
        if not (isinstance(self.validation_tracks, int) and self.validation_tracks >= 0):
            raise ValueError(f"TrainConfig.validation_tracks must be an int >= 0, got "
                             f"{self.validation_tracks!r}")
        if self.validation_tracks and self.track != PROCEDURAL:
            raise ValueError("TrainConfig.validation_tracks are held-out random tracks for "
                             "track='procedural' runs; a fixed track has no held-out tracks")
        if self.validation_tracks and not self.eval_every:
            raise ValueError("TrainConfig.validation_tracks are driven at the evaluations: set "
                             "eval_every > 0 (iterations between them)")
        if self.teacher is not None and self.observations == "state" and not self.scripted_teacher:
            raise ValueError("TrainConfig.teacher distils a state policy into a camera policy: "
                             "set observations to 'camera_only' or 'camera' (a state student "
                             "of a state teacher would only copy it), or imitate a scripted "
                             f"driver ({', '.join(SCRIPTED_TEACHERS)})")
        for name in ("procedural_varying_share", "procedural_reverse_share",
                     "procedural_tight_share"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"TrainConfig.{name} must be in [0, 1], got "
                                 f"{getattr(self, name)!r}")
        fewest, most = self.procedural_chicanes
        if not (isinstance(fewest, int) and isinstance(most, int) and 0 <= fewest <= most):
            raise ValueError(f"TrainConfig.procedural_chicanes must be (fewest, most) ints with "
                             f"0 <= fewest <= most, got {self.procedural_chicanes!r}")
        low, high = self.procedural_length
        if not 5.0 <= low <= high:
            raise ValueError(f"TrainConfig.procedural_length must be (low, high) laps with "
                             f"5 <= low <= high [m], got {self.procedural_length!r}")
        if not 0.4 <= self.procedural_min_radius:
            raise ValueError(f"TrainConfig.procedural_min_radius must be >= 0.4 m (above the "
                             f"narrowest half-width, 0.38 m), got {self.procedural_min_radius!r}")
        if self.num_envs < 1 or self.num_steps_per_env < 1:
            raise ValueError("TrainConfig.num_envs and num_steps_per_env must be >= 1")
        if self.max_std is not None and not (isinstance(self.max_std, (int, float))
                                             and self.max_std > STD_FLOOR):
            raise ValueError(f"TrainConfig.max_std must be None or a number > {STD_FLOOR}, got "
                             f"{self.max_std!r}")
        if not isinstance(self.simtrace_envs, int) or not 0 <= self.simtrace_envs <= min(
                10, self.num_envs):
            raise ValueError(f"TrainConfig.simtrace_envs must be an int in [0, "
                             f"{min(10, self.num_envs)}] (at most 10 and num_envs), got "
                             f"{self.simtrace_envs!r}")
        if self.track == PROCEDURAL and (self.reward_function or self.simtrace_envs):
            raise ValueError("TrainConfig: a DeepRacer reward function or simtrace logs need "
                             "one track; pick a fixed track instead of 'procedural'")
        for name in ("reward_function", "model_metadata"):
            path = getattr(self, name)
            if path is not None and not Path(path).is_file():
                raise ValueError(f"TrainConfig.{name}: {path!r} is not a file; give the path "
                                 f"of your DeepRacer {name.replace('_', ' ')} file")
        if not (isinstance(self.eval_every, int) and self.eval_every >= 0):
            raise ValueError(f"TrainConfig.eval_every must be an int >= 0 (iterations; 0 turns "
                             f"evaluation off), got {self.eval_every!r}")
        if not (isinstance(self.eval_episodes, int) and self.eval_episodes >= 1):
            raise ValueError(f"TrainConfig.eval_episodes must be an int >= 1, got "
                             f"{self.eval_episodes!r}")
        if not (isinstance(self.eval_race_seconds, (int, float)) and self.eval_race_seconds > 0):
            raise ValueError(f"TrainConfig.eval_race_seconds must be > 0 [s], got "
                             f"{self.eval_race_seconds!r}")

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "train config") -> TrainConfig:
        """Build from plain data (a parsed TOML file): top-level keys are this class's fields,
        the tables ``[ppo]``, ``[distill]`` and ``[reward]`` fill ``PPOConfig``,
        ``DistillConfig`` and ``RewardConfig``; unknown keys raise ``ValueError``."""
        nested = {"ppo": PPOConfig, "distill": DistillConfig, "reward": RewardConfig}
        values = dict(data)
        for key, kind in ((None, cls), *nested.items()):
            table = values if key is None else values.get(key, {})
            if key is not None and not isinstance(table, dict):
                raise ValueError(f"{source}: {key!r} must be a table of {kind.__name__} fields, "
                                 f"got {table!r}")
            known = {f.name for f in dataclasses.fields(kind)}
            unknown = sorted(set(table) - known)
            if unknown:
                where = "" if key is None else f"[{key}] "
                raise ValueError(f"{source}: {where}unknown keys {unknown}; allowed keys are "
                                 f"{sorted(known)}")
        # Types first, so that a wrong one is named with its key (not "'<' not supported").
        values = check_fields(cls, values, source)
        for key, kind in nested.items():
            if key in values and isinstance(values[key], dict):
                values[key] = kind(**check_fields(kind, values[key], source, f"[{key}] "))
        try:
            return cls(**values)
        except (TypeError, ValueError) as err:
            raise ValueError(f"{source}: {err}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> TrainConfig:
        """Read a training config file (see ``from_dict``; e.g.
        ``policies/trained/ppo_generalist/imitate.toml``)."""
        try:
            with open(path, "rb") as handle:
                data = tomllib.load(handle)
        except tomllib.TOMLDecodeError as err:
            raise ValueError(f"{path}: not valid TOML: {err}") from None
        return cls.from_dict(data, source=str(path))

    def opponents(self) -> list[str]:
        """The drivers named by ``opponent`` (empty without one)."""
        return [] if self.opponent is None else [n.strip() for n in self.opponent.split(",")]

    @property
    def scripted_teacher(self) -> bool:
        """Whether ``teacher`` names a scripted driver (imitated through the ``expert`` group)."""
        return self.teacher in SCRIPTED_TEACHERS

    def expert(self) -> Any:
        """The scripted driver that labels actions (the env's ``expert`` group): a scripted
        ``teacher``, else the ``imitation_driver``, with ``teacher_options``; or None."""
        name = self.teacher if self.scripted_teacher else self.imitation_driver
        if name is None:
            return None
        from h2h_racing.policies import make_driver

        try:
            return make_driver(name, **self.teacher_options)
        except TypeError as err:
            raise ValueError(f"TrainConfig.teacher_options {self.teacher_options!r} do not fit "
                             f"the {name!r} driver: {err}") from None

    def procedural_track(self, rng: np.random.Generator) -> Track:
        """A random training track drawn from ``rng`` with this run's ``procedural_*``
        settings (``random_training_track``)."""
        return random_training_track(rng, self.procedural_varying_share,
                                     self.procedural_min_radius, self.procedural_length,
                                     self.procedural_reverse_share, self.procedural_chicanes,
                                     self.procedural_tight_share)

    def env_config(self) -> EnvConfig:
        """The env the learners race in: ``rules`` (DeepRacer's training rules by default: an
        infraction ends the car's episode), one lap per episode (``track`` names the first track; a procedural
        run starts on ``speedway`` and moves to random tracks)."""
        race_type = "time_trial" if self.num_cars == 1 else "head_to_head"
        camera = dataclasses.replace(EnvConfig().camera, width=self.camera_size[0],
                                     height=self.camera_size[1])
        track = "speedway" if self.track == PROCEDURAL else self.track
        rules = RaceRules.preset(race_type, "training")
        if self.rules == "race":
            rules = dataclasses.replace(RaceRules.preset(race_type, "race"), laps=rules.laps,
                                        time_limit=rules.time_limit, ranking="total_time",
                                        max_resets_per_lap=None)
        return EnvConfig(track=track, num_cars=self.num_cars, race_type=race_type,
                         rules=rules, reward=self.reward,
                         camera=camera, **self.action_space())

    def action_space(self) -> dict[str, Any]:
        """The ``EnvConfig`` action-space overrides of ``model_metadata`` (empty without)."""
        if self.model_metadata is None:
            return {}
        from h2h_racing.deepracer.metadata import load_action_space

        return load_action_space(self.model_metadata)

    def actor_groups(self) -> list[str]:
        """Observation groups the actor reads (see ``h2h_racing.training.vec_env``)."""
        return {"state": ["policy"], "camera": ["policy", "camera"],
                "camera_only": ["camera", "motion"]}[self.observations]

    def actor_dict(self) -> dict[str, Any]:
        """rsl-rl config of the actor (the student when distilling): an MLP on the state, a CNN
        (then an MLP) with a camera."""
        camera = self.observations != "state"
        init_std = self.distill.student_std if self.teacher is not None else self.init_std
        actor: dict[str, Any] = {
            "class_name": "CNNModel" if camera else "MLPModel",
            "hidden_dims": list(self.hidden_dims), "obs_normalization": True,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": init_std}}
        if self.max_std is not None and self.teacher is None:
            actor["distribution_cfg"]["std_range"] = [STD_FLOOR, float(self.max_std)]
            actor["distribution_cfg"]["init_std"] = min(init_std, float(self.max_std))
        if camera:
            # Three stride-2 convolutions, then flattened (no global pooling: where the lines
            # and cars are in the image is what steers): 64 x 48 -> 8 x 6 x 16 = 768 features.
            actor["cnn_cfg"] = {"output_channels": [16, 32, 16], "kernel_size": [5, 3, 3],
                                "stride": [2, 2, 2], "padding": "zeros"}
        return actor

    def rsl_rl_dict(self, teacher: dict[str, Any] | None = None) -> dict[str, Any]:
        """Return a fresh rsl-rl runner config (rsl-rl mutates what it is given): PPO's for an
        ``OnPolicyRunner``, or with ``teacher`` Distillation's for a ``DistillationRunner``,
        whose teacher model config comes from the teacher's policy dict (``load_teacher``;
        loaded here unless given)."""
        actor = self.actor_dict()
        if self.teacher is not None:
            if self.scripted_teacher:
                teacher_groups = ["expert"]
                teacher_model = {"class_name": "h2h_racing.training.train:ScriptedTeacher"}
            else:
                teacher = teacher if teacher is not None else load_teacher(self)
                teacher_groups = ["policy"]
                teacher_model = {**copy.deepcopy(teacher["actor_cfg"]),
                                 "class_name": "h2h_racing.training.train:ClippedTeacher"}
            return {
                "num_steps_per_env": self.num_steps_per_env,
                "save_interval": 50,
                "obs_groups": {"student": self.actor_groups(), "teacher": teacher_groups},
                "algorithm": {"class_name": "Distillation", "loss_type": "mse",
                              **{k: v for k, v in dataclasses.asdict(self.distill).items()
                                 if k != "student_std"}},
                "student": actor,
                "teacher": teacher_model,
            }
        # The critic reads the privileged state; with the camera and the state vector it also
        # gets the camera (as first built). A camera-only actor's critic needs no CNN: the
        # privileged state holds what the value depends on, at a fraction of the update cost.
        critic: dict[str, Any] = {"class_name": "MLPModel",
                                  "hidden_dims": list(self.hidden_dims), "obs_normalization": True}
        critic_groups = ["critic"]
        if self.observations == "camera":
            critic = {**critic, "class_name": "CNNModel",
                      "cnn_cfg": copy.deepcopy(actor["cnn_cfg"])}
            critic_groups = ["critic", "camera"]
        algorithm: dict[str, Any] = {"class_name": "PPO", "schedule": "adaptive",
                                     **dataclasses.asdict(self.ppo)}
        if self.imitation_coef:
            algorithm.update(class_name="h2h_racing.training.train:ImitationPPO",
                             imitation_coef=float(self.imitation_coef))
        elif self.max_std is not None:
            algorithm["class_name"] = "h2h_racing.training.train:BoundedStdPPO"
        return {
            "num_steps_per_env": self.num_steps_per_env,
            "save_interval": 50,
            "obs_groups": {"actor": self.actor_groups(), "critic": critic_groups},
            "algorithm": algorithm,
            "actor": actor,
            "critic": critic,
        }

    def make_env(self, device: str = "cpu", simtrace: str | Path | None = None) -> RacingVecEnv:
        """Build the VecEnv for this config (logging ``simtrace_envs`` copies to ``simtrace``
        when both are given)."""
        log = None if simtrace is None or not self.simtrace_envs else str(simtrace)
        opponent: Any = self.opponent
        if opponent is not None and "," in opponent:
            names = self.opponents()
            opponent = PoolOpponent(tuple(names[e % len(names)] for e in range(self.num_envs)),
                                    seed=self.seed)
        return RacingVecEnv(self.env_config(), num_envs=self.num_envs, learners=self.learners,
                            opponent=opponent, observations=self.observations,
                            seed=self.seed, device=device, reward_function=self.reward_function,
                            simtrace=log, simtrace_envs=max(self.simtrace_envs, 1),
                            expert=self.expert())


def train(config: TrainConfig, iterations: int, out: str | Path | None = None,
          minutes: float | None = None) -> Any:
    """Train with PPO (or distil ``config.teacher``); return the rsl-rl runner.

    Args:
        config: What to train.
        iterations: PPO iterations (each ``num_envs * num_steps_per_env`` samples).
        out: Folder for rsl-rl's logs and checkpoints, the evaluation recordings
            (``eval/iter_<n>.rrd``, see ``evaluate_during_training``), the final
            ``policy.pt`` and, with ``config.simtrace_envs``, DeepRacer logs in
            ``out/simtrace/<car>``; None keeps nothing on disk and skips the evaluations.
        minutes: Stop after the first iteration that ends past this wall-clock budget.
    """
    from rsl_rl.runners import DistillationRunner, OnPolicyRunner

    torch.manual_seed(config.seed)
    torch.set_num_threads(config.torch_threads)
    env = config.make_env(simtrace=None if out is None else Path(out) / "simtrace")
    log_dir = None if out is None else str(Path(out))
    if config.teacher is None:
        runner = OnPolicyRunner(env, config.rsl_rl_dict(), log_dir=log_dir, device="cpu")
    elif config.scripted_teacher:
        runner = DistillationRunner(env, config.rsl_rl_dict(), log_dir=log_dir, device="cpu")
        runner.alg.teacher_loaded = True  # the env's expert group: no weights to load
    else:
        teacher = load_teacher(config)
        runner = DistillationRunner(env, config.rsl_rl_dict(teacher), log_dir=log_dir,
                                    device="cpu")
        # The teacher is the policy file's actor: same model config, so its weights (and its
        # observation normaliser's statistics) load strictly.
        _load_actor(runner.alg.teacher, teacher, f"teacher {config.teacher!r}")
        runner.alg.teacher_loaded = True
    if config.init is not None:
        load_init(runner, config.init)
    start = time.perf_counter()
    done = 0
    procedural = config.track == PROCEDURAL
    eval_every = config.eval_every if out is not None else 0
    chunk = iterations
    if minutes is not None:
        chunk = 10
    tracks = np.random.default_rng(config.seed + 1)
    validation = validation_tracks(config) if procedural and eval_every else []
    best: tuple[float, int] | None = None  # (validation lap completion, iteration)
    best_payload: dict[str, Any] | None = None
    save_interval = runner.cfg["save_interval"]
    extra: Path | None = None
    while done < iterations:
        # Each learn() call stops where the track changes, an evaluation is due or the time
        # budget is checked.
        step = min(chunk, iterations - done)
        if procedural:
            if done % config.track_every == 0:
                env.set_track(config.procedural_track(tracks))
            step = min(step, config.track_every - done % config.track_every)
        if eval_every:
            step = min(step, eval_every - done % eval_every)
        runner.learn(step)
        # learn() also saves a checkpoint when it returns: keep only the latest of those (and
        # every save_interval one), or a run of short learn() calls fills the disk.
        last = Path(out) / f"model_{runner.current_learning_iteration}.pt" if out else None
        if extra is not None and extra != last:
            extra.unlink(missing_ok=True)
        extra = last if runner.current_learning_iteration % save_interval else None
        # rsl-rl's learn() re-runs the last iteration index on the next call (its G3 gotcha).
        runner.current_learning_iteration += 1
        # Each learn() also opens a new tensorboard event file (and never closes the last):
        # keep the first writer for the whole run.
        runner.logger.init_logging_writer = _keep_writer
        done += step
        over_time = minutes is not None and time.perf_counter() - start > 60.0 * minutes
        last = over_time or done >= iterations
        if eval_every and (done % eval_every == 0 or (validation and last)):
            scalars = evaluate_during_training(runner, config, Path(out),  # type: ignore[arg-type]
                                               done, validation)
            if validation and (best is None or scalars["validation_completion"] >= best[0]):
                best = (scalars["validation_completion"], done)
                best_payload = policy_payload(runner, config)
        if over_time:
            break
    env.close()
    if runner.logger.writer is not None:
        runner.logger.writer.close()
    if out is not None:
        training = {"iterations": done, "seconds": time.perf_counter() - start}
        if best is not None:
            training.update(selected_iteration=best[1], validation_completion=best[0])
            print(f"policy.pt: the actor of iteration {best[1]} (lap completion "
                  f"{100 * best[0]:.1f} % on {len(validation)} held-out random tracks)")
        save_policy(runner, config, Path(out) / "policy.pt", training=training,
                    payload=best_payload)
    return runner


def validation_tracks(config: TrainConfig) -> list[Track]:
    """``config.validation_tracks`` random tracks drawn like a procedural run's training tracks
    but from seed ``config.seed + 2`` (the training tracks come from ``seed + 1``): tracks
    the run never trains on, for choosing among its actors without looking at the shipped
    tracks it is judged on."""
    rng = np.random.default_rng(config.seed + 2)
    return [config.procedural_track(rng) for _ in range(config.validation_tracks)]


def _keep_writer() -> None:
    """Stands in for rsl-rl's ``Logger.init_logging_writer`` after the first ``learn()``."""


def evaluate_during_training(runner: Any, config: TrainConfig, out: str | Path,
                             iteration: int, validation: Sequence[Track] = ()
                             ) -> dict[str, float]:
    """Evaluate the runner's current actor, log the figures and record a race.

    The actor becomes a ``TrainedPolicy`` straight from memory (no file). On the evaluation
    track (``config.env_config().track``; ``speedway`` for procedural runs) it makes
    ``config.eval_episodes`` one-lap attempts (``training.evaluate.evaluate``: training rules,
    start points spread round the lap), then races one lap as car 0 (in race rules) against
    the training opponent, or against itself in self-play, or alone, with the race's grid
    drawn from ``config.seed`` so that every evaluation of a run races the same start. The
    race is recorded to ``<out>/eval/iter_<iteration>.rrd`` when rerun-sdk is installed (a
    warning says so otherwise).

    Figures go to rsl-rl's tensorboard log at step ``iteration`` (iterations completed):
    ``Eval/lap_completion`` (fraction of attempts), ``Eval/mean_lap_time`` and
    ``Eval/best_lap_time`` [s] (only when a lap was completed), ``Eval/off_tracks`` (attempts
    that ended off track) and ``Eval/collisions`` (contacts, over all attempts), and of the
    race ``Eval/race_finished`` (1 or 0) and ``Eval/race_position`` (1 = first). With
    ``validation`` tracks, ``Eval/validation_completion``: the fraction of
    ``config.eval_episodes`` attempts per track completed over all of them.

    Args:
        runner: The rsl-rl ``OnPolicyRunner`` being trained.
        config: Its training config.
        out: The run's output folder.
        iteration: Iterations completed (names the recording and steps the log).
        validation: Held-out tracks (``validation_tracks``).

    Returns:
        The figures, keyed as logged without the ``Eval/`` prefix.
    """
    from h2h_racing.training.evaluate import evaluate
    from h2h_racing.match import run_race
    from h2h_racing.policies.trained import TrainedPolicy

    out = Path(out)
    payload = policy_payload(runner, config, training={"iterations": iteration})
    driver = TrainedPolicy.from_payload(payload, name=f"iter_{iteration}",
                                        source=f"{out} at iteration {iteration}")
    env_config = config.env_config()
    # The evaluation envs give the camera images the actor was trained on (and the recorded
    # reward terms are the ones it was trained with).
    env_fields = {"camera": env_config.camera, "reward": env_config.reward}
    figures = evaluate(driver, env_config.track, episodes=config.eval_episodes,
                       seed=config.seed, **env_fields)
    scalars = {"lap_completion": figures.lap_completion,
               "off_tracks": float(figures.off_tracks), "collisions": float(figures.collisions)}
    if np.isfinite(figures.mean_lap_time):
        scalars["mean_lap_time"] = figures.mean_lap_time
        scalars["best_lap_time"] = figures.best_lap_time
    if validation:
        scalars["validation_completion"] = float(np.mean([
            evaluate(driver, track, episodes=config.eval_episodes, seed=config.seed,
                     **env_fields).lap_completion for track in validation]))

    learners = config.num_cars if config.learners is None else config.learners
    # With several opponents the recorded race is against the first.
    drivers = [driver] * learners + config.opponents()[:1] * (config.num_cars - learners)
    save = None
    if importlib.util.find_spec("rerun") is not None:
        save = out / "eval" / f"iter_{iteration}.rrd"
    else:
        warnings.warn("rerun-sdk is not installed, so the evaluation race is not recorded; "
                      "pip install 'h2h-racing[viz]' to record it", stacklevel=2)
    race = run_race(env_config.track, drivers,
                    race_type="time_trial" if config.num_cars == 1 else "head_to_head",
                    laps=1, seed=config.seed, save=save,
                    max_cycles=max(1, round(config.eval_race_seconds / env_config.step_dt)),
                    **env_fields)
    mine = next(row for row in race.rows if row["agent"] == "car_0")
    scalars["race_finished"] = float(mine["finished"])
    scalars["race_position"] = float(mine["position"])

    writer = runner.logger.writer
    if writer is not None:
        for key, value in scalars.items():
            writer.add_scalar(f"Eval/{key}", value, iteration)
        writer.flush()
    lap = (f"{scalars['mean_lap_time']:.2f} s" if "mean_lap_time" in scalars else "-")
    held_out = (f", {100 * scalars['validation_completion']:.1f} % on {len(validation)} "
                f"held-out tracks" if validation else "")
    print(f"eval at iteration {iteration}: laps {100 * figures.lap_completion:.0f} % of "
          f"{figures.episodes}{held_out}, mean lap {lap}, off track {figures.off_tracks}, race "
          f"position {mine['position']}/{config.num_cars}" + (f" -> {save}" if save else ""))
    return scalars


class ClippedTeacher(MLPModel):  # type: ignore[misc]
    """A distillation teacher: the policy file's MLP actor with its actions clipped to [-1, 1].

    The env clips actions to [-1, 1], so PPO's Gaussian means drift past the bounds at no cost
    (a trained actor's raw steering can read 30 where the env applies 1). Regressing a student
    onto the raw means would spend its loss on those excursions; the clipped actions are what
    the teacher drives.
    """

    def forward(self, *args: Any, **kwargs: Any) -> torch.Tensor:
        return super().forward(*args, **kwargs).clamp(-1.0, 1.0)


class ScriptedTeacher(torch.nn.Module):
    """A distillation teacher that is a scripted driver: it returns the ``expert`` observation
    group (``RacingVecEnv(expert=...)``: the driver's action in the learner's state), so
    rsl-rl's ``Distillation`` regresses the student onto the driver's actions. No weights.

    Built by rsl-rl as ``ScriptedTeacher(obs, obs_groups, "teacher", num_actions)``; the
    ``teacher`` observation set must be exactly ``["expert"]``.
    """

    is_recurrent = False

    def __init__(self, obs: Any, obs_groups: dict[str, list[str]], obs_set: str,
                 output_dim: int, **unused: Any) -> None:
        super().__init__()
        if obs_groups.get(obs_set) != ["expert"] or "expert" not in obs.keys():
            raise ValueError(f"ScriptedTeacher reads the env's 'expert' observation group "
                             f"(RacingVecEnv(expert=...)); got obs_groups[{obs_set!r}] = "
                             f"{obs_groups.get(obs_set)!r} and groups {list(obs.keys())}")
        if obs["expert"].shape[-1] != output_dim:
            raise ValueError(f"the expert group has {obs['expert'].shape[-1]} actions, the "
                             f"student {output_dim}")

    def forward(self, obs: Any, *args: Any, **kwargs: Any) -> torch.Tensor:
        return obs["expert"]

    def reset(self, dones: Any = None, hidden_state: Any = None) -> None:
        """Stateless (rsl-rl resets recurrent models through this)."""

    def get_hidden_state(self) -> None:
        return None

    def detach_hidden_state(self, dones: Any = None) -> None:
        """Stateless."""


class BoundedStdPPO(PPO):  # type: ignore[misc]
    """rsl-rl's PPO, with the actor's standard deviation projected into its distribution's
    ``std_range`` after every update (``TrainConfig.max_std``).

    rsl-rl's ``GaussianDistribution`` clamps the std it samples with, but not the parameter:
    the gradient is zero past the clamp, so a parameter that steps over the bound stays there
    (Adam's momentum carries it further) and the std can never shrink again. Projecting the
    parameter back keeps it on the bound, where the gradient flows.
    """

    def update(self) -> dict[str, float]:
        losses = super().update()
        project_std(self.get_policy())
        return losses


class ImitationPPO(BoundedStdPPO):
    """rsl-rl's PPO (with ``BoundedStdPPO``'s std projection) plus a behaviour-cloning step
    (``TrainConfig.imitation_coef``): after each PPO update, one pass over the rollout in
    ``num_mini_batches`` mini-batches of the loss ``imitation_coef * mean((mu(o) - a*)^2)``,
    where ``mu(o)`` is the actor's mean action and ``a*`` the scripted driver's action in the
    same state (the ``expert`` observation group the env adds). With equal standard
    deviations sigma, KL(N(a*, sigma) || N(mu, sigma)) = |mu - a*|^2 / (2 sigma^2), so this is
    AlphaStar's KL to a fixed teacher up to scale. It uses PPO's optimizer and learning rate
    (critic gradients stay None, so Adam leaves the critic alone).
    """

    def __init__(self, *args: Any, imitation_coef: float = 0.0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.imitation_coef = imitation_coef

    def update(self) -> dict[str, float]:
        losses = super().update()
        losses["imitation"] = self.imitate()
        project_std(self.get_policy())
        return losses

    def imitate(self) -> float:
        """One behaviour-cloning pass over the last rollout; return its mean loss."""
        if self.imitation_coef == 0:
            return 0.0  # a step on a zero loss would still move the weights (Adam's momentum)
        # storage.clear() (at the end of PPO's update) only rewinds the write cursor: the
        # rollout's observations are still there.
        obs = self.storage.observations.flatten(0, 1)
        if "expert" not in obs.keys():
            raise ValueError("ImitationPPO needs the env's 'expert' observation group "
                             "(RacingVecEnv(expert=...); TrainConfig.imitation_driver)")
        actor = self.get_policy()
        rows = obs.batch_size[0]
        size = max(1, rows // self.num_mini_batches)
        order = torch.randperm(rows, device=self.device)
        total = 0.0
        for start in range(0, size * self.num_mini_batches, size):
            batch = obs[order[start:start + size]]
            loss = self.imitation_coef * (actor(batch) - batch["expert"]).pow(2).mean()
            self.optimizer.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(actor.parameters(), self.max_grad_norm)
            self.optimizer.step()
            total += loss.item()
        return total / self.num_mini_batches


def project_std(actor: Any) -> None:
    """Clamp ``actor``'s Gaussian std parameter into its distribution's ``std_range``."""
    dist = getattr(actor, "distribution", None)
    if not isinstance(dist, GaussianDistribution):
        return
    with torch.no_grad():
        if dist.std_type == "scalar":
            dist.std_param.clamp_(*dist.std_range)
        else:
            dist.log_std_param.clamp_(*dist.log_std_range)


def load_init(runner: Any, init: str) -> None:
    """Load the actor weights of policy ``init`` (shipped name or path) into ``runner``'s
    actor (the student when distilling), its std projected into this run's range (an init
    trained without ``max_std`` may have a std of 10).

    Raises:
        FileNotFoundError, ValueError: ``init`` is not a policy, or its actor does not fit.
    """
    from h2h_racing.policies.trained import load_policy_payload

    payload = load_policy_payload(init)
    _load_actor(runner.alg.get_policy(), payload, f"init policy {init!r}")
    project_std(runner.alg.get_policy())


def _load_actor(model: Any, payload: dict[str, Any], what: str) -> None:
    """Load policy dict ``payload``'s actor weights into ``model`` (strictly), or raise a
    ``ValueError`` that says ``what`` does not fit and which tensors differ."""
    try:
        model.load_state_dict(payload["actor_state_dict"])
    except (RuntimeError, TypeError, ValueError) as err:
        raise ValueError(f"{what} does not fit the actor being trained (hidden sizes or "
                         f"observations differ): {' '.join(str(err).split())}") from None


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


def load_teacher(config: TrainConfig) -> dict[str, Any]:
    """Load ``config.teacher``'s policy dict and check that it can teach in ``config``'s env: a
    state-observation policy whose state vector has this env's layout.

    Raises:
        FileNotFoundError, ValueError: With what is wrong and what to do.
    """
    from h2h_racing.policies.trained import load_policy_payload

    payload = load_policy_payload(config.teacher)  # type: ignore[arg-type]
    if payload["observations"] != "state":
        raise ValueError(f"teacher {config.teacher!r} drives from {payload['observations']!r} "
                         "observations; a teacher must be a state-observation policy")
    env = config.env_config()
    for key in ("opponent_slots", "obstacle_slots"):
        if payload["env_config"][key] != getattr(env, key):
            raise ValueError(f"teacher {config.teacher!r} was trained with {key}="
                             f"{payload['env_config'][key]}, this run's env has {key}="
                             f"{getattr(env, key)}: its state vector would not fit")
    return payload


def random_training_track(rng: np.random.Generator, varying_share: float = 0.0,
                          min_radius: float = 0.6,
                          length: tuple[float, float] = (20.0, 45.0),
                          reverse_share: float = 0.0,
                          chicanes: tuple[int, int] = (0, 0),
                          tight_share: float = 0.0) -> Track:
    """A random closed track for training: lap length drawn in ``length`` [m], width in the
    catalogue's range [0.76, 1.07] m: constant (drawn uniformly) or, on a ``varying_share`` of
    the tracks, varying along the lap between two widths drawn in that range (sorted); corners
    down to ``min_radius`` [m], or 1.2 x the widest half-width if that is larger
    (``random_track``), with a number of chicanes drawn in ``chicanes``; on a
    ``reverse_share`` of the tracks driven clockwise (its name then ends in ``-cw``).

    A ``tight_share`` of the tracks are instead short, narrow and twisty, as ``technical`` is:
    lap ``TIGHT_LENGTH``, constant width ``TIGHT_WIDTH``, control-point radii down to 0.3 of
    the loop's size (deep bays: tight right-handers between left-handers), corners down to
    ``min_radius``, 1-3 chicanes; 5-20 % of their lap is in corners under 1 m radius, against
    0-5 % for the other tracks (``technical``: 40 %)."""
    # No draw without the option: the same seed gives the same tracks as before it.
    if tight_share > 0 and rng.random() < tight_share:
        width: float | tuple[float, float] = float(rng.uniform(*TIGHT_WIDTH))
        # About 1 in 12 calls of random_track finds no valid loop of this kind in its 100
        # tries; the next call (same generator, new draws) almost always does.
        for attempt in range(5):
            try:
                spec = random_track(rng, length_range=TIGHT_LENGTH, width=width,
                                    min_radius=max(min_radius, 0.6 * width),
                                    radius_range=(0.3, 1.0), chicanes=(1, 3))
                break
            except RuntimeError:
                if attempt == 4:
                    raise
        return _maybe_reversed(rng, spec, reverse_share)
    width = float(rng.uniform(0.76, 1.07))
    # No draw without varying widths: the same seed gives the same tracks as before the option.
    if varying_share > 0 and rng.random() < varying_share:
        width = (min(width, w := float(rng.uniform(0.76, 1.07))), max(width, w))
    widest = width if isinstance(width, float) else width[1]
    spec = random_track(rng, length_range=length, width=width,
                        min_radius=max(min_radius, 0.6 * widest), chicanes=chicanes)
    return _maybe_reversed(rng, spec, reverse_share)


TIGHT_LENGTH = (14.0, 22.0)
"""Lap-length range of ``random_training_track``'s tight tracks [m] (``technical``: 20 m)."""
TIGHT_WIDTH = (0.76, 0.9)
"""Width range of the tight tracks [m] (``technical``: 0.76 m)."""


def _maybe_reversed(rng: np.random.Generator, spec: Any, reverse_share: float) -> Track:
    """``spec`` as a ``Track``, on a ``reverse_share`` of draws driven clockwise."""
    track = Track(spec.centre, spec.width_left, spec.width_right, name=spec.name,
                  description=spec.description, source="training.train.random_training_track")
    # As above: no draw without reversing, so that older settings give the same tracks.
    if reverse_share > 0 and rng.random() < reverse_share:
        track = track.reversed()
        track = Track(track.centre, track.width_left, track.width_right,
                      name=f"{spec.name}-cw", description=f"{spec.description} Driven clockwise.",
                      source=track.source)
    return track


def policy_payload(runner: Any, config: TrainConfig,
                   training: dict[str, float] | None = None) -> dict[str, Any]:
    """The policy dict of ``runner``'s actor: weights (copied, so later training does not
    change them), the actor's config and the configs it was trained with. It holds only
    tensors and plain Python values (see ``save_policy``; ``TrainedPolicy.from_payload``
    drives with it directly)."""
    return {
        "format": POLICY_FORMAT,
        "actor_state_dict": {key: value.detach().clone()
                             for key, value in runner.alg.get_policy().state_dict().items()},
        "actor_cfg": config.actor_dict(),
        "obs_groups": config.actor_groups(),
        "observations": config.observations,
        "env_config": _plain(config.env_config().to_dict()),
        "train_config": _plain(dataclasses.asdict(config)),
        "training": dict(training or {}),
    }


def save_policy(runner: Any, config: TrainConfig, path: str | Path,
                training: dict[str, float] | None = None,
                payload: dict[str, Any] | None = None) -> Path:
    """Write the actor of ``runner`` (or the earlier actor of ``payload``, a ``policy_payload``)
    and the configs it was trained with to ``path``, with ``training`` figures.

    The file holds only tensors and plain Python values, so it loads with
    ``torch.load(path, weights_only=True)``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if payload is None:
        payload = policy_payload(runner, config, training)
    else:
        payload = {**payload, "training": dict(training or {})}
    torch.save(payload, path)
    return path


def _plain(value: Any) -> Any:
    """Tuples to lists, recursively, so that the dict is plain JSON-like data."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value
