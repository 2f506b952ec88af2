"""Racing lines: a minimum-curvature path within the track and a speed profile along it.

A racing line is a lateral offset ``d*(s)`` from the centre line on a uniform grid of
centre-line arc positions ``s_i = i L / K``. With ``C_i`` the centre point and ``n_i`` the
left normal at ``s_i``, the line's points are ``P_i = C_i + d_i n_i``: linear in ``d``. The
normals are :func:`smooth_frame`'s, which turn evenly along the lap, not the track's own,
which turn by a whole corner at each waypoint (tracks drawn through waypoints 30-80 cm apart,
as DeepRacer's routes, would otherwise get a line kept to the outside of every bend); the
line is then handed to the drivers as offsets in the track's own frame (:func:`track_offsets`).
The line minimises the summed squared second differences of its points (a discrete
curvature energy; for near-uniform spacing ``|P_{i+1} - 2 P_i + P_{i-1}| ~ kappa_i ds^2``)

    minimise   sum_i |P_{i+1}(d) - 2 P_i(d) + P_{i-1}(d)|^2 + eps |d|^2
    subject to -(w_right(s_i) - margin) <= d_i <= w_left(s_i) - margin,

a box-constrained convex quadratic programme. Its Hessian couples each point only with its
two neighbours on each side, round the loop (cyclic pentadiagonal), so it is kept as three
bands and solved by ADMM with a banded factorisation (:mod:`h2h_racing.policies.banded`):
``O(K)`` memory and work per iteration, seconds for the ~2,500 points of a 500 m circuit
where dense matrices took minutes. This is the min-curvature formulation of Braghin et al.
(2008) and Heilmeier et al. (2019), without their splines.

The speed profile is the classic quasi-steady-state one: the cornering limit
``v = min(v_max, sqrt(a_lat / |kappa|))`` followed by a backward (braking) and a forward
(acceleration) pass over the closed loop; see :func:`speed_profile`.

Pure numpy; results are cached per ``Track`` object (tracks are immutable).
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from h2h_racing.config.env import CarParams
from h2h_racing.policies.banded import box_qp
from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]

GRAVITY = 9.81
"""Standard gravity [m/s^2]."""

_CACHE: weakref.WeakKeyDictionary[Track, dict[tuple[Any, ...], Any]] = (
    weakref.WeakKeyDictionary())
"""Per track: its racing lines by setting, and its minimum-curvature paths (read-only)."""


@dataclass(frozen=True, eq=False)
class RaceLine:
    """A closed racing line on a track with its speed profile (arrays owned, read-only).

    Attributes:
        s: Centre-line arc position of each grid point, shape (K,) [m], uniform in [0, L).
        d: Lateral offset of the line from the centre line, shape (K,) [m], left positive.
        points: World points of the line, shape (K, 2) [m].
        curvature: Signed curvature of the line at each point, shape (K,) [1/m].
        path_length: Length of the line itself (not the centre line) [m].
        speed: Target speed at each point, shape (K,) [m/s].
        lap_time: Lap time of the speed profile driven exactly [s] (a lower bound for a
            real car, which lags the profile).
        track_length: Centre-line length L [m].
    """

    s: FloatArray
    d: FloatArray
    points: FloatArray
    curvature: FloatArray
    path_length: float
    speed: FloatArray
    lap_time: float
    track_length: float

    def _interp(self, values: FloatArray, s: FloatArray,
                closed: FloatArray | None = None) -> FloatArray:
        """Periodic linear interpolation of a per-grid-point quantity at arc positions ``s``
        (``closed``: ``values`` with its first value appended, if at hand)."""
        if closed is None:
            closed = np.append(values, values[0])
        return np.interp(np.remainder(s, self.track_length), self._grid, closed)

    @functools.cached_property
    def _grid(self) -> FloatArray:
        """``s`` closed by the lap length (the drivers interpolate every step: built once)."""
        return np.append(self.s, self.track_length)

    @functools.cached_property
    def _closed(self) -> dict[str, FloatArray]:
        """``d`` and ``speed`` closed by their first value."""
        return {"d": np.append(self.d, self.d[0]), "speed": np.append(self.speed, self.speed[0])}

    def offset_at(self, s: FloatArray) -> FloatArray:
        """Return the line's lateral offset [m] at centre-line arc positions ``s`` (any shape)."""
        return self._interp(self.d, s, self._closed["d"])

    def speed_at(self, s: FloatArray) -> FloatArray:
        """Return the profile speed [m/s] at centre-line arc positions ``s`` (any shape)."""
        return self._interp(self.speed, s, self._closed["speed"])

    def point_at(self, s: FloatArray) -> FloatArray:
        """Return the line's world points at arc positions ``s``, shape (..., 2) [m]."""
        return np.stack([self._interp(self.points[:, 0], s),
                         self._interp(self.points[:, 1], s)], axis=-1)

    def min_speed_ahead(self, s: FloatArray, horizon: FloatArray) -> FloatArray:
        """Return the lowest profile speed over ``[s, s + horizon]`` (both shape (E,)) [m/s].

        The window is sampled on the grid spacing, so no corner between samples is missed.
        """
        ds = self.track_length / len(self.s)
        count = max(1, math.ceil(float(np.max(horizon, initial=0.0)) / ds)) + 1
        frac = np.linspace(0.0, 1.0, count)
        samples = s[..., None] + horizon[..., None] * frac
        return self.speed_at(samples).min(axis=-1)


def min_curvature_offsets(track: Track, ds: float = 0.2, margin: float = 0.12,
                          regularisation: float = 1e-4, reweightings: int = 3,
                          peak_emphasis: float = 0.0,
                          ) -> tuple[FloatArray, FloatArray]:
    """Return the minimum-curvature lateral offsets of ``track`` (see the module docstring).

    The grid is uniform in centre-line ``s``, but the line's own spacing is not: on the
    inside of a corner it is shorter by ``1 - kappa d``, and an unweighted sum of squared
    second differences would under-count that part (``|D2 P| ~ kappa l^2``). The discrete
    bending energy ``sum kappa_i^2 l_i = sum |D2 P_i|^2 / l_i^3`` is therefore minimised by
    iterative re-weighting: each pass weights point i by ``(ds / l_i)^3`` from the previous
    pass's line.

    Args:
        track: The track.
        ds: Target grid spacing along the centre line [m].
        margin: Distance kept from each border by the line's centre [m].
        regularisation: Weight of ``|d|^2`` relative to the curvature energy; it makes the
            problem strictly convex and keeps the line central where curvature does not
            care (on long straights).
        reweightings: Re-weighting passes after the first solve.

    The offsets are along :func:`smooth_frame`'s normals, not the track's own (which turn at
    each waypoint): the line's points are ``centre + d * normal`` of that frame, and
    :func:`compute_race_line` re-expresses them in the track's frame.

    Returns:
        ``(s, d)``: the grid, shape (K,) [m], and the offsets in :func:`smooth_frame`,
        shape (K,) [m].

    Raises:
        ValueError: If the track is narrower than ``2 * margin`` somewhere.
    """
    length = track.length
    k = max(8, round(length / ds))
    step = length / k
    s = np.arange(k) * step
    left, right = track.half_widths_at(s)
    hi = left - margin
    lo = -(right - margin)
    if np.any(hi < lo):
        raise ValueError(f"track {track.name!r} is narrower than 2 * margin = {2 * margin} m "
                         f"somewhere; use a smaller margin")
    centre, normal = smooth_frame(track, s)
    d = np.zeros(k)
    for _ in range(reweightings + 1):
        points = centre + d[:, None] * normal
        seg = np.hypot(*(np.roll(points, -1, axis=0) - points).T)
        local = 0.5 * (seg + np.roll(seg, 1))
        weight = (step / local) ** 3
        if peak_emphasis > 0 and np.any(d):
            kappa, _ = line_curvature(points)
            weight = weight * (np.abs(kappa) / np.mean(np.abs(kappa))) ** peak_emphasis
        diag, off1, off2, lin = curvature_qp_bands(centre, normal, weight, step)
        d = box_qp(diag + regularisation, off1, off2, lin, lo, hi, d,
                   rho=1e-4 * (step / 0.1) ** 4)
    return s, d


def smooth_frame(track: Track, s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return centre points and smoothly turning unit left normals at arc positions ``s``.

    The track's own normal (:meth:`Track.heading_at`) is its segment's, turned through each
    waypoint within 1 cm: the exact inverse of the env's projection, but on a track drawn
    through waypoints tens of cm apart it turns by the whole corner angle at each waypoint.
    Offset points ``C + d n`` in that frame run backwards on the inside of every waypoint (by
    ``2 |d| tan(turn / 2)``: 12 cm at 0.38 m from a 0.6 m-gap waypoint on a 1 m-radius bend)
    and leave a gap on the outside, so the curvature energy sees a zig-zag wherever the line
    takes the inside and the optimiser keeps it to the outside of every bend: a one-sided,
    slow line. Here the heading is interpolated linearly in ``s`` between segment midpoints
    instead, so the normal turns evenly along the lap; on a finely drawn track (5 cm
    waypoints) the two frames differ by well under a millimetre at the offsets used.

    A point ``C + d n`` of this frame is at most ``|d|`` from the centre polyline (``C`` is
    on it), so the optimiser's bounds on ``d`` keep the line on the track in either frame.

    Args:
        track: The track.
        s: Arc positions, shape (K,) [m].

    Returns:
        ``(centre, normal)``, each shape (K, 2).
    """
    length = track.length
    vertex_s = np.append(track.vertex_s, length)
    seg = np.diff(vertex_s)
    keep = seg > 1e-9
    mids = (vertex_s[:-1] + 0.5 * seg)[keep]
    psi = np.unwrap(track.heading_at(mids))
    # One lap turns the heading by a multiple of 2 pi (the wrap from the last segment to
    # the first is a small turn, as every other).
    turn = psi[-1] - psi[0] + np.mod(psi[0] - psi[-1] + math.pi, 2.0 * math.pi) - math.pi
    knots = np.concatenate([mids - length, mids, mids + length])
    values = np.concatenate([psi - turn, psi, psi + turn])
    heading = np.interp(np.remainder(s, length), knots, values)
    normal = np.stack([-np.sin(heading), np.cos(heading)], axis=1)
    return track.point_at(s, 0.0), normal


def curvature_qp_bands(centre: FloatArray, normal: FloatArray, weight: FloatArray,
                       step: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Bands of the Hessian and the linear term of the weighted curvature energy in ``d``.

    With the circulant second difference ``(D2 u)_i = u_{i-1} - 2 u_i + u_{i+1}``, the line's
    second differences are ``b + A d`` with ``b = D2 C / step^2`` and ``A = [D2 diag(n_x);
    D2 diag(n_y)] / step^2``, and the energy ``sum_i w_i |b_i + (A d)_i|^2 / 2`` has the
    Hessian ``H = A' W A`` and linear term ``A' W b``. Row i of ``D2`` touches points
    ``i-1, i, i+1`` with weights ``(1, -2, 1)``, so H is cyclic pentadiagonal::

        H[j, j]     = (w_{j-1} + 4 w_j + w_{j+1}) / step^4
        H[j, j + 1] = -2 (w_j + w_{j+1}) (n_j . n_{j+1}) / step^4
        H[j, j + 2] = w_{j+1} (n_j . n_{j+2}) / step^4
        lin[j]      = n_j . (w_{j-1} b_{j-1} - 2 w_j b_j + w_{j+1} b_{j+1}) / step^2

    (indices modulo K; see :class:`h2h_racing.policies.banded.CyclicPentadiagonal` for the
    band layout).

    Args:
        centre: Centre points, shape (K, 2) [m].
        normal: Unit left normals, shape (K, 2).
        weight: Weight of each point's squared second difference, shape (K,).
        step: Grid spacing [m].

    Returns:
        ``(diag, off1, off2, lin)``, each shape (K,).
    """
    def ahead(v: FloatArray, n: int) -> FloatArray:
        return np.roll(v, -n, axis=0)

    w_next, w_prev = ahead(weight, 1), ahead(weight, -1)
    s4 = step**4
    diag = (w_prev + 4.0 * weight + w_next) / s4
    off1 = -2.0 * (weight + w_next) * np.sum(normal * ahead(normal, 1), axis=1) / s4
    off2 = w_next * np.sum(normal * ahead(normal, 2), axis=1) / s4
    b = (ahead(centre, -1) - 2.0 * centre + ahead(centre, 1)) / step**2
    wb = weight[:, None] * b
    lin = np.sum(normal * (ahead(wb, -1) - 2.0 * wb + ahead(wb, 1)), axis=1) / step**2
    return diag, off1, off2, lin


def line_curvature(points: FloatArray, smooth: int = 2) -> tuple[FloatArray, FloatArray]:
    """Return the signed curvature and segment lengths of a closed polyline.

    Curvature at vertex i is the turn between its two segments over their mean length,
    averaged over ``2 * smooth + 1`` vertices to remove grid noise.

    Args:
        points: Closed polyline, shape (K, 2) [m], first point not repeated.
        smooth: Half-width of the circular moving average [vertices].

    Returns:
        ``(curvature (K,) [1/m], segment_length (K,) [m])``; segment i runs from point i
        to point i + 1.
    """
    seg = np.roll(points, -1, axis=0) - points
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    turn = np.mod(heading - np.roll(heading, 1) + math.pi, 2.0 * math.pi) - math.pi
    kappa = turn / np.maximum(0.5 * (seg_len + np.roll(seg_len, 1)), 1e-9)
    if smooth > 0:
        width = 2 * smooth + 1
        kappa = sum(np.roll(kappa, j) for j in range(-smooth, smooth + 1)) / width
    return kappa, seg_len


def speed_profile(curvature: FloatArray, seg_len: FloatArray, v_max: float, a_lat: float,
                  a_accel: float, a_brake: float) -> FloatArray:
    """Return the quasi-steady-state speed profile of a closed path.

    ``v_i = min(v_max, sqrt(a_lat / |kappa_i|))``, then a backward pass
    ``v_i <= sqrt(v_{i+1}^2 + 2 a_brake l_i)`` (brake in time for every corner) and a
    forward pass ``v_{i+1} <= sqrt(v_i^2 + 2 a_accel l_i)``. Both passes start at the
    slowest point of the loop, whose limit no pass can lower, so one sweep each is exact.

    >>> kappa = np.array([0.0, 1.0, 0.0, 0.0])
    >>> speed_profile(kappa, np.ones(4), 4.0, 1.0, 1.0, 1.0).round(3).tolist()
    [1.732, 1.0, 1.732, 2.236]

    Args:
        curvature: Curvature at each point, shape (K,) [1/m].
        seg_len: Length of the segment from point i to point i + 1, shape (K,) [m].
        v_max: Top speed [m/s].
        a_lat: Lateral acceleration budget [m/s^2].
        a_accel: Longitudinal acceleration [m/s^2].
        a_brake: Longitudinal deceleration [m/s^2].

    Returns:
        Speed at each point, shape (K,) [m/s].
    """
    limit = np.minimum(v_max, np.sqrt(a_lat / np.maximum(np.abs(curvature), 1e-9)))
    k = len(limit)
    start = int(np.argmin(limit))
    order = (start + np.arange(k + 1)) % k  # the loop, from the slowest point back to it
    v = limit[order].tolist()
    lengths = seg_len[order[:-1]].tolist()
    for i in range(k - 1, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * a_brake * lengths[i]))
    for i in range(k):
        v[i + 1] = min(v[i + 1], math.sqrt(v[i] ** 2 + 2.0 * a_accel * lengths[i]))
    out = np.empty(k)
    out[order[:-1]] = v[:-1]
    return out


def catmull_rom(points: FloatArray, u: FloatArray) -> FloatArray:
    """Return the closed uniform Catmull-Rom spline through ``points`` (shape (K, 2)) at
    parameters ``u`` (shape (M,); point i at ``u = i``, periodic in K), shape (M, 2)."""
    k = len(points)
    u = np.remainder(u, k)
    i = np.floor(u).astype(np.int64)
    t = (u - i)[:, None]
    p0, p1, p2, p3 = (points[(i + j) % k] for j in (-1, 0, 1, 2))
    return 0.5 * (2.0 * p1 + (p2 - p0) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t**2
                  + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t**3)


def track_offsets(track: Track, s: FloatArray, points: FloatArray) -> FloatArray:
    """Return the offsets in the track's own frame of a closed line through ``points``.

    The drivers read the line as an offset from the centre line in the track's frame (the
    env's projection: ``core.s``, ``core.d``, :meth:`Track.point_at`); the line's points
    (shape (K, 2) [m], in lap order from near arc position ``s[0]``) are projected onto the
    track and their offsets interpolated at the arc positions ``s`` (shape (K,) [m]).
    Projected positions stall on the outside of a waypoint and skip on its inside; a running
    maximum keeps them in order for the interpolation.
    """
    length = track.length
    s_proj, d_proj = track.project(points)
    # Unwrap each projected position to within half a lap of its grid position.
    s_proj = s + np.remainder(s_proj - s + 0.5 * length, length) - 0.5 * length
    s_proj = np.maximum.accumulate(s_proj)
    return np.interp(s, np.concatenate([s_proj - length, s_proj, s_proj + length]),
                     np.tile(d_proj, 3))


def compute_race_line(track: Track, car: CarParams, v_max: float, *, ds: float = 0.1,
                      qp_ds: float = 0.2, margin: float = 0.12, peak_emphasis: float = 0.0,
                      grip_factor: float = 0.6,
                      accel_factor: float = 0.9, brake_factor: float = 0.6) -> RaceLine:
    """Compute (or fetch from the per-track cache) the racing line of a track.

    Args:
        track: The track.
        car: Car parameters (friction, acceleration and braking limits).
        v_max: Top speed of the profile [m/s] (the env's ``config.max_speed``).
        ds: Grid spacing of the returned line along the centre line [m].
        qp_ds: Grid spacing of the curvature optimisation [m] (the offsets are then
            interpolated linearly onto the ``ds`` grid).
        margin: Distance kept from each border by the line [m]; the car body (half-width
            0.1 m) stays on the surface when the car is on the line.
        peak_emphasis: Exponent p of the extra weight ``(|kappa| / mean |kappa|)^p`` on
            each point's bending energy in the re-weighting passes (0: plain minimum
            curvature; larger values trade overall smoothness for a lower peak).
        grip_factor: Fraction of the tyre limit ``mu g`` used in corners.
        accel_factor: Fraction of ``car.max_accel`` used in the forward pass.
        brake_factor: Fraction of ``car.max_brake`` used in the backward pass (the speed
            controller only reaches full braking ``v - v_cmd`` behind the command).

    Returns:
        The racing line.
    """
    key = (car.friction, car.max_accel, car.max_brake, v_max, ds, qp_ds, margin, peak_emphasis,
           grip_factor,
           accel_factor, brake_factor)
    per_track = _CACHE.setdefault(track, {})
    if key in per_track:
        return per_track[key]
    # The path is the same for every speed profile (reference_lap_time's and the driver's):
    # optimised once per track and setting.
    path_key = ("offsets", qp_ds, margin, peak_emphasis)
    if path_key not in per_track:
        path = min_curvature_offsets(track, ds=qp_ds, margin=margin, peak_emphasis=peak_emphasis)
        for arr in path:
            arr.flags.writeable = False
        per_track[path_key] = path
    s_coarse, d_coarse = per_track[path_key]
    k = max(8, round(track.length / ds))
    s = np.arange(k) * (track.length / k)
    # The optimised points, not their offsets, are interpolated onto the finer grid: offsets
    # carried along the centre polyline would bring back its kink at every waypoint (a
    # corner of 40 degrees on a track drawn through 70 cm waypoints).
    centre, normal = smooth_frame(track, s_coarse)
    points = catmull_rom(centre + d_coarse[:, None] * normal, s / (track.length / len(s_coarse)))
    left, right = track.half_widths_at(s)
    # The bounds vary along s where the width does; clamp the line's offsets to them.
    d = np.minimum(np.maximum(track_offsets(track, s, points), -(right - margin)),
                   left - margin)
    kappa, seg_len = line_curvature(points, smooth=max(1, round(qp_ds / ds)))
    speed = speed_profile(kappa, seg_len, v_max, grip_factor * car.friction * GRAVITY,
                          accel_factor * car.max_accel, brake_factor * car.max_brake)
    mean_speed = 0.5 * (speed + np.roll(speed, -1))
    lap_time = float(np.sum(seg_len / mean_speed))
    arrays = [s, d, points, kappa, speed]
    for arr in arrays:
        arr.flags.writeable = False
    line = RaceLine(s=s, d=d, points=points, curvature=kappa, path_length=float(seg_len.sum()),
                    speed=speed, lap_time=lap_time, track_length=track.length)
    per_track[key] = line
    return line


def reference_lap_time(track: Track, car: CarParams, v_max: float, *,
                       margin: float = 0.12) -> float:
    """Return the minimum-time reference lap of a track [s]: an estimate, not a lap driven.

    The racing line's own path (the one ``racing_line`` drives, ``margin`` from the borders)
    with the speed profile of a point mass at the car's full grip, acceleration and braking
    (``compute_race_line(..., grip_factor=1, accel_factor=1, brake_factor=1).lap_time``: a
    flying lap, cornering at ``mu g``, no controller lag, no weight transfer, braking and
    cornering never combined). A real car lags it, and a faster path may exist; it bounds
    what a driver of this path can gain over ``racing_line``, whose own profile uses 60 % of
    the grip, 90 % of the acceleration and 60 % of the braking.

    Args:
        track: The track.
        car: Car parameters (friction, acceleration and braking limits).
        v_max: Top speed [m/s] (the env's ``config.max_speed``).
        margin: Distance kept from each border by the path [m].
    """
    return compute_race_line(track, car, v_max, margin=margin, grip_factor=1.0,
                             accel_factor=1.0, brake_factor=1.0).lap_time
