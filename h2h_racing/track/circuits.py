"""Random kart-style circuits: loops made of tight corners, as ``technical`` is.

``random_track``'s smooth star-shaped loops spend 5-20 % of their lap in corners under 1 m
radius even when drawn short and deep-bayed, and their tightest corner is a lone one: shrinking
a loop until that corner is 0.5 m leaves the rest gentle. ``technical`` spends 40 % of its lap
under 1 m (0.5 m corners, 0.76 m wide). :func:`random_circuit` builds that kind of lap
directly: the outline of a random blob of grid cells (a polyomino), every grid corner rounded
into an arc of 0.5-0.7 m radius. Two corners one cell apart the same way make a hairpin, the
opposite way an S-bend; 40-60 % of the lap is arcs.

With ``corners="bspline"`` the outline is rounded instead by its quadratic B-spline: the
curve from each unit edge's midpoint to the next one's, pulled towards the grid point between
them, all of them jittered. A right-angle corner then has a radius of about ``a / sqrt(2)`` for
half-edges ``a`` (0.57-0.71 m for cells of 1.6-2.0 m), two corners one cell apart merge into
one round hairpin with no straight between them, as on ``technical`` (a spline through
hand-placed points); the arcs' circuits join 90 deg arcs with straights. The pieces meet at
the midpoints with a common tangent but not a common curvature: after the final spline the
curvature changes by at most about 0.7 /m between vertices 5 cm apart, the arcs' 1.1 /m.

Pure numpy, beside :mod:`h2h_racing.track.generator`, whose checks it reuses.
"""

from __future__ import annotations

import hashlib

import numpy as np
import numpy.typing as npt

from h2h_racing.track.generator import (
    TrackSpec,
    _add_chicanes,
    _rejection,
    _start_on_straight,
    smooth_closed_curve,
)
from h2h_racing.track.metrics import closed_length, min_radius_of_curvature

FloatArray = npt.NDArray[np.float64]

GRID = (5, 4)
"""Columns and rows of the grid the circuit's cells are drawn on."""

_STEPS = ((1, 0), (-1, 0), (0, 1), (0, -1))


def random_circuit(
    rng: np.random.Generator,
    *,
    width: float = 0.76,
    corner_radius: tuple[float, float] = (0.5, 0.7),
    cell: tuple[float, float] = (1.3, 2.2),
    cells: tuple[int, int] = (5, 11),
    chicanes: tuple[int, int] = (0, 0),
    corners: str = "arcs",
    jitter: float = 0.1,
    spacing: float = 0.05,
    max_tries: int = 100,
) -> TrackSpec:
    """Draw a random circuit of tight corners, driven anticlockwise.

    Each try grows a simply connected blob of a number of cells drawn in ``cells`` on a
    ``GRID`` (one random cell, then random neighbours, refusing any that would enclose a
    hole), sizes the grid's columns and rows independently in ``cell`` [m], walks the blob's
    outline anticlockwise, and rounds each corner of the outline into a circular arc of a radius
    drawn in ``corner_radius``, but at most half of either straight next to it (so that arcs
    never overlap). A number of chicanes drawn in ``chicanes`` is added as in ``random_track``.
    It is accepted only if

    * its smallest radius of curvature is at least ``0.6 * width`` (the inner border must not
      fold; chicanes can tighten a corner);
    * parts more than ``3 * width`` apart along the lap stay ``width + 0.25`` m apart;
    * neither the centre line nor the borders self-intersect.

    Outlines that touch themselves at a grid point (two cells meeting only at a corner) are
    drawn again. The result depends only on the generator state.

    Args:
        rng: Source of randomness; it is advanced, never replaced.
        width: Track width [m], > 0, constant along the lap (``technical``: 0.76).
        corner_radius: ``(low, high)`` radii of the corners [m], ``0.5 * width < low <= high``.
        cell: ``(low, high)`` widths of the grid's columns and heights of its rows [m],
            ``width + 0.25 <= low <= high`` (two legs one cell apart must not touch).
        cells: ``(fewest, most)`` cells of the blob, ``4 <= fewest <= most <= 20``.
        chicanes: ``(fewest, most)`` chicanes per circuit.
        corners: ``"arcs"`` (each grid corner an arc of ``corner_radius``, straights between)
            or ``"bspline"`` (the outline's quadratic B-spline; ``corner_radius`` is then
            unused: the radii follow from ``cell``).
        jitter: Largest shift of a grid point along each axis [m], ``0 <= jitter < cell[0] /
            4``; ``"bspline"`` only.
        spacing: Distance between centre-line vertices [m], > 0.
        max_tries: Circuits to draw before giving up, >= 1.

    Returns:
        A :class:`TrackSpec` named ``"circuit-<8 hex digits of the geometry hash>"``.

    Raises:
        ValueError: On invalid arguments.
        RuntimeError: When no valid circuit was found in ``max_tries`` tries.
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"Expected rng to be a numpy.random.Generator, got {type(rng).__name__}; "
                        "use np.random.default_rng(seed)")
    if not (np.isfinite(width) and width > 0):
        raise ValueError(f"Expected width > 0 [m], got {width}")
    r_low, r_high = (float(v) for v in corner_radius)
    if not 0.5 * width < r_low <= r_high:
        raise ValueError(f"Expected corner_radius = (low, high) with width / 2 = {0.5 * width} m "
                         f"< low <= high [m], got {corner_radius}")
    c_low, c_high = (float(v) for v in cell)
    if not width + 0.25 <= c_low <= c_high:
        raise ValueError(f"Expected cell = (low, high) with width + 0.25 = {width + 0.25} m <= "
                         f"low <= high [m], got {cell}")
    fewest, most = cells
    if not 4 <= fewest <= most <= 20:
        raise ValueError(f"Expected cells = (fewest, most) with 4 <= fewest <= most <= 20, "
                         f"got {cells}")
    if corners not in ("arcs", "bspline"):
        raise ValueError(f"Expected corners = 'arcs' or 'bspline', got {corners!r}")
    if not (np.isfinite(jitter) and 0 <= jitter < 0.25 * c_low):
        raise ValueError(f"Expected 0 <= jitter < cell low / 4 = {0.25 * c_low} m, got {jitter}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"Expected spacing > 0 [m], got {spacing}")
    if max_tries < 1:
        raise ValueError(f"Expected max_tries >= 1, got {max_tries}")

    rejections = {"pinch": 0, "radius": 0, "clearance": 0, "crossing": 0}
    for _ in range(max_tries):
        path = _outline(_blob(rng, int(rng.integers(fewest, most + 1))))
        columns = np.concatenate([[0.0], np.cumsum(rng.uniform(c_low, c_high, GRID[0]))])
        rows = np.concatenate([[0.0], np.cumsum(rng.uniform(c_low, c_high, GRID[1]))])
        turning = _turns(path)
        radii = rng.uniform(r_low, r_high, max(int(turning.sum()), 1))
        if not len(path):
            rejections["pinch"] += 1
            continue
        points = np.c_[columns[path[:, 0]], rows[path[:, 1]]]
        if corners == "arcs":
            dense = _rounded(points[turning], radii)
        else:
            dense = _bspline(points + rng.uniform(-jitter, jitter, points.shape))
        centre = smooth_closed_curve(dense, spacing=spacing)
        # No draw without chicanes, as in random_track.
        if chicanes[1] > 0:
            centre = _add_chicanes(rng, centre, int(rng.integers(chicanes[0], chicanes[1] + 1)))
        rejected = _rejection(centre, width, 0.6 * width)
        if rejected:
            rejections[rejected] += 1
            continue
        centre = _start_on_straight(centre, window=0.5)
        digest = hashlib.sha256(np.round(centre, 4).tobytes()).hexdigest()[:8]
        half = np.full(len(centre), 0.5 * width)
        return TrackSpec(
            name=f"circuit-{digest}",
            description=(f"Random circuit of {int(turning.sum())} corners ({corners}), "
                         f"{closed_length(centre):.1f} m lap, {width:.2f} m wide, "
                         f"min radius {min_radius_of_curvature(centre):.2f} m."),
            centre=centre, width_left=half, width_right=half.copy(),
        )
    raise RuntimeError(f"random_circuit found no valid circuit in {max_tries} tries (rejected: "
                       f"{rejections}) for width={width}, corner_radius={corner_radius}, "
                       f"cell={cell}; try wider cells or more max_tries")


def _blob(rng: np.random.Generator, count: int) -> npt.NDArray[np.bool_]:
    """``count`` connected cells of the ``GRID`` with no hole, as a (columns, rows) mask."""
    occupied = np.zeros(GRID, dtype=bool)
    occupied[int(rng.integers(GRID[0])), int(rng.integers(GRID[1]))] = True
    while occupied.sum() < count:
        frontier = sorted({(x + dx, y + dy) for x, y in zip(*np.nonzero(occupied))
                           for dx, dy in _STEPS
                           if 0 <= x + dx < GRID[0] and 0 <= y + dy < GRID[1]
                           and not occupied[x + dx, y + dy]})
        x, y = frontier[int(rng.integers(len(frontier)))]
        occupied[x, y] = True
        if _has_hole(occupied):
            occupied[x, y] = False
    return occupied


def _has_hole(occupied: npt.NDArray[np.bool_]) -> bool:
    """Whether some empty cell is cut off from the outside (flood fill from the border)."""
    empty = np.pad(~occupied, 1, constant_values=True)
    reached = np.zeros_like(empty)
    stack = [(0, 0)]
    reached[0, 0] = True
    while stack:
        x, y = stack.pop()
        for dx, dy in _STEPS:
            u, v = x + dx, y + dy
            if (0 <= u < empty.shape[0] and 0 <= v < empty.shape[1] and empty[u, v]
                    and not reached[u, v]):
                reached[u, v] = True
                stack.append((u, v))
    return bool((empty & ~reached).any())


def _outline(occupied: npt.NDArray[np.bool_]) -> npt.NDArray[np.int64]:
    """Every grid point along the blob's outline, in anticlockwise order, shape (K, 2) (its
    corners: ``_turns``); empty when the outline touches itself at a grid point."""
    edges: dict[tuple[int, int], tuple[int, int]] = {}
    count = 0
    # Unit edges with the blob on their left: bottom, right, top and left sides of each cell.
    for x, y in zip(*np.nonzero(occupied)):
        x, y = int(x), int(y)
        sides = (((x, y), (x + 1, y), (x, y - 1)), ((x + 1, y), (x + 1, y + 1), (x + 1, y)),
                 ((x + 1, y + 1), (x, y + 1), (x, y + 1)), ((x, y + 1), (x, y), (x - 1, y)))
        for start, end, (nx, ny) in sides:
            if not (0 <= nx < GRID[0] and 0 <= ny < GRID[1] and occupied[nx, ny]):
                edges[start] = end
                count += 1
    if len(edges) != count:  # two edges leave one grid point: the outline pinches
        return np.zeros((0, 2), dtype=np.int64)
    first = next(iter(edges))
    loop = [first]
    while (point := edges[loop[-1]]) != first:
        loop.append(point)
    return np.array(loop, dtype=np.int64)


def _turns(path: npt.NDArray[np.int64]) -> npt.NDArray[np.bool_]:
    """Which points of the closed grid path ``path`` (K, 2) are corners (the path turns there)."""
    if not len(path):
        return np.zeros(0, dtype=bool)
    incoming = path - np.roll(path, 1, axis=0)
    outgoing = np.roll(path, -1, axis=0) - path
    return incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0] != 0


def _bspline(points: FloatArray, samples: int = 16) -> FloatArray:
    """Dense points of the closed polygon ``points``' quadratic uniform B-spline: from the
    midpoint ``M_i`` of each side to the next one's ``M_{i+1}``, pulled towards the vertex
    ``P_{i+1}`` between them, ``B(t) = (1 - t)^2 M_i + 2 t (1 - t) P_{i+1} + t^2 M_{i+1}``,
    ``samples`` points per side (without ``t = 1``: the next piece starts there).

    Along collinear points it is straight; at a right angle with half-sides ``a`` its radius
    is ``a / sqrt(2)`` (``|B' x B''| / |B'|^3`` at ``t = 1/2``, with ``B' = (a, a)`` and
    ``B'' = (-2a, 2a)``)."""
    following = np.roll(points, -1, axis=0)
    mid = 0.5 * (points + following)
    t = (np.arange(samples) / samples)[None, :, None]
    curve = ((1 - t) ** 2 * mid[:, None] + 2 * t * (1 - t) * following[:, None]
             + t ** 2 * np.roll(mid, -1, axis=0)[:, None])
    return curve.reshape(-1, 2)


def _rounded(points: FloatArray, radii: FloatArray, step: float = 0.05) -> FloatArray:
    """Dense points of the closed polygon ``points`` with each corner replaced by a circular
    arc tangent to both sides: radius ``radii[i]``, capped at half of either side, so that the
    arc starts ``r`` before the corner and ends ``r`` after it (right-angle corners).

    For a corner ``P`` with unit directions ``d_in``, ``d_out`` and turn ``s`` (+1 left, -1
    right), the arc's centre is ``P - r d_in + s r n(d_in)`` with ``n`` the left normal, and it
    sweeps 90 deg from ``P - r d_in`` to ``P + r d_out``.
    """
    count = len(points)
    sides = np.roll(points, -1, axis=0) - points
    lengths = np.linalg.norm(sides, axis=1)
    directions = sides / lengths[:, None]
    radii = np.minimum(radii[:count], 0.5 * np.minimum(lengths, np.roll(lengths, 1)))
    dense = []
    for i in range(count):
        d_in, d_out, r = directions[i - 1], directions[i], radii[i]
        turn = np.sign(d_in[0] * d_out[1] - d_in[1] * d_out[0])
        normal = np.array([-d_in[1], d_in[0]]) * turn
        centre = points[i] - r * d_in + r * normal
        start = np.arctan2(-normal[1], -normal[0])
        angles = start + turn * np.linspace(0.0, 0.5 * np.pi, max(3, round(0.5 * np.pi * r / step)))
        # Without its end point: the next piece starts there (no repeated points).
        dense.append(centre + r * np.c_[np.cos(angles[:-1]), np.sin(angles[:-1])])
        # The straight to the next corner, without its ends (the arcs' tangent points).
        straight = lengths[i] - r - radii[(i + 1) % count]
        steps = int(straight / step)
        if steps > 1:
            along = r + straight * np.arange(0, steps) / steps
            dense.append(points[i] + along[:, None] * d_out)
    return np.concatenate(dense)
