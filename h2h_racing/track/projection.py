"""Projection lookup grid for :meth:`h2h_racing.track.shape.Track.project` and its compiled
kernels.

A :class:`Projector` covers the track's bounds with a grid; each cell stores a window of
candidate centre-line segments and a certificate (a distance below which the window's nearest
segment is provably the true nearest). :func:`project_kernel` answers queries from the window
and falls back to every segment for the rare uncertified points, so the answer is always exact.
:func:`grid_kernel` builds the grid (compiled: about 10 ms for a DeepRacer track, where
measuring every segment from every cell in numpy took 0.1-0.5 s), to the bit as numpy's
arithmetic gave it. Queries go point by point with :func:`project_point`, which the simulation
core's compiled step calls too, on the tables of each copy's track
(:mod:`h2h_racing.track.tables`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
from numba import njit, types
from numba.extending import intrinsic


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
"""Margin [m] of the lookup grid around the track bounds; points beyond it are answered
exactly too."""
GRID_MAX_CELLS = 200_000
"""Cap on the number of grid cells; large (full-scale) circuits get coarser cells."""
WINDOW_ARC = 0.4
"""Arc length [m] each side of a cell's nearest segment searched when refining a query."""

GRID_TILE = 8
"""Cells per side of the tiles in which :func:`grid_kernel` picks the segments worth measuring."""
# Slack [m] on the tiles' distance bounds, far above their rounding (1e-12 m on a 1 km track).
_BOUND_SLACK = 1e-6
# Relative slack of the squared-distance pre-selection, far above its rounding (a few 1e-16):
# the segments within it are measured again with hypot, as the grid's distances are.
_TIE_SLACK = 1e-9


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
        full = np.stack([zc, dz, np.conj(dz) * inv_l2, np.conj(tz), g["vertex_s"] + 1j * seg_len],
                        axis=1)

        xmin, ymin, xmax, ymax = track.bounds
        area = (xmax - xmin + 2 * GRID_MARGIN) * (ymax - ymin + 2 * GRID_MARGIN)
        cell = max(GRID_CELL, math.sqrt(area / GRID_MAX_CELLS))
        nx = int(math.ceil((xmax - xmin + 2 * GRID_MARGIN) / cell))
        ny = int(math.ceil((ymax - ymin + 2 * GRID_MARGIN) / cell))
        origin = np.array([xmin - GRID_MARGIN, ymin - GRID_MARGIN])

        # Window of +-K segments covering at least `arc` of arc length each side of every segment.
        arc = max(WINDOW_ARC, 4.0 * cell)
        cum = np.concatenate([[0.0], np.cumsum(np.tile(seg_len, 3))])
        # For every start segment i (in the middle copy), the number of segments needed to cover
        # `arc`.
        i_mid = np.arange(m, 2 * m)
        ahead = np.searchsorted(cum, cum[i_mid + 1] + arc, side="left") - (i_mid + 1)
        behind = i_mid - np.searchsorted(cum, cum[i_mid] - arc, side="right") + 1
        k = int(min(max(ahead.max(), behind.max(), 1), m // 2))
        ext = np.arange(-k, m + k) % m
        tab = full[ext]
        # Exact nearest segment of every cell centre, and the distance to the nearest segment
        # OUTSIDE the window around it. A query q in the cell is within r = half-diagonal of the
        # centre, so every outside segment is at least (outside distance - r) from q: if the
        # window's best is below that, it is the true nearest.
        gx = origin[0] + (np.arange(nx) + 0.5) * cell
        gy = origin[1] + (np.arange(ny) + 0.5) * cell
        nearest = np.empty(nx * ny, dtype=np.intp)
        outside = np.empty(nx * ny)
        fused_multiply, fused_abs = numpy_fuses()
        grid_kernel(gx, gy, full, k, fused_multiply, fused_abs, nearest, outside)
        cert = outside - (cell * math.sqrt(0.5) + 1e-9)
        edge = np.zeros((nx, ny), dtype=bool)
        edge[[0, -1], :] = True
        edge[:, [0, -1]] = True
        # Points beyond the grid are clamped into edge cells, where the half-diagonal bound does
        # not hold.
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


@functools.lru_cache(maxsize=1)
def numpy_fuses() -> tuple[bool, bool]:
    """Whether numpy's complex product and complex ``abs`` round a multiply-add once (a fused
    multiply-add, as its SIMD loops do on CPUs that have one) on this machine: ``(product,
    abs)``. The grid's distances have always been numpy's; :func:`grid_kernel` rounds as
    numpy does here, so its grid is the one numpy's arithmetic gives, to the bit."""
    a = np.array([complex(1.0 + 2.0**-30, 1.0)])
    # (1 + 2^-30)^2 - 1 keeps its 2^-60 only when rounded once.
    product = float((a * a)[0].real) == 2.0**-29 + 2.0**-60
    # max * sqrt(ratio^2 + 1): the two roundings of this ratio differ in the last bit.
    size = float(np.abs(np.array([complex(1.0, 0.40311298644712923)]))[0])
    return product, size == 1.0781929696683814


@intrinsic
def _fma(typingctx, a, b, c):  # pragma: no cover
    """``a * b + c`` rounded once (LLVM's fma: the CPU's instruction, or libm's)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


@njit(cache=True, inline="always")
def _numpy_abs(x, y, fused):  # pragma: no cover
    """``abs(complex(x, y))`` as numpy's SIMD loop computes it: ``big * sqrt(r^2 + 1)``
    with ``r = small / big`` (0 when ``big`` is 0), ``r^2 + 1`` fused when ``fused``."""
    x = abs(x)
    y = abs(y)
    big = max(x, y)
    small = min(x, y)
    r = small / big if big != 0.0 else 0.0
    return math.sqrt(_fma(r, r, 1.0) if fused else r * r + 1.0) * big


@njit(cache=True)
def grid_kernel(gx, gy, full, k, fused_multiply, fused_abs, nearest,
                outside):  # pragma: no cover
    """The grid of :meth:`Projector.build`: for every cell centre ``(gx[ix], gy[iy])`` (cell
    ``ix * ny + iy``), ``nearest``: the index of the nearest segment of ``full`` (the first
    of equals), and ``outside``: the distance to the nearest segment more than ``k`` segments
    from it round the loop (inf when there is none).

    The same numbers as measuring every segment from every centre with numpy's complex
    arithmetic, ``abs(w - t D)`` with ``w = z - A`` and ``t = clip(Re(w conj(D)/|D|^2), 0,
    1)``, rounded as numpy rounds them (``fused_multiply``, ``fused_abs``: whether numpy's
    complex product and ``abs`` fuse their multiply-adds on this machine; ``numpy_fuses``),
    in fewer operations: for a
    tile of ``GRID_TILE`` x ``GRID_TILE`` cells, no point of it is further than ``T`` from its
    outside segment (the ``2k+2``-th smallest of the segments' largest distance from the
    tile: the window holds ``2k+1``), so the segments nearer than ``T`` to the tile are the
    only ones either figure can come from. Among them every distance is compared as its
    square first, and those within ``_TIE_SLACK`` of the smallest are measured as
    numpy measures them, so the smallest value and the first index holding it are the exhaustive
    search's (only the segments measured differ).
    """
    m = full.shape[0]
    nx = gx.shape[0]
    ny = gy.shape[0]
    ax = np.empty(m)
    ay = np.empty(m)
    low_x = np.empty(m)
    high_x = np.empty(m)
    low_y = np.empty(m)
    high_y = np.empty(m)
    for j in range(m):
        a = full[j, 0]
        b = a + full[j, 1]
        ax[j] = a.real
        ay[j] = a.imag
        low_x[j] = min(a.real, b.real)
        high_x[j] = max(a.real, b.real)
        low_y[j] = min(a.imag, b.imag)
        high_y[j] = max(a.imag, b.imag)
    reach = np.empty(m)
    near_by = np.empty(m, dtype=np.intp)
    ex = np.empty(m)
    ey = np.empty(m)
    d2 = np.empty(m)
    # With 2k + 1 >= m every segment is in the window: nothing is outside.
    rank = 2 * k + 1
    for tx in range(0, nx, GRID_TILE):
        x0 = gx[tx]
        x1 = gx[min(tx + GRID_TILE, nx) - 1]
        for ty in range(0, ny, GRID_TILE):
            y0 = gy[ty]
            y1 = gy[min(ty + GRID_TILE, ny) - 1]
            limit = np.inf
            if rank < m:
                for j in range(m):
                    # Largest distance from the tile to the segment's start (a corner's).
                    fx = max(abs(x0 - ax[j]), abs(x1 - ax[j]))
                    fy = max(abs(y0 - ay[j]), abs(y1 - ay[j]))
                    reach[j] = math.sqrt(fx * fx + fy * fy)
                limit = np.partition(reach, rank)[rank] + _BOUND_SLACK
            count = 0
            for j in range(m):
                # Smallest distance from the tile to the segment's bounding box.
                dx = max(low_x[j] - x1, x0 - high_x[j], 0.0)
                dy = max(low_y[j] - y1, y0 - high_y[j], 0.0)
                if math.sqrt(dx * dx + dy * dy) <= limit:
                    near_by[count] = j
                    count += 1
            for ix in range(tx, min(tx + GRID_TILE, nx)):
                for iy in range(ty, min(ty + GRID_TILE, ny)):
                    zx = gx[ix]
                    zy = gy[iy]
                    best2 = np.inf
                    for c in range(count):
                        j = near_by[c]
                        wx = zx - full[j, 0].real
                        wy = zy - full[j, 0].imag
                        f = full[j, 2]
                        if fused_multiply:
                            t = _fma(wx, f.real, -(wy * f.imag))
                        else:
                            t = wx * f.real - wy * f.imag
                        t = min(max(t, 0.0), 1.0)
                        dz = full[j, 1]
                        x = wx - t * dz.real
                        y = wy - t * dz.imag
                        ex[c] = x
                        ey[c] = y
                        d2[c] = x * x + y * y
                        best2 = min(best2, d2[c])
                    best = np.inf
                    best_j = -1
                    cut = best2 * (1.0 + _TIE_SLACK)
                    for c in range(count):
                        if d2[c] <= cut:
                            dist = _numpy_abs(ex[c], ey[c], fused_abs)
                            if dist < best:
                                best = dist
                                best_j = near_by[c]
                    cell = ix * ny + iy
                    nearest[cell] = best_j
                    out2 = np.inf
                    for c in range(count):
                        gap = (near_by[c] - best_j) % m
                        if k < gap < m - k:
                            out2 = min(out2, d2[c])
                    out = np.inf
                    cut = out2 * (1.0 + _TIE_SLACK)
                    for c in range(count):
                        gap = (near_by[c] - best_j) % m
                        if k < gap < m - k and d2[c] <= cut:
                            out = min(out, _numpy_abs(ex[c], ey[c], fused_abs))
                    outside[cell] = out


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
