"""Upper bounds on the sizes a training or league config may ask for, and their checks.

Each bound is far above every recipe shipped or recorded (256-512 env copies, 8-64 steps,
two hidden layers of 128-512), and low enough that what it allows fits a machine of the
project's (23 GiB on the workstations, 128 GiB on the GPU machines). Past them a config got a
raw allocation traceback (``Unable to allocate 7.45 GiB``) or took gigabytes before failing.
"""

from __future__ import annotations

from typing import Any

MAX_NUM_ENVS = 4096
"""Most env copies a learner runs (``num_envs``): each copy holds its own physics space, cars
and sensors, about 1-3 MB."""
MAX_STEPS_PER_ENV = 1024
"""Longest rollout per PPO iteration [steps] (``num_steps_per_env``; rsl-rl's recipes use 24-64)."""
MAX_ROLLOUT_BYTES = 4 * 2**30
"""Largest rollout storage: ``num_envs * num_steps_per_env`` transitions of float32
observations (4 GiB; rsl-rl keeps the actor's and the critic's, and PPO's mini-batches copy them)."""
STATE_VALUES = 512
"""Values a transition's state observation, action, reward and value are counted as, an upper
estimate (33 by default; 19 + 4 x 27 + 3 x 32 = 223 with every slot)."""
MAX_HIDDEN_LAYERS = 8
"""Most hidden layers of an actor or critic MLP (``hidden_dims``)."""
MAX_HIDDEN_WIDTH = 4096
"""Widest hidden layer: a 4096 x 4096 layer is 64 MiB of float32 weights, and Adam keeps two
more copies; 8 of them in the actor and the critic are about 3 GiB."""


def check_count(value: Any, where: str, name: str, most: int) -> None:
    """Raise ``ValueError`` unless ``value`` is an int in [1, ``most``], naming ``where`` and ``name``."""
    if not (isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= most):
        raise ValueError(f"{where} {name} must be an int in [1, {most}], got {value!r} "
                         f"(h2h_racing.training.limits bounds it by what a machine holds)")


def check_hidden_dims(dims: Any, where: str) -> None:
    """Raise ``ValueError`` unless ``dims`` is 1 to ``MAX_HIDDEN_LAYERS`` ints in
    [1, ``MAX_HIDDEN_WIDTH``], before any network is built from them.

    >>> check_hidden_dims([128, 128], "TrainConfig")
    >>> check_hidden_dims([60000, 60000], "policy.pt: actor_cfg")
    Traceback (most recent call last):
    ...
    ValueError: policy.pt: actor_cfg hidden_dims must be 1 to 8 layer sizes, each an int in [1, 4096], got [60000, 60000] (a 4096 x 4096 layer is 64 MiB of weights)
    """
    ok = (isinstance(dims, (list, tuple)) and 1 <= len(dims) <= MAX_HIDDEN_LAYERS
          and all(isinstance(d, int) and not isinstance(d, bool) and 1 <= d <= MAX_HIDDEN_WIDTH
                  for d in dims))
    if not ok:
        shown = repr(dims if not isinstance(dims, (list, tuple)) else list(dims))
        if isinstance(dims, (list, tuple)) and len(dims) > 12:
            shown = f"a list of {len(dims)} values"
        raise ValueError(f"{where} hidden_dims must be 1 to {MAX_HIDDEN_LAYERS} layer sizes, each "
                         f"an int in [1, {MAX_HIDDEN_WIDTH}], got {shown} (a {MAX_HIDDEN_WIDTH} x "
                         f"{MAX_HIDDEN_WIDTH} layer is 64 MiB of weights)")


def check_rollout(num_envs: int, num_steps_per_env: int, obs_values: int, where: str) -> None:
    """Raise ``ValueError`` when the rollout storage would pass ``MAX_ROLLOUT_BYTES``.

    Args:
        num_envs: Env copies.
        num_steps_per_env: Steps per copy and iteration.
        obs_values: Camera values of one transition (0 without a camera); ``STATE_VALUES``
            is added for the rest.
        where: What the error names (``TrainConfig``, ``[training]``).
    """
    size = num_envs * num_steps_per_env * (obs_values + STATE_VALUES) * 4
    if size > MAX_ROLLOUT_BYTES:
        raise ValueError(
            f"{where}: num_envs * num_steps_per_env = {num_envs} * {num_steps_per_env} transitions "
            f"of {obs_values + STATE_VALUES} float32 values need {size / 2**30:.1f} GiB of rollout "
            f"storage; at most {MAX_ROLLOUT_BYTES // 2**30} GiB is allowed "
            f"(h2h_racing.training.limits.MAX_ROLLOUT_BYTES): use fewer copies, steps or camera pixels")
