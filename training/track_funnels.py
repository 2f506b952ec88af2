"""Funnel tracks for ``[procedural] funnel_share``: random tracks that narrow sharply into a
tight bend, as DeepRacer's ``Tokyo_Training_track`` (1.44 m wide 1 m before a 0.5-0.6 m
hairpin, 0.70 m 2 m later) and ``Bowtie_track``'s waists (0.61 m in 0.85-0.95 m bends) do.

The other generated tracks never do: their width changes by at most 4.5 % within 2 m, and
their corners tighter than 1.5 /m are at constant width
(``experiments/routes/retrain/ppo_step6/tokyo/funnels.py``). A driver that observes the
half-widths only where the car is (``h2h_racing.sensors.state``) meets such a bend first on a
route, and enters it at the speed of the wide track.

A funnel track is a loop of ``random_track`` (deep bays, so that it has tight corners) scaled
so that its tightest corner has the drawn radius, then given a width profile
(``funnel_widths``): ``wide`` everywhere, ``narrow`` through the tight bend, the width falling
from ``wide`` to ``narrow`` within ``ramp`` metres before the bend (and rising again as fast
after it, so that the track driven the other way round has the same funnel), and any corner
narrowed as far as its radius needs (half-width at most radius / 1.2, over 3 m ramps). The
bend's own approach may so cap the entry under ``wide``: a loop is kept only if the track is
at least ``entry``'s low end wide somewhere in the 0.5 m before its ramp, and its borders
cross nowhere and stay ``WALL_GAP`` apart between parts of the lap far apart along it.
"""

from __future__ import annotations

import hashlib

import numpy as np

from h2h_racing.track.generator import (
    RADIUS_TO_HALF_WIDTH,
    TrackSpec,
    border_polylines,
    closed_length,
    curvature,
    find_crossings,
    min_radius_of_curvature,
    random_track,
    smooth_closed_curve,
)
from h2h_racing.track.shape import FloatArray

SPACING = 0.05
"""Distance between the centre line's vertices [m] (the generator's own)."""
BEND_SHARE = 0.5
"""The tight bend is the stretch round the tightest vertex whose curvature is at least this
share of the tightest's; the track is ``narrow`` over it and ``BEND_MARGIN`` either side."""
BEND_MARGIN = 0.2
"""Narrow stretch kept before and after the tight bend [m]."""
OTHER_RAMP = 3.0
"""Length over which the other corners' narrowing (radius / 1.2 half-width) fades [m]."""
LOOP_TRIES = 40
"""Loops drawn for one funnel track before ``RuntimeError`` (about 1 in 3 is accepted)."""
WALL_GAP = 0.25
"""Smallest gap between the borders of two parts of the lap that are far apart along it [m]
(``random_track``'s clearance rule: room for the walls)."""


def smoothstep(x: FloatArray) -> FloatArray:
    """``3x^2 - 2x^3`` on [0, 1], 0 below and 1 above: a ramp with no kink at either end."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def funnel_widths(lap: float, count: int, wide: float, narrow: float, bend: tuple[int, int],
                  ramp: float, limits: FloatArray | None = None) -> FloatArray:
    """Total width [m] at each of ``count`` vertices evenly spaced round a ``lap`` [m] loop:
    ``narrow`` on the vertices ``bend = (first, last)`` (indices, ``last`` may pass ``count``
    and wraps), rising to ``wide`` over ``ramp`` metres either side (``smoothstep``); where
    ``limits`` (per vertex [m]) is below the result, the width falls to it and fades back over
    ``OTHER_RAMP``. Half-way along a ramp the width is ``(narrow + wide) / 2``.

    >>> w = funnel_widths(10.0, 100, 1.4, 0.6, (0, 4), 2.0)
    >>> [round(float(w[i]), 3) for i in (0, 4, 14, 24, 50, 90)]
    [0.6, 0.6, 1.0, 1.4, 1.4, 1.0]
    """
    ds = lap / count
    s = np.arange(count) * ds
    first, last = bend
    centre = np.arange(first, last + 1) % count
    # Arc distance (round the loop) from every vertex to the narrow stretch.
    gap = np.abs(s[:, None] - s[centre][None, :])
    gap = np.minimum(gap, lap - gap).min(axis=1)
    widths = narrow + (wide - narrow) * smoothstep(gap / ramp)
    if limits is not None:
        tight = np.flatnonzero(limits < wide)
        if tight.size:
            apart = np.abs(s[:, None] - s[tight][None, :])
            apart = np.minimum(apart, lap - apart)
            low = limits[tight][None, :]
            capped = (low + (wide - low) * smoothstep(apart / OTHER_RAMP)).min(axis=1)
            widths = np.minimum(widths, capped)
    return widths


def _bend(kappa: FloatArray) -> tuple[int, int]:
    """``(first, last)`` vertex of the tight bend round the tightest vertex (``last`` may be
    ``count`` or more: it wraps), widened by ``BEND_MARGIN``."""
    count = len(kappa)
    apex = int(np.argmax(kappa))
    inside = kappa >= BEND_SHARE * kappa[apex]
    first = last = apex
    while inside[(first - 1) % count] and apex - first < count // 4:
        first -= 1
    while inside[(last + 1) % count] and last - apex < count // 4:
        last += 1
    margin = int(round(BEND_MARGIN / SPACING))
    return first - margin, last + margin


def _walls_clear(centre: FloatArray, widths: FloatArray) -> bool:
    """Whether parts of the lap more than ``3 x`` the widest width apart along it keep their
    borders ``WALL_GAP`` apart (each part's own half-width), every 4th vertex."""
    pts, w = centre[::4], widths[::4]
    n = len(pts)
    apart = 4 * SPACING * np.abs(np.arange(n)[:, None] - np.arange(n)[None, :])
    lap = 4 * SPACING * n
    far = np.minimum(apart, lap - apart) > 3.0 * widths.max()
    dist = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=-1)
    need = 0.5 * (w[:, None] + w[None, :]) + WALL_GAP
    return bool(np.all(dist[far] >= need[far]))


def funnel_fits(centre: FloatArray, widths: FloatArray, first: int, fall: float,
                entry: float, narrow: float) -> bool:
    """Whether a funnel drawn into a loop is one to keep: at least ``entry`` wide [m] just
    before its narrowing, which starts ``fall`` metres before vertex ``first`` (the loop's
    other corners may have narrowed the entry), nowhere under ``narrow`` [m], its walls clear
    of each other, and neither the centre line nor a border crossing itself."""
    before = np.arange(first - int(round((fall + 0.5) / SPACING)),
                       first - int(round(fall / SPACING)) + 1) % len(centre)
    if widths[before].max() < entry - 1e-9 or widths.min() < narrow - 1e-9:
        return False
    if not _walls_clear(centre, widths):
        return False
    left, right = border_polylines(centre, 0.5 * widths, 0.5 * widths)
    return not (len(find_crossings(centre)) or len(find_crossings(left, right)))


def funnel_digest(centre: FloatArray, widths: FloatArray) -> str:
    """Short content hash of a drawn track (its name's suffix)."""
    return hashlib.sha256(np.round(centre, 4).tobytes()
                          + np.round(widths, 4).tobytes()).hexdigest()[:8]


def funnel_track(rng: np.random.Generator, *, length: tuple[float, float],
                 entry: tuple[float, float], width: tuple[float, float],
                 ramp: tuple[float, float], radius: tuple[float, float]) -> TrackSpec:
    """A random funnel track (see the module): its lap in ``length`` [m], ``entry`` [m] wide
    away from its corners, ``width`` [m] wide through a bend of ``radius`` [m] (its tightest),
    the width falling within ``ramp`` [m] before it; each of the four drawn uniformly in its
    range. ``RuntimeError`` after ``LOOP_TRIES`` loops without a valid one (none drawn yet)."""
    wide = float(rng.uniform(*entry))
    narrow = float(rng.uniform(*width))
    bend_radius = float(rng.uniform(*radius))
    fall = float(rng.uniform(*ramp))
    for _ in range(LOOP_TRIES):
        lap = float(rng.uniform(*length))
        # Deep bays (radius_range low 0.3) give the loop tight corners; its tightest radius is
        # about 2 % of its lap (10th-90th percentile 1.4-3.9 %), scaled to bend_radius below.
        spec = random_track(rng, length_range=(lap, lap), width=narrow,
                            min_radius=0.51 * narrow, radius_range=(0.3, 1.0))
        scale = bend_radius / min_radius_of_curvature(spec.centre)
        if not length[0] <= scale * lap <= length[1]:
            continue
        # Every other vertex as control points: the spline through them is the same curve.
        centre = smooth_closed_curve(spec.centre[::2] * scale, spacing=SPACING)
        kappa = np.abs(curvature(centre))
        if 1.0 / kappa.max() < 0.95 * bend_radius:
            continue
        limits = 2.0 * np.divide(1.0, kappa, out=np.full_like(kappa, np.inf),
                                 where=kappa > 1e-9) / RADIUS_TO_HALF_WIDTH
        first, last = _bend(kappa)
        lap_now = closed_length(centre)
        widths = funnel_widths(lap_now, len(centre), wide, narrow, (first, last), fall, limits)
        if not funnel_fits(centre, widths, first, fall, entry[0], narrow):
            continue
        digest = funnel_digest(centre, widths)
        at = (first + BEND_MARGIN / SPACING) * SPACING % lap_now
        return TrackSpec(
            name=f"funnel-{digest}",
            description=(f"Random funnel track, {lap_now:.1f} m lap, {wide:.2f} m wide, "
                         f"narrowing to {narrow:.2f} m within {fall:.1f} m into a "
                         f"{bend_radius:.2f} m bend at {at:.1f} m."),
            centre=centre, width_left=0.5 * widths, width_right=0.5 * widths)
    raise RuntimeError(
        f"funnel_track found no valid loop in {LOOP_TRIES} tries for a {wide:.2f} m track "
        f"narrowing to {narrow:.2f} m into a {bend_radius:.2f} m bend, laps {length} m; "
        "widen [procedural] length or funnel_radius")
