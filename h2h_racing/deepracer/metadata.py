"""Read DeepRacer's ``model_metadata.json`` into ``EnvConfig`` overrides.

Schema (simapp ``boto/s3/files/model_metadata.py``): ``action_space`` (required) is a list
of ``{"steering_angle": deg, "speed": m/s[, "index": i]}`` (discrete) or
``{"steering_angle": {"low", "high"}, "speed": {"low", "high"}}`` (continuous);
``action_space_type`` ``"discrete"`` (default) or ``"continuous"``; ``sensor`` a list with
one camera and at most one lidar; ``lidar_config`` ``{num_sectors, num_values_per_sector,
clipping_dist}``. Values are clipped to DeepRacer's actuator limits (``agent_ctrl/constants.py``:
``MAX_ANGLE = 30`` deg, ``MIN_SPEED = 0.1``, ``MAX_SPEED = 4`` m/s), with a warning.

DeepRacer reads ``lidar_config`` only for ``DISCRETIZED_SECTOR_LIDAR`` (``sensors/utils.py``);
``LIDAR`` and ``SECTOR_LIDAR`` keep their fixed settings (64 ranges clipped to 1 m; 8 sectors
that read 1 nearer than 0.5 m). This reader does the same, so an observation matches the one
the model was trained on: a ``lidar_config`` is ignored with a warning that names its keys.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.config.env import CameraConfig, LidarConfig
from h2h_racing.common.json_files import read_json_file, short_repr

FloatArrayLike = npt.NDArray[np.float64]

MAX_STEER_DEG = 30.0
"""DeepRacer's steering limit [deg]."""
MIN_SPEED = 0.1
"""DeepRacer's lowest actuated speed [m/s]."""
MAX_SPEED = 4.0
"""DeepRacer's highest actuated speed [m/s]."""

CAMERAS = ("FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LEFT_CAMERA", "observation")
LIDARS = ("LIDAR", "SECTOR_LIDAR", "DISCRETIZED_SECTOR_LIDAR")
_FIXED_LIDAR = {
    "LIDAR": "LIDAR gives its 64 ranges clipped to 1.0 m",
    "SECTOR_LIDAR": "SECTOR_LIDAR gives 8 sectors that read 1 nearer than 0.5 m",
    None: "'sensor' names no lidar",
}


def _fail(path: Path, key: str, expected: str, got: Any) -> ValueError:
    return ValueError(f"{path}: {key} must be {expected}, got {short_repr(got)}; fix "
                      f"model_metadata.json "
                      f"(see DeepRacer's schema in h2h_racing.deepracer.metadata)")


def _number(path: Path, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(path, key, "a finite number", value)
    try:
        number = float(value)  # an int of 400 digits overflows a float
    except OverflowError:
        number = math.inf
    if not math.isfinite(number):
        raise _fail(path, key, "a finite number", value)
    return number


def _clip(path: Path, key: str, value: float, low: float, high: float) -> float:
    clipped = min(max(value, low), high)
    if clipped != value:
        warnings.warn(f"{path}: {key} = {value:g} is outside DeepRacer's actuator limits "
                      f"[{low:g}, {high:g}]; clipped to {clipped:g}", UserWarning, stacklevel=3)
    return clipped


def load_model_metadata(path: str | Path) -> dict[str, Any]:
    """Return ``EnvConfig`` overrides for a DeepRacer ``model_metadata.json``.

    Args:
        path: The JSON file.

    Returns:
        A dict for ``parallel_env(**overrides)`` / ``dataclasses.replace(config, **overrides)``
        with ``action_type`` and either ``discrete_actions`` ((steering deg, speed m/s) in
        the file's order, or by ``index`` when every action has one) or ``min_speed``,
        ``max_speed``, ``min_steer_deg``, ``max_steer_deg``; plus ``sensors`` (camera ->
        ``"camera"``, lidars -> ``"lidar"``), and ``camera`` / ``lidar`` configs where the
        sensor needs one (stereo cameras, sector lidar).

    Raises:
        ValueError: Unreadable JSON or a bad key, naming the file and the key.
    """
    path = Path(path)
    data = read_json_file(path, "model metadata (a JSON object with an 'action_space')")
    if not isinstance(data, dict):
        raise _fail(path, "the file", "a JSON object", type(data).__name__)
    if "action_space" not in data:
        raise _fail(path, "'action_space'", "present (a list or a dict)", None)
    space = data["action_space"]
    kind = data.get("action_space_type", "discrete")
    if kind not in ("discrete", "continuous"):
        raise _fail(path, "'action_space_type'", "'discrete' or 'continuous'", kind)
    algorithm = data.get("training_algorithm", "clipped_ppo")
    if algorithm not in ("clipped_ppo", "sac"):
        raise _fail(path, "'training_algorithm'", "'clipped_ppo' or 'sac'", algorithm)
    if algorithm == "sac" and kind != "continuous":
        raise _fail(path, "'action_space_type'", "'continuous' with training_algorithm 'sac'",
                    kind)
    overrides: dict[str, Any] = {"action_type": kind}
    if kind == "discrete":
        overrides["discrete_actions"] = _discrete(path, space)
    else:
        overrides.update(_continuous(path, space))
    overrides.update(_sensors(path, data.get("sensor", ["FRONT_FACING_CAMERA"]),
                              data.get("lidar_config")))
    return overrides


def _discrete(path: Path, space: Any) -> tuple[tuple[float, float], ...]:
    if not isinstance(space, list) or not space:
        raise _fail(path, "'action_space'", "a non-empty list of {steering_angle, speed} for "
                    "a discrete action space", space)
    actions = []
    indices = []
    for i, item in enumerate(space):
        key = f"action_space[{i}]"
        if not isinstance(item, dict) or "steering_angle" not in item or "speed" not in item:
            raise _fail(path, key, "an object with 'steering_angle' and 'speed'", item)
        steer = _clip(path, f"{key}.steering_angle",
                      _number(path, f"{key}.steering_angle", item["steering_angle"]),
                      -MAX_STEER_DEG, MAX_STEER_DEG)
        speed = _clip(path, f"{key}.speed", _number(path, f"{key}.speed", item["speed"]),
                      MIN_SPEED, MAX_SPEED)
        actions.append((steer, speed))
        indices.append(item.get("index"))
    if all(isinstance(i, int) for i in indices):
        if sorted(indices) != list(range(len(actions))):
            raise _fail(path, "'action_space[*].index'", f"a permutation of 0..{len(actions) - 1}",
                        indices)
        actions = [a for _, a in sorted(zip(indices, actions))]
    return tuple(actions)


def _range(path: Path, space: dict[str, Any], name: str) -> tuple[float, float]:
    item = space.get(name)
    if not isinstance(item, dict) or "low" not in item or "high" not in item:
        raise _fail(path, f"'action_space.{name}'", "an object with 'low' and 'high'", item)
    return (_number(path, f"action_space.{name}.low", item["low"]),
            _number(path, f"action_space.{name}.high", item["high"]))


def _continuous(path: Path, space: Any) -> dict[str, float]:
    if not isinstance(space, dict):
        raise _fail(path, "'action_space'", "an object {steering_angle: {low, high}, speed: "
                    "{low, high}} for a continuous action space", space)
    steer_low, steer_high = _range(path, space, "steering_angle")
    speed_low, speed_high = _range(path, space, "speed")
    steer_low = _clip(path, "action_space.steering_angle.low", steer_low, -MAX_STEER_DEG,
                      MAX_STEER_DEG)
    steer_high = _clip(path, "action_space.steering_angle.high", steer_high, -MAX_STEER_DEG,
                       MAX_STEER_DEG)
    speed_low = _clip(path, "action_space.speed.low", speed_low, MIN_SPEED, MAX_SPEED)
    speed_high = _clip(path, "action_space.speed.high", speed_high, MIN_SPEED, MAX_SPEED)
    if not steer_low < steer_high:
        raise _fail(path, "'action_space.steering_angle'", "low < high", (steer_low, steer_high))
    if not speed_low < speed_high:
        raise _fail(path, "'action_space.speed'", "low < high", (speed_low, speed_high))
    return {"min_steer_deg": steer_low, "max_steer_deg": steer_high,
            "min_speed": speed_low, "max_speed": speed_high}


def _sensors(path: Path, sensor: Any, lidar_config: Any) -> dict[str, Any]:
    if not isinstance(sensor, list) or not all(isinstance(s, str) for s in sensor):
        raise _fail(path, "'sensor'", "a list of sensor names", sensor)
    cameras = [s for s in sensor if s in CAMERAS]
    lidars = [s for s in sensor if s in LIDARS]
    unknown = [s for s in sensor if s not in CAMERAS + LIDARS]
    if unknown:
        raise _fail(path, "'sensor'", f"names from {CAMERAS + LIDARS}", unknown)
    if len(cameras) != 1 or len(lidars) > 1:
        raise _fail(path, "'sensor'", "exactly one camera and at most one lidar", sensor)
    lidar = lidars[0] if lidars else None
    if lidar_config is not None and lidar in _FIXED_LIDAR:
        _ignore_lidar_config(path, lidar_config, lidar)
    out: dict[str, Any] = {"sensors": ("camera", "lidar") if lidars else ("camera",)}
    if cameras[0] == "STEREO_CAMERAS":
        out["camera"] = CameraConfig(stereo=True)
    if not lidars:
        return out
    if lidars[0] == "LIDAR":
        out["lidar"] = LidarConfig()
    elif lidars[0] == "SECTOR_LIDAR":
        out["lidar"] = LidarConfig(mode="sector_lidar")
    else:
        raise _fail(path, "'sensor'", "a supported lidar ('LIDAR' or 'SECTOR_LIDAR'; "
                    "DISCRETIZED_SECTOR_LIDAR's one-hot encoding is not implemented yet)",
                    lidars[0])
    return out


def _ignore_lidar_config(path: Path, config: Any, lidar: str | None) -> None:
    """Warn that ``lidar_config`` is ignored, naming its keys (its values are not checked:
    a field nobody reads must not stop a file from loading)."""
    if not isinstance(config, dict):
        raise _fail(path, "'lidar_config'", "an object {num_sectors, num_values_per_sector, "
                    "clipping_dist}", config)
    if config:
        warnings.warn(f"{path}: lidar_config {short_repr(config)} is ignored "
                      f"(keys {short_repr(sorted(config))}): "
                      f"DeepRacer reads it only for DISCRETIZED_SECTOR_LIDAR, which h2h-racing "
                      f"does not implement, and {_FIXED_LIDAR[lidar]}, as in DeepRacer",
                      UserWarning, stacklevel=4)


def discrete_table(config: Any) -> tuple[FloatArrayLike, FloatArrayLike]:
    """The discrete actions of ``config`` as (steering [deg], speed [m/s]) arrays, shape (K,)."""
    table = np.asarray(config.discrete_actions, dtype=np.float64).reshape(-1, 2)
    return table[:, 0], table[:, 1]


def nearest_discrete(config: Any, actions: Any) -> Any:
    """Map continuous actions in [-1, 1]^2 to the nearest of ``config``'s discrete actions.

    Policies with a Gaussian head (rsl-rl's) output ``(steer, speed)`` in [-1, 1]; for a
    DeepRacer discrete action space the box [-1, 1]^2 stands for the table's own box
    [min steering, max steering] x [min speed, max speed], and the action taken is the table
    row nearest to the output in those normalised units (clipped to [-1, 1] first):

        u_k = 2 (steer_k - steer_min) / (steer_max - steer_min) - 1   (0 when all equal)
        v_k = 2 (speed_k - speed_min) / (speed_max - speed_min) - 1
        index = argmin_k (a0 - u_k)^2 + (a1 - v_k)^2   (the first on ties)

    Args:
        config: An ``EnvConfig`` with ``discrete_actions``.
        actions: Continuous actions, shape (..., 2).

    Returns:
        Indices into ``config.discrete_actions``, shape (...), int64.
    """
    steer, speed = discrete_table(config)
    points = np.stack([_unit(steer), _unit(speed)], axis=1)  # (K, 2)
    a = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
    d2 = ((a[..., None, :] - points) ** 2).sum(axis=-1)
    return np.argmin(d2, axis=-1)


def _unit(values: Any) -> Any:
    low, high = float(values.min()), float(values.max())
    if high == low:
        return np.zeros_like(values)
    return 2.0 * (values - low) / (high - low) - 1.0


ACTION_KEYS = ("action_type", "discrete_actions", "min_speed", "max_speed", "min_steer_deg",
               "max_steer_deg")
"""The ``EnvConfig`` fields that make up an action space."""


def load_action_space(path: str | Path) -> dict[str, Any]:
    """Only the action-space overrides of ``load_model_metadata(path)`` (``ACTION_KEYS``), for
    training and racing with the metadata's actions while choosing observations separately."""
    return {k: v for k, v in load_model_metadata(path).items() if k in ACTION_KEYS}
