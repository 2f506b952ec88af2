"""The frozen, validated configs (``EnvConfig``, ``RewardConfig``, ``CarParams``, ``RaceRules``,
``CameraConfig``, ``LidarConfig``) and the config files shipped by name.

The names of the old ``h2h_racing.config`` module are here too (from ``env``, imported
when first used).
"""

from __future__ import annotations

from h2h_racing.common.faces import lazy_face

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

__getattr__, __dir__ = lazy_face(__name__, "h2h_racing.config.env", __all__, globals())
