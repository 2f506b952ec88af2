"""Uniform tables of a track's fields along the centre line, for compiled kernels.

The simulation core's compiled kernels (state observation, race rules) need the track's
heading, curvature and widths at arbitrary arc positions many times per step. ``Track``
evaluates them exactly (piecewise-linear interpolation over its vertices); this module
samples those same functions once on a uniform grid of step ``ds`` (2 cm by default), so a
kernel evaluates a field with one multiply and one linear interpolation. The tables are
derived from ``Track``'s own methods, so the geometry has one source of truth; the
resampling error is below 1e-4 of the field's range for the shipped tracks.

The tables hold at most ``MAX_SAMPLES`` samples each (8 MiB a table, 64 MiB in all): a lap
longer than ``MAX_SAMPLES * ds`` (21 km at 2 cm, longer than any real circuit) is sampled
more coarsely instead, so no track (a route file in millimetres makes a lap of thousands of
km) can make the tables outgrow memory.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from numba import njit

if TYPE_CHECKING:
    from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]

DEFAULT_DS = 0.02
"""Default table spacing along the centre line [m]."""
MAX_SAMPLES = 1 << 20
"""Most samples per table; longer laps get a coarser spacing than the one asked for."""


@dataclass(frozen=True, eq=False)
class TrackLookup:
    """Fields of a track sampled at ``s_k = k * ds`` for k = 0..K (``K * ds == length``).

    Attributes:
        length: Lap length L [m].
        inv_ds: 1 / ds [1/m].
        heading: Unwrapped heading, shape (K + 1,) [rad] (``heading[K] = heading[0] +- 2 pi``).
        curvature: Signed curvature, shape (K + 1,) [1/m].
        width_left: Centre-to-left-border distance, shape (K + 1,) [m].
        width_right: Centre-to-right-border distance, shape (K + 1,) [m].
        x: Centre-line x coordinate, shape (K + 1,) [m] (``track.point_at(s)``).
        y: Centre-line y coordinate, shape (K + 1,) [m].
    """

    length: float
    inv_ds: float
    heading: FloatArray
    curvature: FloatArray
    width_left: FloatArray
    width_right: FloatArray
    x: FloatArray
    y: FloatArray

    @classmethod
    def from_track(cls, track: Track, ds: float = DEFAULT_DS) -> TrackLookup:
        """Sample ``track``'s fields every ``ds`` metres (rounded so that K * ds = L), or in
        ``MAX_SAMPLES`` samples where that spacing would need more."""
        count = min(MAX_SAMPLES, max(8, int(math.ceil(track.length / ds))))
        s = np.linspace(0.0, track.length, count + 1)
        heading = np.unwrap(track.heading_at(s))
        left, right = track.half_widths_at(s)
        # The last sample is s = L, which wraps to s = 0: reuse the first sample so the tables
        # are exactly periodic, with the unwrapped heading advanced by the full turn.
        turns = round((heading[-1] - heading[0]) / (2.0 * math.pi))
        heading[-1] = heading[0] + 2.0 * math.pi * turns
        curvature = track.curvature_at(s)
        centre = track.point_at(s)
        x, y = centre[:, 0].copy(), centre[:, 1].copy()
        for arr in (curvature, left, right, x, y):
            arr[-1] = arr[0]
        return cls(length=float(track.length), inv_ds=count / float(track.length),
                   heading=heading, curvature=curvature, width_left=left, width_right=right,
                   x=x, y=y)


@njit(cache=True, inline="always")
def lookup_span(table: FloatArray, first: int, count: int, s: float, inv_ds: float,
                length: float) -> float:  # pragma: no cover
    """Linearly interpolate the periodic table ``table[first:first + count]`` at arc position
    ``s`` (any real number): one track's samples among several tracks' (``TrackTables``)."""
    s = s - length * math.floor(s / length)
    u = s * inv_ds
    k = int(u)
    if k >= count - 1:
        k = count - 2
    f = u - k
    return table[first + k] + f * (table[first + k + 1] - table[first + k])


@njit(cache=True, inline="always")
def lookup(table: FloatArray, s: float, inv_ds: float, length: float) -> float:  # pragma: no cover
    """Linearly interpolate a periodic ``table`` at arc position ``s`` (any real number)."""
    return lookup_span(table, 0, table.shape[0], s, inv_ds, length)


@njit(cache=True, inline="always")
def wrap_angle(angle: float) -> float:  # pragma: no cover
    """Wrap an angle into [-pi, pi)."""
    return angle - 2.0 * math.pi * math.floor((angle + math.pi) / (2.0 * math.pi))


@njit(cache=True, inline="always")
def wrap_arc(delta_s: float, length: float) -> float:  # pragma: no cover
    """Wrap an arc-position difference into [-length/2, length/2) (9.5 m ahead on a 10 m lap
    is 0.5 m behind)."""
    return delta_s - length * math.floor((delta_s + 0.5 * length) / length)


def wrap_arcs(delta_s: npt.ArrayLike, length: npt.ArrayLike) -> FloatArray:
    """``wrap_arc`` for arrays (numpy broadcasting): arc-position differences wrapped into
    [-length/2, length/2), e.g. the gap from one car to every other along the track."""
    delta_s = np.asarray(delta_s, dtype=np.float64)
    return delta_s - length * np.floor(delta_s / length + 0.5)
