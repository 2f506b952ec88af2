"""Tracks: the ``Track`` shape, its geometry, projection grid and lookup tables, file formats,
generators and metrics. It imports only ``common``.

The names of the old ``h2h_racing.track`` module are here too (from ``shape``, imported
when first used).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "BLEND_HALF_WIDTH",
    "BORDER_TOLERANCE",
    "CAR_WIDTH",
    "FloatArray",
    "IntArray",
    "MAX_TRACK_VERTICES",
    "MIN_TOTAL_WIDTH",
    "Projector",
    "Track",
    "project_kernel",
]


def __getattr__(name: str) -> Any:
    # Lazily, so that importing one submodule does not import the face module's dependencies.
    if name in __all__:
        return getattr(importlib.import_module("h2h_racing.track.shape"), name)
    raise AttributeError(f"module 'h2h_racing.track' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
