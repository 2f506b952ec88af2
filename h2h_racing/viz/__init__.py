"""What people see: spectator frames (``render``, which the env's render mode uses), rerun
recordings (``recorder``, the only rerun importer, lazily), their per-car streams, event
lines and the web viewer's server.

The names of the old ``h2h_racing.viz`` module are here too (from ``recorder``, imported
when first used).
"""

from __future__ import annotations

from h2h_racing.common.faces import lazy_face

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

__getattr__, __dir__ = lazy_face(__name__, "h2h_racing.viz.recorder", __all__, globals())
