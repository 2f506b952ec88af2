"""Projection lookup grid for :meth:`h2h_racing.track.shape.Track.project` and its compiled kernel.

A :class:`Projector` covers the track's bounds with a grid; each cell stores a window of
candidate centre-line segments and a certificate (a distance below which the window's nearest
segment is provably the true nearest). :func:`project_kernel` answers queries from the window and
falls back to every segment for the rare uncertified points, so the answer is always exact.
Both do it point by point with :func:`project_point`, which the simulation core's compiled step
calls too, on the tables of each copy's track (:mod:`h2h_racing.track.tables`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
from numba import njit


class _TrackShape(Protocol):
    """What :meth:`Projector.build` reads of a ``Track``: a protocol, so that this module does not
    import ``track.shape`` (which imports this one)."""

    _geo: dict[str, Any]
    centre: npt.NDArray[np.float64]
    bounds: tuple[float, float, float, float]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

GRID_CELL = 0.1
"""Preferred cell size [m] of the projection lookup grid."""
GRID_MARGIN = 2.0
"""Margin [m] of the lookup grid around the track bounds; points beyond it are answered exactly too."""
GRID_MAX_CELLS = 200_000
"""Cap on the number of grid cells; large (full-scale) circuits get coarser cells."""
WINDOW_ARC = 0.4
"""Arc length [m] each side of a cell's nearest segment searched when refining a query."""

# Size of the (cells x segments) blocks of the projection grid build: each block holds about ten
# temporaries of 8-16 bytes per element, so 2**17 elements keep the build near 20 MiB (2M took
# ~140 MiB, the peak of every process).
_GRID_CHUNK_ELEMENTS = 1 << 17


@dataclass(frozen=True)
class Projector:
    """Lookup grid for :meth:`Track.project` (built once per track, lazily)."""

    origin: FloatArray  # (2,) world position of the grid corner [m]
    inv_cell: float  # 1 / cell size [1/m]
    hi: FloatArray  # (2,) largest cell index per axis, as float for clamping
    ny: int  # flat cell index = ix * ny + iy
    start: IntArray  # (cells,) first row of the candidate window in ``tab``
    cert: FloatArray  # (cells,) distance below which the window's answer is certified exact [m]
    window: int  # 2K + 1 segments searched per query: rows start .. start + 2K of ``tab``
    tab: npt.NDArray[np.complex128]  # (M + 2K, 5) segment table, wrapped by K rows each side
    tab_full: npt.NDArray[np.complex128]  # (M, 5)
    length: float

    @staticmethod
    def build(track: _TrackShape) -> Projector:
        g = track._geo
        c = track.centre
        m = len(c)
        seg = np.roll(c, -1, axis=0) - c
        seg_len = g["seg_len"]
        inv_l2 = np.divide(1.0, seg_len**2, out=np.zeros(m), where=seg_len > 0)
        zc = c[:, 0] + 1j * c[:, 1]
        dz = seg[:, 0] + 1j * seg[:, 1]
        tz = g["seg_tangent"][:, 0] + 1j * g["seg_tangent"][:, 1]
        full = np.stack([zc, dz, np.conj(dz) * inv_l2, np.conj(tz), g["vertex_s"] + 1j * seg_len], axis=1)

        xmin, ymin, xmax, ymax = track.bounds
        area = (xmax - xmin + 2 * GRID_MARGIN) * (ymax - ymin + 2 * GRID_MARGIN)
        cell = max(GRID_CELL, math.sqrt(area / GRID_MAX_CELLS))
        nx = int(math.ceil((xmax - xmin + 2 * GRID_MARGIN) / cell))
        ny = int(math.ceil((ymax - ymin + 2 * GRID_MARGIN) / cell))
        origin = np.array([xmin - GRID_MARGIN, ymin - GRID_MARGIN])

        # Window of +-K segments covering at least `arc` of arc length each side of every segment.
        arc = max(WINDOW_ARC, 4.0 * cell)
        cum = np.concatenate([[0.0], np.cumsum(np.tile(seg_len, 3))])
        # For every start segment i (in the middle copy), the number of segments needed to cover `arc`.
        i_mid = np.arange(m, 2 * m)
        ahead = np.searchsorted(cum, cum[i_mid + 1] + arc, side="left") - (i_mid + 1)
        behind = i_mid - np.searchsorted(cum, cum[i_mid] - arc, side="right") + 1
        k = int(min(max(ahead.max(), behind.max(), 1), m // 2))
        ext = np.arange(-k, m + k) % m
        tab = full[ext]
        # Exact nearest segment of every cell centre, and the distance to the nearest segment OUTSIDE the
        # window around it. A query q in the cell is within r = half-diagonal of the centre, so every
        # outside segment is at least (outside distance - r) from q: if the window's best is below that,
        # it is the true nearest.
        gx = origin[0] + (np.arange(nx) + 0.5) * cell
        gy = origin[1] + (np.arange(ny) + 0.5) * cell
        centres = (gx[:, None] + 1j * gy[None, :]).ravel()
        nearest = np.empty(len(centres), dtype=np.intp)
        outside = np.empty(len(centres))
        step = max(1, _GRID_CHUNK_ELEMENTS // m)
        seg_ids = np.arange(m)
        for a in range(0, len(centres), step):
            zz = centres[a : a + step, None]
            w = zz - zc[None, :]
            t = np.clip((w * full[None, :, 2]).real, 0.0, 1.0)
            dist = np.abs(w - t * dz[None, :])
            near = dist.argmin(axis=1)
            nearest[a : a + step] = near
            offset = (seg_ids[None, :] - near[:, None]) % m
            in_window = (offset <= k) | (offset >= m - k)
            dist[in_window] = np.inf
            outside[a : a + step] = dist.min(axis=1)
        cert = outside - (cell * math.sqrt(0.5) + 1e-9)
        edge = np.zeros((nx, ny), dtype=bool)
        edge[[0, -1], :] = True
        edge[:, [0, -1]] = True
        # Points beyond the grid are clamped into edge cells, where the half-diagonal bound does not hold.
        cert[edge.ravel()] = -1.0
        return Projector(
            origin=origin,
            inv_cell=1.0 / cell,
            hi=np.array([nx - 1, ny - 1], dtype=np.float64),
            ny=ny,
            start=nearest,
            cert=cert,
            window=2 * k + 1,
            tab=tab,
            tab_full=full,
            length=g["length"],
        )


@njit(cache=True, inline="always")
def _segment_distance2(z, tab, r):  # pragma: no cover
    """Squared distance from complex point ``z`` to segment ``tab[r] = (A, D, conj(D)/|D|^2, ...)``.

    Points and vectors are complex numbers ``x + iy``: for a segment ``A + tD`` the foot is at
    ``t = clamp(Re((z - A) conj(D)) / |D|^2, 0, 1)``; a zero-length segment stores
    ``conj(D)/|D|^2 = 0``, so ``t = 0`` and the distance is to ``A``.
    """
    w = z - tab[r, 0]
    t = min(max((w * tab[r, 2]).real, 0.0), 1.0)
    e = w - t * tab[r, 1]
    return e.real * e.real + e.imag * e.imag, t, e


@njit(cache=True, inline="always")
def project_point(x, y, origin_x, origin_y, inv_cell, hi_x, hi_y, ny, start, cell_first, cert,
                  tab, tab_first, window, tab_full, full_first, full_count,
                  length):  # pragma: no cover
    """Exact nearest point of one track's centre polyline to ``(x, y)``: ``(s, d)``.

    The track's grid cells are ``start[cell_first:]`` and ``cert[cell_first:]``, its windowed
    segment rows ``tab[tab_first:]`` (``start`` counts from there) and its full segment table
    ``tab_full[full_first:full_first + full_count]``: one track's tables among several tracks'
    (``h2h_racing.track.tables``), or a whole ``Projector`` with every offset 0. The cell of
    the point gives a window of ``window`` candidate segments; when the best distance in the
    window exceeds the cell's certificate, the window might miss the nearest segment and every
    segment is searched.
    """
    z = complex(x, y)
    ix = int(min(max((x - origin_x) * inv_cell, 0.0), hi_x))
    iy = int(min(max((y - origin_y) * inv_cell, 0.0), hi_y))
    cell = cell_first + ix * ny + iy
    first = tab_first + start[cell]
    best = np.inf
    best_row = first
    best_t = 0.0
    best_e = 0j
    for r in range(first, first + window):
        dist2, t, e = _segment_distance2(z, tab, r)
        if dist2 < best:
            best, best_row, best_t, best_e = dist2, r, t, e
    table = tab
    limit = cert[cell]
    if limit < 0.0 or best > limit * limit:
        best = np.inf
        table = tab_full
        for r in range(full_first, full_first + full_count):
            dist2, t, e = _segment_distance2(z, tab_full, r)
            if dist2 < best:
                best, best_row, best_t, best_e = dist2, r, t, e
    s = table[best_row, 4].real + best_t * table[best_row, 4].imag
    # s0 + t * len reaches ``length`` only at the very end of the closing segment.
    return (0.0 if s >= length else s,
            math.copysign(math.sqrt(best), (best_e * table[best_row, 3]).imag))


@njit(cache=True)
def project_kernel(q, mask, origin, inv_cell, hi, ny, start, cert, tab, window, tab_full, length,
                   out_s, out_d):  # pragma: no cover
    """Exact nearest point of the centre polyline for each point of ``q`` (P, 2)
    (``project_point`` with one ``Projector``'s tables).

    Points where ``mask`` is False are skipped (s = d = 0); an empty mask selects all.
    """
    everything = mask.shape[0] == 0
    full_count = tab_full.shape[0]
    for i in range(q.shape[0]):
        if not everything and not mask[i]:
            out_s[i] = 0.0
            out_d[i] = 0.0
            continue
        out_s[i], out_d[i] = project_point(q[i, 0], q[i, 1], origin[0], origin[1], inv_cell,
                                           hi[0], hi[1], ny, start, 0, cert, tab, 0, window,
                                           tab_full, 0, full_count, length)
