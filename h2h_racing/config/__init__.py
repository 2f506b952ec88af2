"""The frozen, validated configs (``EnvConfig``, ``RewardConfig``, ``CarParams``, ``RaceRules``,
``CameraConfig``, ``LidarConfig``) and the config files shipped by name.

The names of the old ``h2h_racing.config`` module are here too (from ``env``, imported
when first used).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "DEFAULT_DISCRETE_ACTIONS",
    "LIDAR_MAX_RANGE",
    "MAX_BOTS",
    "RACE_TYPES",
    "RULE_MODES",
    "SENSORS",
    "ActionType",
    "CameraConfig",
    "CarParams",
    "EnvConfig",
    "LidarConfig",
    "RaceRules",
    "RaceType",
    "Ranking",
    "RewardConfig",
    "RuleMode",
]


def __getattr__(name: str) -> Any:
    # Lazily, so that importing one submodule does not import the face module's dependencies.
    if name in __all__:
        return getattr(importlib.import_module("h2h_racing.config.env"), name)
    raise AttributeError(f"module 'h2h_racing.config' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
