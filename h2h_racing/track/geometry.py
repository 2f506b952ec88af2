"""Geometry of a closed polyline for :class:`h2h_racing.track.shape.Track`: arc positions,
headings, normals, and checks.

:func:`_centre_geometry` derives what a track needs from its centre line (segment lengths, arc
positions, unwrapped headings, vertex normals, area); :func:`_check_no_fold` and
:func:`_check_simple` reject borders that fold back or polylines that cross themselves, with an
error that names where. Pure numpy, vectorised over segments.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

_CHUNK_ELEMENTS = 1_000_000  # candidate pairs tested at once by the crossing check


def _ro(a: np.ndarray) -> np.ndarray:
    """Return ``a`` flagged read-only (the array is owned by the track)."""
    a.flags.writeable = False
    return a


def _centre_geometry(centre: FloatArray, where: str) -> dict[str, Any]:
    """Segment lengths, arc positions, unwrapped headings and vertex normals of a closed polyline.

    Zero-length segments (duplicate consecutive vertices) are skipped when defining headings and normals:
    the distinct vertices ("kept", the first of each run of duplicates) form the compressed polyline.
    """
    m = len(centre)
    seg = np.roll(centre, -1, axis=0) - centre
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    vertex_s = np.concatenate([[0.0], np.cumsum(seg_len[:-1])])
    length = float(seg_len.sum())
    # Vertex i is kept when the segment arriving at it has non-zero length.
    keep = np.flatnonzero(np.roll(seg_len, 1) > 0)
    # The compressed segment leaving kept vertex v starts at it and runs to the next kept vertex; its first
    # original segment is the non-zero one leaving the last duplicate of v.
    nxt = np.roll(keep, -1)
    seg_of_kept = (nxt - 1) % m
    cseg = centre[nxt] - centre[keep]
    ang = np.arctan2(cseg[:, 1], cseg[:, 0])
    turn = np.diff(ang)
    turn = (turn + np.pi) % (2 * np.pi) - np.pi
    psi = np.concatenate([[ang[0]], ang[0] + np.cumsum(turn)])
    closing = (ang[0] - ang[-1] + np.pi) % (2 * np.pi) - np.pi
    total = float(psi[-1] - psi[0] + closing)

    # Unit tangent of every original segment (a zero-length one borrows the compressed segment it lies in,
    # which gives project() a sign for d there).
    tangent = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    owner = np.searchsorted(keep, np.arange(m), side="right") - 1  # kept vertex at or before each vertex
    seg_tangent = tangent[owner % len(keep)]
    # Vertex normal = mean of the incoming and outgoing segment normals (normalised).
    seg_normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    nsum = seg_normal + np.roll(seg_normal, 1, axis=0)
    nlen = np.hypot(nsum[:, 0], nsum[:, 1])
    if np.any(nlen < 1e-9):
        v = int(keep[np.argmax(nlen < 1e-9)])
        raise ValueError(
            f"{where}: the centre line reverses direction (a 180 degree spike) at vertex {v} "
            f"({centre[v, 0]:.4f}, {centre[v, 1]:.4f}); remove the spike."
        )
    vertex_normal = (nsum / nlen[:, None])[owner % len(keep)]
    x, y = centre[:, 0], centre[:, 1]
    area = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    return {
        "seg_len": seg_len,
        "vertex_s": _ro(vertex_s),
        "length": length,
        "keep": keep,
        "seg_of_kept": seg_of_kept,
        "psi": psi,
        "total_turn": total,
        "seg_tangent": seg_tangent,
        "vertex_normal": vertex_normal,
        "area": area,
    }


def _check_no_fold(centre: FloatArray, border: FloatArray, what: str, where: str) -> None:
    """Raise ``ValueError`` where a computed border runs backwards relative to the centre line.

    Offsetting a curve of radius ``r`` by ``w > r`` towards its centre reverses the offset curve (a cusp or an
    inverted loop, which need not cross itself, e.g. a circle of radius 0.5 offset by 0.6 is a circle of
    radius 0.1): a border segment whose direction opposes its centre segment (negative dot product) shows it.
    """
    dc = np.roll(centre, -1, axis=0) - centre
    db = np.roll(border, -1, axis=0) - border
    bad = np.sum(dc * db, axis=1) < 0
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"{where}: the {what} folds back at vertex {i} ({centre[i, 0]:.4f}, {centre[i, 1]:.4f}): the radius of "
            "curvature there is smaller than the half-width. Widen the corner or narrow the track there."
        )


def _candidate_pairs(a: FloatArray, b: FloatArray) -> Iterator[tuple[IntArray, IntArray]]:
    """Batches of pairs ``(i, j)``, ``i < j``, of segments ``a[k] -> b[k]`` that may meet.

    Uniform-grid bucketing: the segments are cut into pieces no longer than the cell size ``c``, every
    piece is entered in the (2 x 2 at most) cells its bounding box covers, and two segments are a
    candidate pair when they share a cell. ``c`` is the median segment length, but at least a quarter
    of the mean, so that the entries number at most ``4 * (n + 4 n)``. Sorting the entries costs
    O(n log n); the pairs are O(n) when the vertices are spread along the loop (every real track) and
    grow only with the number of segments packed into one cell.
    """
    n = len(a)
    length = np.hypot(*(b - a).T)
    cell = max(float(np.median(length)), float(length.sum()) / (4 * n), 1e-12)
    pieces = np.maximum(1, np.ceil(length / cell).astype(np.int64))
    seg = np.repeat(np.arange(n), pieces)
    first = np.repeat(np.cumsum(pieces) - pieces, pieces)
    k = np.arange(len(seg)) - first
    t0, t1 = k / pieces[seg], (k + 1) / pieces[seg]
    d = b[seg] - a[seg]
    p0 = a[seg] + t0[:, None] * d
    p1 = np.where((k + 1 == pieces[seg])[:, None], b[seg], a[seg] + t1[:, None] * d)
    origin = np.minimum(a.min(axis=0), b.min(axis=0))
    lo = np.floor((np.minimum(p0, p1) - origin) / cell).astype(np.int64)
    hi = np.floor((np.maximum(p0, p1) - origin) / cell).astype(np.int64)
    # A piece spans at most 2 cells a side (3 if rounding stretches it past a cell); the loop's
    # extent is at most half its length, so the cell indices stay below about 2 n.
    width = int(hi[:, 0].max()) + 3
    cells, segs = [], []
    for dx in (0, 1, 2):
        for dy in (0, 1, 2):
            ok = (lo[:, 0] + dx <= hi[:, 0]) & (lo[:, 1] + dy <= hi[:, 1])
            cells.append((lo[ok, 1] + dy) * width + lo[ok, 0] + dx)
            segs.append(seg[ok])
    entry = np.unique(np.stack([np.concatenate(cells), np.concatenate(segs)], axis=1), axis=0)
    cell_id, seg_id = entry[:, 0], entry[:, 1]
    # Every entry pairs with the entries after it in its cell (sorted by cell, then segment). The pairs
    # come in batches of about _CHUNK_ELEMENTS, so that a crowded cell costs time, not memory.
    starts = np.flatnonzero(np.r_[True, cell_id[1:] != cell_id[:-1]])
    ends = np.r_[starts[1:], len(cell_id)]
    end_of = np.repeat(ends, ends - starts)
    count = end_of - np.arange(len(cell_id)) - 1
    total = np.cumsum(count)
    e0 = 0
    while e0 < len(count):
        base = total[e0 - 1] if e0 else 0
        e1 = max(e0 + 1, int(np.searchsorted(total, base + _CHUNK_ELEMENTS, side="right")))
        cnt = count[e0:e1]
        left = np.repeat(np.arange(e0, e1), cnt)
        right = left + 1 + np.arange(len(left)) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        i, j = seg_id[left], seg_id[right]
        key = np.unique(i * n + j)
        yield key // n, key % n
        e0 = e1


def _check_simple(poly: FloatArray, what: str, where: str, tolerance: float) -> None:
    """Raise ``ValueError`` if the closed polyline ``poly`` crosses or touches itself.

    Segment-segment test over the pairs of non-adjacent segments that share a cell of a uniform grid
    (:func:`_candidate_pairs`, O(n log n) for a track's evenly spread vertices), after dropping
    zero-length segments. Two segments meet iff each one's endpoints are not strictly on the same side
    of the other (orientation signs) and their bounding boxes overlap (which settles the collinear
    case). With ``tolerance > 0`` a crossing is ignored when the smaller of the four
    endpoint-to-other-segment distances is at most ``tolerance`` (a crossing that barely overlaps).
    The crossing reported is the one with the lowest pair of vertex indices.
    """
    seg_len = np.hypot(*(np.roll(poly, -1, axis=0) - poly).T)
    idx = np.flatnonzero(np.roll(seg_len, 1) > 0)  # distinct vertices
    q = poly[idx]
    n = len(q)
    if n < 4:
        return
    a, b = q, np.roll(q, -1, axis=0)
    lo, hi = np.minimum(a, b), np.maximum(a, b)

    def orient(p: FloatArray, r: FloatArray, t: FloatArray) -> FloatArray:
        return (r[..., 0] - p[..., 0]) * (t[..., 1] - p[..., 1]) - (r[..., 1] - p[..., 1]) * (t[..., 0] - p[..., 0])

    hits: list[tuple[int, int]] = []
    for pi, pj in _candidate_pairs(a, b):
        # Only pairs j > i + 1, and not (first, last), which share a vertex.
        keep = (pj > pi + 1) & ~((pi == 0) & (pj == n - 1))
        pi, pj = pi[keep], pj[keep]
        ai, bi, aj, bj = a[pi], b[pi], a[pj], b[pj]
        o1, o2 = orient(ai, bi, aj), orient(ai, bi, bj)
        o3, o4 = orient(aj, bj, ai), orient(aj, bj, bi)
        hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
        hit &= np.all((lo[pi] <= hi[pj]) & (lo[pj] <= hi[pi]), axis=-1)
        if tolerance > 0 and hit.any():
            sel = np.flatnonzero(hit)
            depth = _crossing_depth(a[pi[sel]], b[pi[sel]], a[pj[sel]], b[pj[sel]])
            hit[sel[depth <= tolerance]] = False
        if hit.any():
            order = np.lexsort((pj[hit], pi[hit]))[0]
            hits.append((int(pi[hit][order]), int(pj[hit][order])))
    if hits:
        i, j = min(hits)
        vi, vj = int(idx[i]), int(idx[j])
        pa, pb, pc, pd = a[i], b[i], a[j], b[j]
        den = (pb[0] - pa[0]) * (pd[1] - pc[1]) - (pb[1] - pa[1]) * (pd[0] - pc[0])
        if den != 0:
            u = ((pc[0] - pa[0]) * (pd[1] - pc[1]) - (pc[1] - pa[1]) * (pd[0] - pc[0])) / den
            px, py = pa + u * (pb - pa)
        else:
            px, py = pc
        hint = (
            " A computed border crosses itself where the radius of curvature is smaller than the "
            "half-width: widen the corner or narrow the track there."
            if what != "centre line"
            else " The centre line must be a simple closed loop."
        )
        raise ValueError(
            f"{where}: the {what} crosses itself near ({px:.4f}, {py:.4f}): the segment from vertex {vi} "
            f"({pa[0]:.4f}, {pa[1]:.4f}) meets the segment from vertex {vj} ({pc[0]:.4f}, {pc[1]:.4f})."
            f"{hint}"
        )


def _crossing_depth(a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray) -> FloatArray:
    """Smallest distance from an endpoint of one segment to the other segment, for pairs of segments."""

    def point_seg(p: FloatArray, s0: FloatArray, s1: FloatArray) -> FloatArray:
        v = s1 - s0
        den = np.maximum(np.sum(v * v, axis=-1), 1e-300)
        t = np.minimum(np.maximum(np.sum((p - s0) * v, axis=-1) / den, 0.0), 1.0)
        e = p - s0 - t[:, None] * v
        return np.hypot(e[:, 0], e[:, 1])

    return np.minimum.reduce([point_seg(a, c, d), point_seg(b, c, d), point_seg(c, a, b), point_seg(d, a, b)])
