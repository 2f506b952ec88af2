"""Tracks: the ``Track`` shape, its geometry, projection grid and lookup tables, file formats,
generators and metrics. It imports only ``common``.

The names of the old ``h2h_racing.track`` module are here too (from ``shape``, imported
when first used).
"""

from __future__ import annotations

from h2h_racing.common.faces import lazy_face

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

__getattr__, __dir__ = lazy_face(__name__, "h2h_racing.track.shape", __all__, globals())
