"""Procedural and hand-designed track geometry: smooth closed curves, checks and random tracks.

Pure numpy (no cv2, no pymunk), so it sits at the bottom of the layering rule beside ``track/shape.py``.

* :func:`smooth_closed_curve` turns a handful of control points into a C2-smooth closed centre line
  sampled at uniform arc-length spacing (periodic interpolating cubic spline).
* :func:`curvature`, :func:`find_crossings`, :func:`border_polylines` and :func:`measure_track`
  are the shared geometric checks used by the generator, by ``tracks/design.py`` and by the tests;
  they live in :mod:`h2h_racing.track.metrics` and are importable from here too.
* :func:`random_track` draws a seeded random closed track for training generalisation.

Results are plain numpy arrays wrapped in the frozen :class:`TrackSpec`, so that ``h2h_racing.track.shape.Track``
can wrap them without this module depending on it.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.track.metrics import (
    TrackMetrics,
    _as_points,
    border_polylines,
    closed_length,
    curvature,
    find_crossings,
    left_normals,
    measure_track,
    min_clearance,
    min_radius_of_curvature,
    signed_area,
)

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "MIN_RADIUS_FLOOR", "RADIUS_TO_HALF_WIDTH", "TRACK_FORMAT", "TrackMetrics", "TrackSpec", "border_polylines",
    "closed_length", "curvature", "find_crossings", "left_normals", "measure_track", "min_clearance",
    "min_radius_of_curvature", "random_track", "signed_area", "smooth_closed_curve",
]

TRACK_FORMAT = "h2h-racing-track/1"
"""Value of the ``"format"`` key of the JSON track files written by ``tracks/design.py``."""

MIN_RADIUS_FLOOR = 0.6
"""Smallest centre-line radius of curvature [m] a random track may have, whatever its width."""

RADIUS_TO_HALF_WIDTH = 1.2
"""Required ratio of the minimum radius of curvature to the half-width of the track.

The inner border of a corner of radius ``R`` is an offset curve of radius ``R - w/2``; ``R > w/2`` keeps it
regular (no cusp), and the 20 % margin keeps the inner wall from degenerating into a point.
"""


@dataclass(frozen=True, slots=True)
class TrackSpec:
    """Geometry of a closed track as plain arrays (what ``Track`` wraps).

    The loop is closed implicitly: the first vertex is not repeated, and the driving direction is the
    order of the vertices.
    """

    name: str
    """Short identifier, e.g. ``"speedway"`` or ``"random-1a2b3c4d"``."""
    description: str
    """One human-readable sentence."""
    centre: FloatArray
    """Centre line, shape (M, 2) as (x [m], y [m]), read-only."""
    width_left: FloatArray
    """Distance from the centre line to the left border, shape (M,) [m], read-only."""
    width_right: FloatArray
    """Distance from the centre line to the right border, shape (M,) [m], read-only."""

    def __post_init__(self) -> None:
        """Validate shapes and values, convert to float64 and freeze the arrays."""
        centre = np.array(self.centre, dtype=np.float64)
        if centre.ndim != 2 or centre.shape[1] != 2 or centre.shape[0] < 3:
            raise ValueError(f"Expected centre of shape (M >= 3, 2), got {centre.shape}")
        num_points = centre.shape[0]
        widths = {}
        for key in ("width_left", "width_right"):
            value = np.array(getattr(self, key), dtype=np.float64)
            if value.shape != (num_points,):
                raise ValueError(f"Expected {key} of shape ({num_points},), got {value.shape}")
            if not np.all(np.isfinite(value)) or np.any(value <= 0):
                raise ValueError(f"Expected {key} > 0 and finite everywhere, got min {value.min()}")
            widths[key] = value
        if not np.all(np.isfinite(centre)):
            raise ValueError("Expected a finite centre line, got NaN or inf")
        for key, value in (("centre", centre), *widths.items()):
            value.flags.writeable = False
            object.__setattr__(self, key, value)

    @property
    def length(self) -> float:
        """Lap length of the closed centre line [m]."""
        return closed_length(self.centre)

    def to_dict(self, decimals: int = 4) -> dict[str, Any]:
        """Return the ``h2h-racing-track/1`` JSON document of this track.

        Args:
            decimals: Coordinates and widths are rounded to ``10**-decimals`` m.

        Returns:
            ``{"format", "name", "description", "x", "y", "width_left", "width_right"}`` with plain lists.
        """

        def rounded(values: FloatArray) -> list[float]:
            return [float(v) for v in np.round(values, decimals)]

        return {
            "format": TRACK_FORMAT,
            "name": self.name,
            "description": self.description,
            "x": rounded(self.centre[:, 0]),
            "y": rounded(self.centre[:, 1]),
            "width_left": rounded(self.width_left),
            "width_right": rounded(self.width_right),
        }


# ----------------------------------------------------------------------------------------------------------
# Smooth closed curves
# ----------------------------------------------------------------------------------------------------------


def _periodic_spline_moments(points: FloatArray, knots_step: FloatArray) -> FloatArray:
    """Solve for the second derivatives ``M_i`` of the periodic interpolating cubic spline.

    With ``h_i = t_{i+1} - t_i`` and ``P_i`` the control points, C2 continuity at every knot gives
    (indices modulo K)::

        h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 [(P_{i+1} - P_i)/h_i - (P_i - P_{i-1})/h_{i-1}]

    a cyclic tridiagonal system, strictly diagonally dominant, so always solvable. K is small (tens),
    so a dense solve is simplest.
    """
    num = points.shape[0]
    h = knots_step
    h_prev = np.roll(h, 1)
    idx = np.arange(num)
    system = np.zeros((num, num))
    system[idx, (idx - 1) % num] += h_prev
    system[idx, idx] += 2.0 * (h_prev + h)
    system[idx, (idx + 1) % num] += h
    slope = (np.roll(points, -1, axis=0) - points) / h[:, None]
    rhs = 6.0 * (slope - np.roll(slope, 1, axis=0))
    return np.linalg.solve(system, rhs)


def _eval_spline(
    points: FloatArray, moments: FloatArray, knots: FloatArray, h: FloatArray, t: FloatArray
) -> FloatArray:
    """Evaluate the periodic cubic spline at parameters ``t`` in ``[0, knots[-1])``.

    On span ``i`` with ``u = t - t_i`` (standard second-derivative form)::

        S(u) = M_i (h-u)^3/(6h) + M_{i+1} u^3/(6h) + (P_i/h - M_i h/6)(h-u) + (P_{i+1}/h - M_{i+1} h/6) u
    """
    num = points.shape[0]
    span = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, num - 1)
    nxt = (span + 1) % num
    hs = h[span][:, None]
    u = (t - knots[span])[:, None]
    v = hs - u
    m0, m1 = moments[span], moments[nxt]
    p0, p1 = points[span], points[nxt]
    return m0 * v**3 / (6 * hs) + m1 * u**3 / (6 * hs) + (p0 / hs - m0 * hs / 6) * v + (p1 / hs - m1 * hs / 6) * u


def smooth_closed_curve(control_points: npt.ArrayLike, spacing: float = 0.05) -> FloatArray:
    """Interpolate a C2-smooth closed curve through control points, sampled at uniform arc length.

    The curve is the periodic interpolating cubic spline with chord-length parameterisation: it passes
    exactly through every control point, has continuous curvature (no steering jumps at the knots), and
    keeps the order of the control points, so the direction of travel is the order given. The first
    returned vertex is the first control point; the last vertex is not a repeat of the first.

    Args:
        control_points: Control points, shape (K, 2) with K >= 3, as (x [m], y [m]). Do not repeat the first
            point at the end; consecutive points must be distinct.
        spacing: Target distance between consecutive output vertices [m], > 0.

    Returns:
        Vertices of the closed curve, shape (M, 2) [m], with ``M = round(L / spacing)`` for lap length ``L``;
        every gap, including the closing one, is within ~1e-3 relative of ``L / M``.

    Raises:
        ValueError: On a bad shape, non-finite values, repeated consecutive points or ``spacing <= 0``.

    >>> angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    >>> curve = smooth_closed_curve(np.c_[np.cos(angles), np.sin(angles)], spacing=0.1)
    >>> curve.shape, bool(np.allclose(np.hypot(curve[:, 0], curve[:, 1]), 1.0, atol=1e-3))
    ((63, 2), True)
    """
    points = _as_points(control_points, "control_points")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"Expected spacing > 0 [m], got {spacing}")
    h = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
    if np.any(h <= 1e-9):
        bad = np.flatnonzero(h <= 1e-9).tolist()
        raise ValueError(
            f"Expected distinct consecutive control points, got repeats after indices {bad} "
            "(the loop closes implicitly; do not repeat the first point at the end)"
        )
    knots = np.concatenate([[0.0], np.cumsum(h)])
    moments = _periodic_spline_moments(points, h)

    # Dense evaluation (about spacing/10 between samples, at least 16 per span) to tabulate arc length
    # s(t); then invert s(t) by linear interpolation and evaluate the spline exactly at the found t.
    per_span = np.maximum(16, np.ceil(h / (spacing / 10.0)).astype(np.int64))
    t_dense = np.concatenate(
        [np.linspace(knots[i], knots[i + 1], n, endpoint=False) for i, n in enumerate(per_span)] + [knots[-1:]]
    )
    dense = _eval_spline(points, moments, knots, h, np.minimum(t_dense, np.nextafter(knots[-1], 0.0)))
    dense[-1] = points[0]
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    total = arc[-1]
    num_out = max(3, round(total / spacing))
    s_out = np.arange(num_out) * (total / num_out)
    t_out = np.interp(s_out, arc, t_dense)
    curve = _eval_spline(points, moments, knots, h, t_out)
    curve[0] = points[0]
    return curve


# ----------------------------------------------------------------------------------------------------------
# Random tracks
# ----------------------------------------------------------------------------------------------------------


def _start_on_straight(centre: FloatArray, window: float) -> FloatArray:
    """Roll the loop so that vertex 0 sits where the curvature, averaged over ``+-window`` m, is smallest.

    Start lines belong on straights (as on every DeepRacer track), so the grid does not start in a bend.
    """
    kappa = np.abs(curvature(centre))
    spacing = closed_length(centre) / len(centre)
    half = max(1, round(window / spacing))
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    padded = np.concatenate([kappa[-half:], kappa, kappa[:half]])
    smoothed = np.convolve(padded, kernel, mode="valid")
    return np.roll(centre, -int(np.argmin(smoothed)), axis=0)


def _add_chicanes(rng: np.random.Generator, centre: FloatArray, count: int) -> FloatArray:
    """Shift ``count`` stretches of the closed centre line sideways into chicanes.

    Each chicane is the lateral offset ``y(u) = A sin(2 pi u) (1 - cos(2 pi u)) / 2`` for
    ``u = (s - s0) / l`` in [0, 1] along the left normal: one swerve out and back, depth ``A``
    in +-[0.1, 0.35] m, length ``l`` in [2, 4] m, start ``s0`` anywhere on the lap. ``y`` and
    its first two derivatives vanish at both ends (``y ~ 2 pi^3 A u^3`` near u = 0), so the
    curvature stays continuous; inside, the added curvature is about ``y'' = A / l^2 * 2 pi^2
    (2 sin 4 pi u - sin 2 pi u)``, up to ``54 A / l^2`` (1.7 /m for 0.2 m over 2.5 m), which
    the caller's radius check bounds. Overlapping chicanes add up.
    """
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centre, axis=0), axis=1))])
    lap = closed_length(centre)
    offset = np.zeros(len(centre))
    for _ in range(count):
        length = rng.uniform(2.0, 4.0)
        depth = rng.uniform(0.1, 0.35) * (1.0 if rng.random() < 0.5 else -1.0)
        u = ((arc - rng.uniform(0.0, lap)) % lap) / length
        inside = u < 1.0
        phase = 2 * np.pi * u[inside]
        offset[inside] += depth * np.sin(phase) * (1.0 - np.cos(phase)) / 2
    return centre + left_normals(centre) * offset[:, None]


def _rejection(centre: FloatArray, width: float, min_radius: float) -> str | None:
    """Why a candidate loop of a random track is refused, or None if it is valid: ``"radius"``
    (a corner tighter than ``min_radius`` [m]), ``"clearance"`` (parts more than ``3 * width``
    apart along the lap closer than ``width + 0.25`` m: overlapping tarmac, no room for the
    walls) or ``"crossing"`` (the centre line or the borders, ``width / 2`` each side,
    self-intersect)."""
    if min_radius_of_curvature(centre) < min_radius:
        return "radius"
    if min_clearance(centre[::2], exclude_arc=3 * width) < width + 0.25:
        return "clearance"
    left, right = border_polylines(centre, 0.5 * width, 0.5 * width)
    if len(find_crossings(centre)) or len(find_crossings(left, right)):
        return "crossing"
    return None


def _width_profile(rng: np.random.Generator, count: int, narrowest: float, widest: float) -> FloatArray:
    """A smooth periodic width profile over ``count`` vertices of a loop, spanning exactly
    [``narrowest``, ``widest``] [m]: ``g(u) = sum_k a_k cos(2 pi k u + phi_k)`` for k = 1..K, K in
    [1, 3], ``a_k`` in [0.3, 1], rescaled linearly so that min g -> narrowest and max g -> widest."""
    u = np.arange(count) / count
    harmonics = int(rng.integers(1, 4))
    amplitudes = rng.uniform(0.3, 1.0, harmonics)
    phases = rng.uniform(0.0, 2 * np.pi, harmonics)
    k = np.arange(1, harmonics + 1)
    g = (amplitudes[:, None] * np.cos(2 * np.pi * k[:, None] * u[None, :] + phases[:, None])).sum(axis=0)
    return narrowest + (widest - narrowest) * (g - g.min()) / (g.max() - g.min())


def random_track(
    rng: np.random.Generator,
    *,
    length_range: tuple[float, float] = (20.0, 45.0),
    width: float | tuple[float, float] = 1.0,
    min_radius: float | None = None,
    spacing: float = 0.05,
    max_tries: int = 100,
    radius_range: tuple[float, float] = (0.55, 1.0),
    chicanes: tuple[int, int] = (0, 0),
) -> TrackSpec:
    """Draw a random closed track: a smoothed, star-shaped loop scaled to a random lap length.

    Each try draws K in [8, 14] control points at jittered, sorted angles around a circle with random radii
    in ``radius_range`` (so the loop runs counter-clockwise and cannot wind twice), interpolates them with
    :func:`smooth_closed_curve`, scales the loop to a lap length drawn uniformly from ``length_range``, and
    adds a number of chicanes drawn in ``chicanes`` (:func:`_add_chicanes`), and accepts it only if

    * its smallest radius of curvature is at least ``min_radius``;
    * parts of the track that are more than ``3 * width`` apart along the loop stay at least
      ``width + 0.25`` m apart (no overlapping tarmac, room for the walls; the widest ``width``
      when it varies);
    * neither the centre line nor the borders (``centre +- normal * width / 2``) self-intersect.

    Vertex 0 is moved to the straightest part of the loop, where a start line belongs. The result depends
    only on the generator state, so the same seed gives bit-identical arrays.

    Args:
        rng: Source of randomness; it is advanced, never replaced.
        length_range: ``(low, high)`` bounds of the lap length [m], ``0 < low <= high``.
        width: Total track width [m], > 0; DeepRacer tracks are 0.76-1.07 m. A ``(narrowest,
            widest)`` pair makes the width vary smoothly along the lap between the two (as on
            the catalogue's ``varying``): a random periodic profile of 1-3 cosine harmonics of
            the lap, rescaled so that it reaches both bounds; both sides stay equal.
        min_radius: Smallest allowed radius of curvature [m]. Defaults to
            ``max(0.6, 1.2 * widest / 2)``; values below ``widest / 2`` are rejected (the inner
            border would fold).
        spacing: Distance between centre-line vertices [m], > 0.
        max_tries: Candidate loops to draw before giving up, >= 1.
        radius_range: ``(low, high)`` radii of the control points, relative to the loop's
            size, ``0 < low <= high``. A smaller ``low`` cuts deeper bays into the loop: tight
            right-handers between left-handers (S-bends), as on the catalogue's ``technical``.
        chicanes: ``(fewest, most)`` chicanes per loop, ``0 <= fewest <= most``: left-right (or
            right-left) wiggles of the centre line 2-4 m long, 0.1-0.35 m deep, anywhere on the
            lap, as on ``technical``'s start straight. Smooth loops have none.

    Returns:
        A :class:`TrackSpec` named ``"random-<8 hex digits of the geometry hash>"``.

    Raises:
        ValueError: On invalid arguments.
        RuntimeError: When no valid track was found in ``max_tries`` tries.
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"Expected rng to be a numpy.random.Generator, got {type(rng).__name__}; use np.random.default_rng(seed)"
        )
    low, high = (float(v) for v in length_range)
    if not (0 < low <= high and np.isfinite(high)):
        raise ValueError(f"Expected length_range = (low, high) with 0 < low <= high [m], got {length_range}")
    bounds = (width, width) if np.isscalar(width) else tuple(width)  # type: ignore[arg-type]
    if not (len(bounds) == 2 and all(np.isfinite(b) and b > 0 for b in bounds)
            and bounds[0] <= bounds[1]):
        raise ValueError(f"Expected width > 0 [m] or (narrowest, widest) with 0 < narrowest <= "
                         f"widest [m], got {width}")
    requested = width
    narrowest, width = float(bounds[0]), float(bounds[1])
    half_width = 0.5 * width
    if min_radius is None:
        min_radius = max(MIN_RADIUS_FLOOR, RADIUS_TO_HALF_WIDTH * half_width)
    if not min_radius > half_width:
        raise ValueError(
            f"Expected min_radius > width / 2 = {half_width} m (else the inner border folds), got {min_radius}"
        )
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"Expected spacing > 0 [m], got {spacing}")
    if max_tries < 1:
        raise ValueError(f"Expected max_tries >= 1, got {max_tries}")
    r_low, r_high = (float(v) for v in radius_range)
    fewest, most = chicanes
    if not (isinstance(fewest, (int, np.integer)) and isinstance(most, (int, np.integer))
            and 0 <= fewest <= most):
        raise ValueError(f"Expected chicanes = (fewest, most) integers with 0 <= fewest <= most, got {chicanes}")
    if not 0 < r_low <= r_high:
        raise ValueError(f"Expected radius_range = (low, high) with 0 < low <= high, got {radius_range}")

    rejections = {"radius": 0, "clearance": 0, "crossing": 0}
    for _ in range(max_tries):
        num_points = int(rng.integers(8, 15))
        step = 2 * np.pi / num_points
        angles = np.arange(num_points) * step + rng.uniform(-0.3, 0.3, num_points) * step
        radii = rng.uniform(r_low, r_high, num_points)
        unit = np.c_[radii * np.cos(angles), radii * np.sin(angles)]
        target = float(rng.uniform(low, high))
        # The spline is scale-covariant (chord-length knots scale with the points), so scaling the control
        # points by target / L0 scales the whole curve and its lap length exactly.
        coarse = smooth_closed_curve(unit, spacing=closed_length(unit) / 400)
        centre = smooth_closed_curve(unit * (target / closed_length(coarse)), spacing=spacing)
        # No draw without chicanes: older arguments give the same tracks.
        if most > 0:
            centre = _add_chicanes(rng, centre, int(rng.integers(fewest, most + 1)))
        rejected = _rejection(centre, width, min_radius)
        if rejected:
            rejections[rejected] += 1
            continue
        centre = _start_on_straight(centre, window=1.0)
        digest = hashlib.sha256(np.round(centre, 4).tobytes()).hexdigest()[:8]
        widths = np.full(len(centre), half_width)
        wide = f"{width:.2f} m wide"
        if narrowest < width:
            widths = 0.5 * _width_profile(rng, len(centre), narrowest, width)
            wide = f"{narrowest:.2f}-{width:.2f} m wide"
            digest = hashlib.sha256(np.round(centre, 4).tobytes() + np.round(widths, 4).tobytes()).hexdigest()[:8]
        return TrackSpec(
            name=f"random-{digest}",
            description=(
                f"Random closed track, {closed_length(centre):.1f} m lap, {wide}, "
                f"min radius {min_radius_of_curvature(centre):.2f} m."
            ),
            centre=centre,
            width_left=widths,
            width_right=widths.copy(),
        )
    raise RuntimeError(
        f"random_track found no valid track in {max_tries} tries (rejected: {rejections}) for "
        f"length_range={length_range}, width={requested}, min_radius={min_radius}; "
        "try a longer length_range, a smaller width or min_radius, or more max_tries"
    )
