"""What people see: spectator frames (``render``, which the env's render mode uses), rerun
recordings (``recorder``, the only rerun importer, lazily), their per-car streams, event
lines and the web viewer's server.

The names of the old ``h2h_racing.viz`` module are here too (from ``recorder``, imported
when first used).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "APPLICATION_ID",
    "CarStreams",
    "EVENT_KINDS",
    "EVENT_LEVELS",
    "INSTALL_HINT",
    "METRICS",
    "OBSTACLE_COLOUR",
    "REWARD_TERMS",
    "RaceRecorder",
    "RecordingEnv",
    "TRACK_COLOURS",
    "TRAJECTORY_PIECE",
    "car_colour",
    "check_ports_free",
    "has_display",
    "import_rerun",
    "install_hint",
    "missing_extra",
    "rerun_binary",
    "start_native_viewer",
    "start_viewer_server",
    "step_event_lines",
    "stop_viewer_server",
]


def __getattr__(name: str) -> Any:
    # Lazily, so that importing one submodule does not import the face module's dependencies.
    if name in __all__:
        return getattr(importlib.import_module("h2h_racing.viz.recorder"), name)
    raise AttributeError(f"module 'h2h_racing.viz' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
