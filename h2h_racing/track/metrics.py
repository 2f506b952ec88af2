"""Measurements and checks of sampled closed curves: length, area, curvature, normals, borders, crossings.

Pure numpy. The procedural generator (:mod:`h2h_racing.track.generator`), ``tracks/design.py``
and the tests use these to check a track: :func:`measure_track` gathers them into a
:class:`TrackMetrics`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


def _as_points(points: npt.ArrayLike, name: str, min_points: int = 3) -> FloatArray:
    array = np.asarray(points, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < min_points:
        raise ValueError(f"Expected {name} of shape (K >= {min_points}, 2), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"Expected finite {name}, got NaN or inf")
    return array


@dataclass(frozen=True, slots=True)
class TrackMetrics:
    """Summary numbers of a closed track, as reported by :func:`measure_track`."""

    length: float
    """Lap length of the centre line [m]."""
    min_width: float
    """Smallest total width ``width_left + width_right`` [m]."""
    max_width: float
    """Largest total width [m]."""
    min_radius: float
    """Smallest radius of curvature of the centre line [m]."""
    min_radius_ratio: float
    """Smallest ``radius / half-width`` along the lap (the half-width on the inside of each corner).

    Below 1 the inner border turns inside out. A corner that is locally too tight makes the border loop and
    cross itself (counted in ``border_crossings``), but a uniformly too-narrow ring inverts the inner border
    into a small non-crossing loop, so check this ratio too.
    """
    counter_clockwise: bool
    """True when the vertex order runs counter-clockwise (positive signed area)."""
    centre_crossings: int
    """Number of crossing segment pairs of the centre line with itself."""
    border_crossings: int
    """Number of crossing segment pairs among the left and right borders (with themselves and each other)."""
    clearance: float
    """Smallest centre-line distance between parts of the lap more than ``3 * max_width`` apart along it [m].

    Below ``max_width`` the tarmac of two parts of the track overlaps; see :func:`min_clearance`.
    """
    max_spacing: float
    """Largest distance between consecutive vertices [m]."""
    min_spacing: float
    """Smallest distance between consecutive vertices [m]."""

    @property
    def is_simple(self) -> bool:
        """True when neither the centre line nor the borders cross."""
        return self.centre_crossings == 0 and self.border_crossings == 0


def closed_length(points: npt.ArrayLike) -> float:
    """Return the length of a closed polyline, closing segment included [m].

    Args:
        points: Vertices, shape (M, 2) [m], first vertex not repeated.
    """
    array = _as_points(points, "points", min_points=2)
    return float(np.linalg.norm(np.roll(array, -1, axis=0) - array, axis=1).sum())


def signed_area(points: npt.ArrayLike) -> float:
    """Return the shoelace signed area of a closed polyline [m^2]; positive means counter-clockwise.

    ``A = 1/2 sum_i (x_i y_{i+1} - x_{i+1} y_i)``.

    Args:
        points: Vertices, shape (M, 2) [m], first vertex not repeated.
    """
    array = _as_points(points, "points")
    x, y = array[:, 0], array[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def curvature(points: npt.ArrayLike) -> FloatArray:
    """Return the signed curvature of a sampled closed curve at every vertex [1/m].

    Uses the Menger curvature of each vertex and its two neighbours, ``kappa = 4 A / (|a| |b| |c|)`` with
    ``A`` the signed triangle area: exactly ``1/R`` for three points on a circle of radius ``R``, whatever
    their spacing. Positive means turning left (counter-clockwise).

    Args:
        points: Vertices, shape (M, 2) [m], first vertex not repeated; consecutive vertices distinct.

    Returns:
        Signed curvature, shape (M,) [1/m].

    >>> square_circle = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    >>> curvature(square_circle).round(6).tolist()
    [1.0, 1.0, 1.0, 1.0]
    """
    array = _as_points(points, "points")
    prev = np.roll(array, 1, axis=0)
    nxt = np.roll(array, -1, axis=0)
    a = array - prev
    b = nxt - array
    c = nxt - prev
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]  # = 2 * signed triangle area
    denom = np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) * np.linalg.norm(c, axis=1)
    if np.any(denom <= 0):
        raise ValueError("Expected distinct consecutive vertices, got a repeated or folded-back vertex")
    return 2.0 * cross / denom


def min_radius_of_curvature(points: npt.ArrayLike) -> float:
    """Return the smallest radius of curvature of a sampled closed curve [m] (``inf`` for a straight).

    Args:
        points: Vertices, shape (M, 2) [m], first vertex not repeated.
    """
    kappa_max = float(np.max(np.abs(curvature(points))))
    return np.inf if kappa_max == 0 else 1.0 / kappa_max


def left_normals(points: npt.ArrayLike) -> FloatArray:
    """Return unit normals pointing to the left of the direction of travel, shape (M, 2).

    The tangent at a vertex is the central difference ``p_{i+1} - p_{i-1}``, normalised; the left normal
    is the tangent rotated by +90 degrees, ``(-t_y, t_x)``.

    Args:
        points: Vertices of a closed curve, shape (M, 2) [m], first vertex not repeated.
    """
    array = _as_points(points, "points")
    tangent = np.roll(array, -1, axis=0) - np.roll(array, 1, axis=0)
    norm = np.linalg.norm(tangent, axis=1, keepdims=True)
    if np.any(norm <= 0):
        raise ValueError("Expected a regular curve, got a vertex whose neighbours coincide")
    tangent = tangent / norm
    return np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)


def border_polylines(
    centre: npt.ArrayLike, width_left: npt.ArrayLike, width_right: npt.ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Return the left and right borders, ``centre + n * width_left`` and ``centre - n * width_right``.

    Args:
        centre: Centre line, shape (M, 2) [m].
        width_left: Distance to the left border, shape (M,) or scalar [m].
        width_right: Distance to the right border, shape (M,) or scalar [m].

    Returns:
        ``(left, right)``, each of shape (M, 2) [m].
    """
    array = _as_points(centre, "centre")
    normal = left_normals(array)
    wl = np.broadcast_to(np.asarray(width_left, dtype=np.float64), array.shape[:1])
    wr = np.broadcast_to(np.asarray(width_right, dtype=np.float64), array.shape[:1])
    return array + normal * wl[:, None], array - normal * wr[:, None]


def find_crossings(*polylines: npt.ArrayLike, chunk: int = 512) -> IntArray:
    """Find every pair of crossing or touching segments among closed polylines (vectorised).

    Each polyline is closed (its last vertex joins its first). All segments of all polylines are tested
    against each other, except a segment against itself and against its two neighbours in the same
    polyline (they share an endpoint by construction). Two segments ``p1p2`` and ``q1q2`` intersect when
    their bounding boxes overlap and each one's endpoints are not strictly on the same side of the other:
    ``orient(p1, p2, q1) * orient(p1, p2, q2) <= 0`` and ``orient(q1, q2, p1) * orient(q1, q2, p2) <= 0``
    with ``orient(a, b, c) = cross(b - a, c - a)``. The bounding-box test also removes the false positives of
    collinear but disjoint segments. Work is O(N^2) in blocks of ``chunk`` rows, cheap for a few thousand
    segments.

    Args:
        *polylines: Closed polylines, each of shape (N_k >= 3, 2) [m], first vertex not repeated.
        chunk: Rows per block (memory ~ chunk * N booleans).

    Returns:
        Crossing pairs, shape (P, 4) int64 as (polyline_a, segment_a, polyline_b, segment_b) with
        ``(polyline_a, segment_a) < (polyline_b, segment_b)``; segment ``j`` joins vertex ``j`` to ``j + 1``.

    >>> bow_tie = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    >>> find_crossings(bow_tie).tolist()
    [[0, 0, 0, 2]]
    """
    if not polylines:
        raise ValueError("Expected at least one polyline, got none")
    arrays = [_as_points(p, f"polylines[{k}]") for k, p in enumerate(polylines)]
    start = np.concatenate(arrays)
    end = np.concatenate([np.roll(a, -1, axis=0) for a in arrays])
    owner = np.concatenate([np.full(len(a), k) for k, a in enumerate(arrays)])
    local = np.concatenate([np.arange(len(a)) for a in arrays])
    count = np.concatenate([np.full(len(a), len(a)) for a in arrays])
    lo = np.minimum(start, end)
    hi = np.maximum(start, end)
    total = start.shape[0]
    found: list[IntArray] = []
    for first in range(0, total, chunk):
        rows = np.arange(first, min(first + chunk, total))
        # Only j > i, so each pair is tested once.
        cols = np.arange(first + 1, total)
        if cols.size == 0:
            continue
        overlap = (
            (lo[rows, None, 0] <= hi[None, cols, 0])
            & (lo[None, cols, 0] <= hi[rows, None, 0])
            & (lo[rows, None, 1] <= hi[None, cols, 1])
            & (lo[None, cols, 1] <= hi[rows, None, 1])
            & (cols[None, :] > rows[:, None])
        )
        same = owner[rows, None] == owner[None, cols]
        gap = np.abs(local[rows, None] - local[None, cols])
        adjacent = same & ((gap == 1) | (gap == count[rows, None] - 1))
        ii, jj = np.nonzero(overlap & ~adjacent)
        if ii.size == 0:
            continue
        i, j = rows[ii], cols[jj]
        p1, p2, q1, q2 = start[i], end[i], start[j], end[j]

        def orient(a: FloatArray, b: FloatArray, c: FloatArray) -> FloatArray:
            return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])

        hit = (orient(p1, p2, q1) * orient(p1, p2, q2) <= 0) & (orient(q1, q2, p1) * orient(q1, q2, p2) <= 0)
        found.append(np.stack([owner[i[hit]], local[i[hit]], owner[j[hit]], local[j[hit]]], axis=1))
    if not found:
        return np.zeros((0, 4), dtype=np.int64)
    return np.concatenate(found).astype(np.int64)


def min_clearance(points: npt.ArrayLike, exclude_arc: float) -> float:
    """Return the smallest distance between two vertices at least ``exclude_arc`` apart along the loop [m].

    Vertices close along the loop are close in space by construction; this measures how near *different*
    parts of the track come to each other (two parts closer than the track width overlap).

    Args:
        points: Vertices of a closed curve, shape (M, 2) [m], first vertex not repeated.
        exclude_arc: Pairs whose cyclic arc-length separation is below this are ignored [m].

    Returns:
        The smallest such distance [m], ``inf`` when no pair is far enough apart along the loop.
    """
    array = _as_points(points, "points")
    seg = np.linalg.norm(np.roll(array, -1, axis=0) - array, axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    total = seg.sum()
    best = np.inf
    for first in range(0, len(array), 512):
        rows = slice(first, first + 512)
        ds = np.abs(s[rows, None] - s[None, :])
        ds = np.minimum(ds, total - ds)
        dist = np.linalg.norm(array[rows, None, :] - array[None, :, :], axis=2)
        dist = np.where(ds >= exclude_arc, dist, np.inf)
        best = min(best, float(dist.min()))
    return best


def measure_track(centre: npt.ArrayLike, width_left: npt.ArrayLike, width_right: npt.ArrayLike) -> TrackMetrics:
    """Measure a closed track: length, widths, tightest corner, direction and self-intersections.

    Args:
        centre: Centre line, shape (M, 2) [m], first vertex not repeated.
        width_left: Distance to the left border, shape (M,) or scalar [m].
        width_right: Distance to the right border, shape (M,) or scalar [m].

    Returns:
        The :class:`TrackMetrics` of the track.
    """
    array = _as_points(centre, "centre")
    wl = np.broadcast_to(np.asarray(width_left, dtype=np.float64), array.shape[:1])
    wr = np.broadcast_to(np.asarray(width_right, dtype=np.float64), array.shape[:1])
    kappa = curvature(array)
    # The border on the inside of a corner is the one that can fold: left for left turns (kappa > 0).
    inner_half_width = np.where(kappa > 0, wl, wr)
    with np.errstate(divide="ignore"):
        radius = np.where(kappa != 0, 1.0 / np.abs(kappa), np.inf)
    left, right = border_polylines(array, wl, wr)
    gaps = np.linalg.norm(np.roll(array, -1, axis=0) - array, axis=1)
    total_width = wl + wr
    return TrackMetrics(
        length=float(gaps.sum()),
        min_width=float(total_width.min()),
        max_width=float(total_width.max()),
        min_radius=float(radius.min()),
        min_radius_ratio=float(np.min(radius / inner_half_width)),
        counter_clockwise=signed_area(array) > 0,
        centre_crossings=len(find_crossings(array)),
        border_crossings=len(find_crossings(left, right)),
        clearance=min_clearance(array, exclude_arc=3.0 * float(total_width.max())),
        max_spacing=float(gaps.max()),
        min_spacing=float(gaps.min()),
    )
