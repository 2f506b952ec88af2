"""Funnel tracks whose narrow part is a run of tight corners (``[procedural] funnel_corners``).

Step 8's funnels (``track_funnels.funnel_track``) narrow into ONE tight bend, the loop's
tightest. DeepRacer's ``Tokyo_Training_track`` narrows (1.44 to 0.70 m within 2 m) into a
RUN of corners: a hairpin of two 0.5-0.6 m corners, a short straight, then an S-bend, all
0.65-0.9 m wide, curvature 1.7-2.5 /m from 9 to 16 m of its lap. Step 8's seeds learned to
brake for the narrowing and carry speed through one narrow bend, and left Tokyo in the
corners after its first (``experiments/routes/retrain/step8/README.md``).

A run track is a gentle random loop (``random_track``, ``entry`` wide) into which a stretch of
tight corners is spliced: ``corner_run_curvature`` gives the run's signed curvature, corner
after corner (each of a radius drawn in ``radius``, turning ``CORNER_TURN``, a straight of
``CORNER_GAP`` between two corners); the loop's headings over a stretch as long as the run are
replaced by the run's, and the heading and position the run leaves unmatched are taken up
evenly by the rest of the loop (``splice_run``), so the run's corners keep their radii. The
width is ``width`` through the run (and ``BEND_MARGIN`` either side), falling to it from the
entry within ``ramp`` before the run and rising as fast after it (``funnel_widths``); other
corners narrowed as ``funnel_track`` narrows them, and the same validity checks.
"""

from __future__ import annotations

import numpy as np

from h2h_racing.track.generator import (
    RADIUS_TO_HALF_WIDTH,
    TrackSpec,
    closed_length,
    curvature,
    random_track,
    smooth_closed_curve,
)
from h2h_racing.track.shape import FloatArray
from h2h_racing.training.track_funnels import (
    BEND_MARGIN,
    LOOP_TRIES,
    SPACING,
    funnel_digest,
    funnel_fits,
    funnel_widths,
    smoothstep,
)

CORNER_TURN = (np.radians(45.0), np.radians(100.0))
"""Range of each corner's turn [rad]: Tokyo's hairpin is two corners of about 90 degrees, its
S-bend two of about 50."""
CORNER_GAP = (0.0, 0.8)
"""Range of the straight between two corners of a run [m]: back to back up to Tokyo's short
straight inside its hairpin."""
TURNS = ("alternate", "same", "mixed")
"""How the corners of a run turn: left and right in turn (S-bends), all one way (a hairpin
cut into corners), or each drawn (Tokyo: a hairpin, then an S-bend)."""
RUN_SMOOTHING = 0.2
"""Length of the box filter over the run's curvature [m]: corners join without a step in the
steering, and a corner at least this long keeps its full curvature at its middle."""


def corner_signs(rng: np.random.Generator, corners: int, turns: str) -> FloatArray:
    """``+1`` (left) or ``-1`` (right) for each of ``corners`` corners, as ``turns`` says
    (``TURNS``); the first corner's way drawn, one draw per corner for ``"mixed"``."""
    if turns not in TURNS:
        raise ValueError(f"turns must be one of {TURNS}, got {turns!r}")
    if turns == "mixed":
        return np.where(rng.random(corners) < 0.5, 1.0, -1.0)
    first = 1.0 if rng.random() < 0.5 else -1.0
    if turns == "same":
        return np.full(corners, first)
    return first * (-1.0) ** np.arange(corners)


def corner_run_curvature(radii: FloatArray, turns: FloatArray, signs: FloatArray,
                         gaps: FloatArray, spacing: float = SPACING) -> FloatArray:
    """Signed curvature [1/m] of each of the run's segments, ``spacing`` [m] long: corner ``i``
    an arc of ``radii[i]`` [m] turning ``turns[i]`` [rad] to ``signs[i]`` (+1 left), then a
    straight of ``gaps[i]`` [m] (one gap fewer than corners), each rounded to whole segments
    (an arc's curvature kept at ``1 / radii[i]``, its turn rounded), then box-filtered over
    ``RUN_SMOOTHING`` (the total turn kept; the run grows by its length).

    >>> k = corner_run_curvature(np.array([0.5, 0.5]), np.array([0.5, 0.5]),
    ...                          np.array([1.0, -1.0]), np.array([0.2]), spacing=0.05)
    >>> len(k), round(float(k.sum() * 0.05), 6), round(float(k.max()), 3)
    (18, 0.0, 2.0)
    """
    if not len(radii) == len(turns) == len(signs) == len(gaps) + 1:
        raise ValueError(f"a run of {len(radii)} corners needs {len(radii)} turns and signs "
                         f"and {len(radii) - 1} gaps, got {len(turns)}, {len(signs)} and "
                         f"{len(gaps)}")
    parts = []
    for i, (radius, turn, sign) in enumerate(zip(radii, turns, signs)):
        count = max(1, int(round(radius * turn / spacing)))
        # The radius kept exactly, the turn rounded to whole segments: a bend tighter than
        # drawn would break the config's radius >= 0.6 x width rule.
        parts.append(np.full(count, sign / radius))
        if i < len(gaps):
            parts.append(np.zeros(int(round(gaps[i] / spacing))))
    kappa = np.concatenate(parts)
    width = max(1, int(round(RUN_SMOOTHING / spacing)))
    if width > 1:
        # Padded with straights so that the filter keeps the total turn.
        padded = np.concatenate([np.zeros(width), kappa, np.zeros(width)])
        smooth = np.convolve(padded, np.ones(width) / width, mode="same")
        kappa = smooth[width // 2: width // 2 + len(kappa) + width]
    return kappa


def splice_run(centre: FloatArray, start: int, run_kappa: FloatArray) -> FloatArray:
    """``centre`` (a closed loop, vertices ``SPACING`` apart) with its segments from vertex
    ``start`` on turning as ``run_kappa`` says (one curvature per segment), the loop's heading
    at ``start`` kept. The turn and the displacement the run differs by from the stretch it
    replaces are taken up by the rest of the loop: its heading shifted by an amount falling
    linearly to 0 round the loop, its vertices moved by a share of the gap rising from 0 to 1
    (``smoothstep``: no kink where the run ends), so that it closes. Returns the vertices,
    the run's first at index 0 (not resampled)."""
    points = np.roll(centre, -start, axis=0)
    count, steps = len(points), len(run_kappa)
    if not 0 < steps < count // 2:
        raise ValueError(f"a run of {steps} segments does not fit a loop of {count} vertices "
                         "at half its length")
    seg = np.roll(points, -1, axis=0) - points
    length = np.linalg.norm(seg, axis=1)
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    new = heading.copy()
    # The run turns at its vertices 1..steps: segment k's heading has the first k turns.
    turned = np.cumsum(run_kappa * length[:steps])
    new[:steps] = heading[0] + np.concatenate([[0.0], turned[:-1]])
    shift = heading[0] + turned[-1] - heading[steps]
    rest = np.arange(count - steps)
    new[steps:] = heading[steps:] + shift * (1.0 - rest / (count - steps))
    step = length[:, None] * np.stack([np.cos(new), np.sin(new)], axis=1)
    out = points[0] + np.concatenate([[np.zeros(2)], np.cumsum(step, axis=0)])
    gap = out[-1] - out[0]
    # A smoothstep share: the move starts and ends tangent to the loop, no kink at the run.
    share = np.concatenate([np.zeros(steps + 1), smoothstep((rest + 1) / (count - steps))])
    out = out - share[:, None] * gap
    return out[:-1]


def funnel_run_track(rng: np.random.Generator, *, length: tuple[float, float],
                     entry: tuple[float, float], width: tuple[float, float],
                     ramp: tuple[float, float], radius: tuple[float, float],
                     corners: tuple[int, int], turns: str = "alternate") -> TrackSpec:
    """A random funnel track whose narrow part is a run of corners (see the module): lap in
    ``length`` [m], ``entry`` [m] wide away from the run, ``width`` [m] wide through it, the
    width falling within ``ramp`` [m] before it; a number of corners drawn in ``corners``, each
    of a radius drawn in ``radius`` [m], turning as ``turns`` says. ``RuntimeError`` after
    ``LOOP_TRIES`` loops without a valid one."""
    wide = float(rng.uniform(*entry))
    narrow = float(rng.uniform(*width))
    fall = float(rng.uniform(*ramp))
    count = int(rng.integers(corners[0], corners[1] + 1))
    radii = rng.uniform(*radius, size=count)
    angles = rng.uniform(*CORNER_TURN, size=count)
    gaps = rng.uniform(*CORNER_GAP, size=count - 1)
    signs = corner_signs(rng, count, turns)
    run_kappa = corner_run_curvature(radii, angles, signs, gaps)
    for _ in range(LOOP_TRIES):
        lap = float(rng.uniform(*length))
        loop = random_track(rng, length_range=(lap, lap), width=wide)
        start = int(rng.integers(len(loop.centre)))
        try:
            spliced = splice_run(loop.centre, start, run_kappa)
        except ValueError:
            continue
        # Evenly spaced again (the move stretched the rest); through every vertex, as through
        # every other one the spline overshot the run's corners by 1-13 %.
        centre = smooth_closed_curve(spliced, spacing=SPACING)
        kappa = curvature(centre)
        first = 0
        last = len(run_kappa)
        inside = np.arange(first, last + 1) % len(centre)
        if np.abs(kappa[inside]).max() > 1.03 * np.abs(run_kappa).max():
            continue
        limits = 2.0 * np.divide(1.0, np.abs(kappa), out=np.full_like(kappa, np.inf),
                                 where=np.abs(kappa) > 1e-9) / RADIUS_TO_HALF_WIDTH
        margin = int(round(BEND_MARGIN / SPACING))
        # The run is narrow anyway (radius >= 0.6 x width, the config's check): its corners'
        # own limits would only narrow the entry.
        limits[np.arange(first - margin, last + margin + 1) % len(centre)] = np.inf
        lap_now = closed_length(centre)
        widths = funnel_widths(lap_now, len(centre), wide, narrow,
                               (first - margin, last + margin), fall, limits)
        if not funnel_fits(centre, widths, first - margin, fall, entry[0], narrow):
            continue
        # Vertex 0 (the start line of a run without random starts) half a lap from the run.
        half = len(centre) // 2
        centre, widths = np.roll(centre, -half, axis=0), np.roll(widths, -half)
        at = (len(centre) - half) * SPACING % lap_now
        digest = funnel_digest(centre, widths)
        ways = "".join("L" if s > 0 else "R" for s in signs)
        return TrackSpec(
            name=f"funnel-{digest}",
            description=(f"Random funnel track, {lap_now:.1f} m lap, {wide:.2f} m wide, "
                         f"narrowing to {narrow:.2f} m within {fall:.1f} m into a run of "
                         f"{count} corners ({ways}) of {radii.min():.2f}-{radii.max():.2f} m "
                         f"radius at {at:.1f} m."),
            centre=centre, width_left=0.5 * widths, width_right=0.5 * widths)
    raise RuntimeError(
        f"funnel_run_track found no valid loop in {LOOP_TRIES} tries for a {wide:.2f} m track "
        f"narrowing to {narrow:.2f} m into a run of {count} corners ({turns}), laps {length} "
        "m; widen [procedural] length, or fewer funnel_corners")
