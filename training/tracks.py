"""Random training tracks of procedural runs (``TrainConfig.track = "procedural"``): lap
length, width, corner radii, chicanes, direction and a share of tight, ``technical``-like
tracks and of kart-style circuits of tight corners, each drawn from one generator;
``ProceduralTracks`` holds a run's settings (its ``[procedural]`` table)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from h2h_racing.track.shape import FloatArray, Track
from h2h_racing.track.generator import random_track
from h2h_racing.track.circuits import random_circuit
from h2h_racing.training.track_funnel_runs import TURNS, funnel_run_track
from h2h_racing.training.track_funnels import funnel_track


def random_training_track(rng: np.random.Generator, varying_share: float = 0.0,
                          min_radius: float = 0.6,
                          length: tuple[float, float] = (20.0, 45.0),
                          reverse_share: float = 0.0,
                          chicanes: tuple[int, int] = (0, 0),
                          tight_share: float = 0.0, circuit_share: float = 0.0,
                          circuit_corners: str | tuple[str, ...] = "arcs",
                          narrowest: float = 0.76, widest: float = 1.07,
                          waypoint_gap: tuple[float, float] = (0.05, 0.05),
                          funnel_share: float = 0.0,
                          funnel: dict[str, tuple[float, float]] | None = None,
                          funnel_corners: tuple[int, int] = (0, 0),
                          funnel_turns: str = "alternate") -> Track:
    """A random closed track for training: lap length drawn in ``length`` [m], width in the
    catalogue's range [0.76, 1.07] m (its low end ``narrowest``): constant (drawn uniformly)
    or, on a ``varying_share`` of the tracks, varying along the lap between two widths drawn
    in that range (sorted); corners down to ``min_radius`` [m], or 1.2 x the widest
    half-width if that is larger (``random_track``), with a number of chicanes drawn in
    ``chicanes``; on a ``reverse_share`` of the tracks driven clockwise (its name then ends
    in ``-cw``).

    A ``tight_share`` of the tracks are instead short, narrow and twisty, as ``technical`` is:
    lap ``TIGHT_LENGTH``, constant width ``TIGHT_WIDTH``, control-point radii down to 0.3 of
    the loop's size (deep bays: tight right-handers between left-handers), corners down to
    ``min_radius``, 1-3 chicanes; 5-20 % of their lap is in corners under 1 m radius, against
    0-5 % for the other tracks (``technical``: 40 %).

    A ``circuit_share`` of the tracks are circuits of tight corners (``random_circuit``): width
    drawn in ``TIGHT_WIDTH`` (up to ``LONG_WIDEST`` for ``"long"`` ones), 0-2 chicanes, drawn
    in one of the ``circuit_corners`` styles (``CIRCUIT_STYLES``; one drawn per circuit when
    several are given).

    ``narrowest`` [m] replaces 0.76 as the low end of every width range (``TIGHT_WIDTH``'s
    too): DeepRacer's ``Oval_track`` narrows to 0.61 m. ``widest`` [m] replaces 1.07 as the
    high end of the other tracks' widths: DeepRacer's routes widen to 1.97 m.

    ``waypoint_gap`` ``(low, high)`` [m] other than the generator's own 5 cm re-draws every
    track's centre line through waypoints spaced as DeepRacer's files are (0.06-0.98 m apart,
    evenly on most routes, unevenly on some): each track draws two gaps in the range, and its
    waypoints are that far apart, each gap drawn uniformly between the two (``resample``).

    A ``funnel_share`` of the tracks are funnel tracks (``funnel_track``): wide, narrowing
    sharply into a tight bend; ``funnel`` holds its ``entry``, ``width``, ``ramp`` and
    ``radius`` ranges (``FUNNEL_DEFAULTS`` for those not given), the lap in ``length``, the
    waypoint gaps at most ``FUNNEL_GAP``. With ``funnel_corners`` other than ``(0, 0)`` a
    funnel track's narrow part is instead a run of that many corners (drawn in the range),
    each of a radius in ``funnel["radius"]``, turning as ``funnel_turns`` says
    (``funnel_run_track``)."""
    # No draw without the option: the same seed gives the same tracks as before it.
    if funnel_share > 0 and rng.random() < funnel_share:
        ranges = {**FUNNEL_DEFAULTS, **(funnel or {})}
        if funnel_corners == (0, 0):
            spec = _retried(lambda: funnel_track(rng, length=length, **ranges))
        else:
            spec = _retried(lambda: funnel_run_track(rng, length=length, **ranges,
                                                     corners=funnel_corners,
                                                     turns=funnel_turns))
        # Waypoints 0.8 m apart would round a 0.5 m bend off to 0.9-1.5 m: funnel routes put
        # theirs closer (FUNNEL_GAP).
        gap = (min(waypoint_gap[0], FUNNEL_GAP), min(waypoint_gap[1], FUNNEL_GAP))
        return _finished(rng, spec, reverse_share, gap)
    if circuit_share > 0 and rng.random() < circuit_share:
        styles = (circuit_corners,) if isinstance(circuit_corners, str) else circuit_corners
        # The width is drawn first, the style after: the same seed gives the same circuits as
        # before "long" existed; no draw for a single style.
        width = float(rng.uniform(narrowest, TIGHT_WIDTH[1]))
        style = styles[int(rng.integers(len(styles)))] if len(styles) > 1 else styles[0]
        settings = dict(CIRCUIT_STYLES[style])
        top = settings.pop("widest", TIGHT_WIDTH[1])
        if top != TIGHT_WIDTH[1] and TIGHT_WIDTH[1] > narrowest:
            # Stretched to the style's own range, narrowest..top, from the same draw.
            width = narrowest + (width - narrowest) * (top - narrowest) / (
                TIGHT_WIDTH[1] - narrowest)
        settings.setdefault("corner_radius", (max(0.5, 0.6 * width), 0.7))
        settings["corner_radius"] = (max(settings["corner_radius"][0], 0.6 * width),
                                     settings["corner_radius"][1])
        spec = random_circuit(rng, width=width, chicanes=(0, 2), **settings)
        return _finished(rng, spec, reverse_share, waypoint_gap)
    if tight_share > 0 and rng.random() < tight_share:
        width: float | tuple[float, float] = float(rng.uniform(narrowest, TIGHT_WIDTH[1]))
        # About 1 in 12 calls of random_track finds no valid loop of this kind in its 100
        # tries; the next call (same generator, new draws) almost always does.
        spec = _retried(lambda: random_track(rng, length_range=TIGHT_LENGTH, width=width,
                                             min_radius=max(min_radius, 0.6 * width),
                                             radius_range=(0.3, 1.0), chicanes=(1, 3)))
        return _finished(rng, spec, reverse_share, waypoint_gap)

    def ordinary() -> Any:
        # A wide track needs wide corners (1.2 x its half-width) that a short loop may not
        # have room for: after 100 loops without one, the width is drawn again.
        drawn: float | tuple[float, float] = float(rng.uniform(narrowest, widest))
        # No draw without varying widths: the same seed gives the same tracks as before.
        if varying_share > 0 and rng.random() < varying_share:
            drawn = (min(drawn, w := float(rng.uniform(narrowest, widest))), max(drawn, w))
        wide = drawn if isinstance(drawn, float) else drawn[1]
        return random_track(rng, length_range=length, width=drawn,
                            min_radius=max(min_radius, 0.6 * wide), chicanes=chicanes)

    return _finished(rng, _retried(ordinary), reverse_share, waypoint_gap)


DRAW_CALLS = 20
"""Most calls of ``_retried``'s ``draw`` before its failure is raised. Five were too few: a
widened config (``ppo_generalist/routes``: up to 2 m wide on 15-45 m loops) failed five in a
row after 871 iterations of a run (seed 2). A draw that succeeded within five calls is the same
track as before, to the bit: only what used to raise goes on."""


def _retried(draw: Callable[[], Any]) -> Any:
    """``draw()``, called again while it finds no valid loop (``RuntimeError``): ``DRAW_CALLS``
    calls at most, the last one's failure raised."""
    for _ in range(DRAW_CALLS - 1):
        try:
            return draw()
        except RuntimeError:
            continue
    return draw()


FUNNEL_DEFAULTS: dict[str, tuple[float, float]] = {
    "entry": (1.2, 1.6), "width": (0.6, 0.75), "ramp": (1.5, 2.5), "radius": (0.5, 0.9)}
"""``funnel_track``'s ranges [m] when ``random_training_track`` is not given them
(``ProceduralTracks``' ``funnel_entry``, ``funnel_width``, ``funnel_ramp`` and
``funnel_radius`` defaults)."""
FUNNEL_GAP = 0.1
"""Widest waypoint gap of a funnel track [m] (``waypoint_gap`` is capped to it): DeepRacer's
``Tokyo_Training_track``, ``Bowtie_track`` and ``Mexico_track`` put theirs 0.11 m apart
(median). Through waypoints up to 0.3 m apart a 0.51-0.67 m bend measured 0.75-0.92 m
(``Track.curvature_at``, 8 tracks), up to 0.15 m apart 0.61-0.77 m, 0.1 m apart 0.58-0.74 m."""
FUNNEL_BOUNDS: dict[str, tuple[float, float]] = {
    "entry": (0.6, 2.5), "width": (0.5, 1.5), "ramp": (0.5, 10.0), "radius": (0.4, 3.0)}
"""Bounds of the ``[procedural] funnel_*`` ranges [m]: widths as ``narrowest`` and
``widest`` allow, ramps from 0.5 m (sharper folds the border) and bends from 0.4 m
(``min_radius``'s floor)."""
LONG_WIDEST = 1.07
"""Widest ``"long"`` circuit [m]: the width of most DeepRacer routes."""
TIGHT_LENGTH = (14.0, 22.0)
"""Lap-length range of ``random_training_track``'s tight tracks [m] (``technical``: 20 m)."""
HAIRPIN_CELL = (1.26, 1.6)
"""Cell sizes of the hairpin circuits [m]: 2 x 0.63 m, the semicircle of ``technical``'s
tightest hairpin (legs 0.5 m apart at the borders), to 1.6 m."""
BSPLINE_CELL = (1.5, 1.9)
"""Cell sizes of the B-spline circuits [m]: right angles of 0.53-0.67 m radius, legs of a
hairpin 0.6-1.1 m apart at the borders (``technical``: 0.5-0.7 m)."""
CIRCUIT_STYLES: dict[str, dict[str, Any]] = {
    "arcs": {},
    "bspline": {"corners": "bspline", "cell": BSPLINE_CELL, "jitter": 0.08},
    "hairpins": {"cell": HAIRPIN_CELL},
    "long": {"cell": (2.5, 5.0), "cells": (8, 20), "corner_radius": (0.6, 1.5),
             "widest": LONG_WIDEST},
}
"""The ``circuit_corners`` styles of ``random_training_track``'s circuits: ``random_circuit``'s
arguments for each, and ``"widest"``, the top of the style's width range [m] when it is not
``TIGHT_WIDTH``'s (the width drawn in ``TIGHT_WIDTH`` is stretched onto it).

- ``"arcs"``: its defaults, every grid corner a 0.5-0.7 m arc, straights between, cells of
  1.3-2.2 m: 25-48 % of the lap under 1 m radius (10th-90th percentile).
- ``"bspline"``: the outline's B-spline on cells of ``BSPLINE_CELL`` (``corner_radius`` unused):
  round hairpins and esses with no straights between, 26-39 % of the lap under 1 m.
- ``"hairpins"``: arcs on cells of ``HAIRPIN_CELL``: a one-cell bay or peninsula is a
  semicircle, its legs 0.36-0.84 m apart at the borders (``technical``'s bay: 0.5 m).
- ``"long"``: arcs of 0.6-1.5 m on 8-20 cells of 2.5-5 m, ``LONG_WIDEST`` wide at most: laps
  of 45-100 m with 10-30 % of the lap under 1.5 m radius, as DeepRacer's 55-77 m routes
  (15-29 %); the other tracks of that length turn about half as often."""
TIGHT_WIDTH = (0.76, 0.9)
"""Width range of the tight tracks [m] (``technical``: 0.76 m)."""


def resample(rng: np.random.Generator, centre: FloatArray, widths: tuple[FloatArray, ...],
             gap: tuple[float, float]) -> tuple[FloatArray, tuple[FloatArray, ...]]:
    """The closed centre line ``centre`` (V, 2) [m] and its per-vertex ``widths`` re-drawn
    through waypoints spaced as a DeepRacer file's: two gaps ``a <= b`` drawn in ``gap``
    [m], then waypoint after waypoint along the lap each ``U(a, b)`` further on (linear
    interpolation along the arc), the last one dropped when it would sit under ``a / 2``
    from the first. Even gaps when ``a`` and ``b`` are close, uneven ones when not."""
    closed = np.vstack([centre, centre[:1]])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    lap = float(arc[-1])
    low, high = np.sort(rng.uniform(gap[0], gap[1], 2))
    # Enough gaps to pass the lap's end for sure: the lap over the smallest gap, plus one.
    steps = rng.uniform(low, high, int(np.ceil(lap / max(low, 1e-3))) + 1)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    s = s[s < lap - 0.5 * low]
    xy = np.column_stack([np.interp(s, arc, closed[:, k]) for k in range(2)])
    return xy, tuple(np.interp(s, arc, np.append(w, w[0])) for w in widths)


def _finished(rng: np.random.Generator, spec: Any, reverse_share: float,
              waypoint_gap: tuple[float, float]) -> Track:
    """``spec`` as a ``Track``: through waypoints ``waypoint_gap`` apart (``resample``) unless
    that is the generator's own 5 cm, and on a ``reverse_share`` of draws driven clockwise."""
    source = "training.tracks.random_training_track"
    track = None
    # No draw at the generator's own spacing: older settings give the same tracks. Chords of
    # wide gaps cut the inside of a tight corner (by gap^2 / 8R), where a border can fold:
    # such a draw is drawn again, and after 5 the track keeps its 5 cm line.
    for _ in range(5 if waypoint_gap != (0.05, 0.05) else 0):
        centre, widths = resample(rng, spec.centre, (spec.width_left, spec.width_right),
                                  waypoint_gap)
        try:
            track = Track(centre, *widths, name=spec.name, description=spec.description,
                          source=source)
            break
        except ValueError:
            continue
    if track is None:
        track = Track(spec.centre, spec.width_left, spec.width_right, name=spec.name,
                      description=spec.description, source=source)
    # As above: no draw without reversing, so that older settings give the same tracks.
    if reverse_share > 0 and rng.random() < reverse_share:
        track = track.reversed()
        track = Track(track.centre, track.width_left, track.width_right,
                      name=f"{spec.name}-cw", description=f"{spec.description} Driven clockwise.",
                      source=track.source)
    return track


@dataclass(frozen=True, kw_only=True)
class ProceduralTracks:
    """``[procedural]`` (``TrainConfig.procedural``): the random training tracks of
    ``track="procedural"`` runs (``random_training_track``) and how often they change."""

    every: int = 10
    """Iterations between track changes."""
    tracks: int = 1
    """Random tracks raced at once: the copies are split into this many blocks, each on a
    track of its own (one core of several tracks), so that every rollout and mini-batch mixes
    them; with
    one, every iteration's gradient steps pull the policy towards one track. 4 (with
    ``[imitation] pace = 0.95``) took ``camera_generalist``'s last step to 10 of 10 tracks on
    all three seeds, against 7-9 with the pace alone and 7-8 with 4 tracks alone
    (``experiments/camera/README.md``)."""
    varying_share: float = 0.0
    """Share of tracks whose width varies along the lap. 0 (as ``ppo_procedural``): three
    10-15 minute runs with 0.3, corners down to 0.45 m and laps from 15 m generalised worse
    (53-69 % of laps on the shipped tracks against 79 %)."""
    length: tuple[float, float] = (20.0, 45.0)
    """Lap-length range [m] (shorter laps of the same shapes have tighter corners)."""
    min_radius: float = 0.6
    """Smallest corner radius [m], raised to 1.2 x the widest half-width on wider tracks
    (``technical`` has 0.5 m corners)."""
    reverse_share: float = 0.0
    """Share of tracks driven clockwise (``Track.reversed``). The generator's loops are
    star-shaped and run anticlockwise: their right-hand bends are gentle (tightest radius
    1.2 m or more, median 4.9 m over 60 tracks), while ``technical`` turns right at 0.53 m,
    ``hairpin_valley`` at 0.75 m; driven the other way, every tight left-hander is a tight
    right-hander. 0 (as ``ppo_procedural``): a 1,020-iteration run with 0.5 lapped 75.0 % of
    the shipped tracks' attempts against 79.3 %, still 0 % on ``technical`` (its card)."""
    chicanes: tuple[int, int] = (0, 0)
    """``(fewest, most)`` chicanes added to each track (``random_track``'s ``chicanes``):
    S-bends as on ``technical``'s start straight, which smooth loops lack. (0, 0) (as
    ``ppo_procedural``): (1, 4) with half the tracks reversed and corners down to 0.5 m lapped
    72.1 %, 0 % on ``technical``."""
    tight_share: float = 0.0
    """Share of tracks that are short, narrow and twisty like ``technical``: the other
    generated tracks spend 0-5 % of their lap in corners under 1 m radius, ``technical``
    40 %. 0.3 (with imitation of the racing line, then PPO) trained ``ppo_generalist``, the
    first procedural policy to lap ``technical``."""
    circuit_share: float = 0.0
    """Share of tracks that are kart-style circuits of tight corners (``random_circuit``):
    25-48 % of their lap under 1 m radius, the tight tracks' 5-20 %, ``technical``'s 40 %."""
    narrowest: float = 0.76
    """Low end of every width range [m], the catalogue's 0.76 by default; DeepRacer's
    ``Oval_track`` narrows to 0.61 m."""
    widest: float = 1.07
    """High end of the width range of the tracks that are not tight or circuits [m], the
    catalogue's 1.07 by default; DeepRacer's routes are 0.6-1.97 m wide."""
    waypoint_gap: tuple[float, float] = (0.05, 0.05)
    """``(low, high)`` spacing of every track's waypoints [m] (``resample``): DeepRacer's files
    put them 0.06-0.98 m apart, evenly on most routes; the default, the generator's own 5 cm,
    re-draws nothing. Up to 0.1.0 a ``racing_line`` teacher kept to one side of a re-drawn
    track, 11-19 % slower a lap, and its students learned that pace on every track
    (``experiments/routes/retrain/obstacle_fine``); its line now matches the finely drawn
    track's (``policies.racing_line.smooth_frame``)."""
    circuit_corners: tuple[str, ...] = ("arcs",)
    """How the circuits are drawn (``CIRCUIT_STYLES``: ``"arcs"``, ``"bspline"``,
    ``"hairpins"``, ``"long"``); one of them drawn per circuit when several are given."""
    funnel_share: float = 0.0
    """Share of tracks that are funnel tracks (``funnel_track``): ``funnel_entry`` wide,
    narrowing within ``funnel_ramp`` into a ``funnel_radius`` bend ``funnel_width`` wide, as
    ``Tokyo_Training_track`` (1.44 to 0.70 m within 2 m into a 0.5-0.6 m hairpin) and
    ``Bowtie_track``'s waists (0.61 m in 0.85-0.95 m bends) do; the other tracks' width
    changes by at most 4.5 % within 2 m. 0 draws nothing: the same seed gives the same tracks
    as before the option. Their lap is drawn in ``length``; no chicanes, no varying width."""
    funnel_entry: tuple[float, float] = FUNNEL_DEFAULTS["entry"]
    """``(low, high)`` width of a funnel track away from its corners [m]."""
    funnel_width: tuple[float, float] = FUNNEL_DEFAULTS["width"]
    """``(low, high)`` width of a funnel track through its tight bend [m]."""
    funnel_ramp: tuple[float, float] = FUNNEL_DEFAULTS["ramp"]
    """``(low, high)`` arc length over which a funnel track's width falls from
    ``funnel_entry`` to ``funnel_width`` before the bend, and rises again after it [m]."""
    funnel_radius: tuple[float, float] = FUNNEL_DEFAULTS["radius"]
    """``(low, high)`` radius of a funnel track's tight bend, its tightest corner [m]; with
    ``funnel_corners``, of each corner of its run."""
    funnel_corners: tuple[int, int] = (0, 0)
    """``(fewest, most)`` corners of a funnel track's narrow part (``funnel_run_track``): a
    run of tight corners back to back, each turning 45-100 degrees, up to 0.8 m of straight
    between two, as ``Tokyo_Training_track``'s narrow part (a hairpin of two corners, then an
    S-bend, 9-16 m of its lap). ``(0, 0)``, the default: the one tight bend of step 8's
    funnels, drawn as before. Otherwise ``2 <= fewest <= most <= 6``."""
    funnel_turns: str = "alternate"
    """How a run's corners turn (``funnel_corners``): ``"alternate"`` (left and right in turn,
    S-bends), ``"same"`` (all one way; runs over 2 corners seldom fit a loop: 3 of 12 tracks
    valid for 2-3 corners) or ``"mixed"`` (each drawn, as Tokyo's hairpin then S-bend)."""

    def __post_init__(self) -> None:
        for name, unit in (("every", "iterations"), ("tracks", "random tracks raced at once")):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise ValueError(f"[procedural] {name} must be an integer >= 1 ({unit}), got "
                                 f"{value!r}")
        for name in ("varying_share", "reverse_share", "tight_share", "circuit_share"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"[procedural] {name} must be in [0, 1], got "
                                 f"{getattr(self, name)!r}")
        if isinstance(self.circuit_corners, str):
            object.__setattr__(self, "circuit_corners", (self.circuit_corners,))
        if not (self.circuit_corners and all(c in CIRCUIT_STYLES for c in self.circuit_corners)):
            raise ValueError(f"[procedural] circuit_corners must be one or more of "
                             f"{sorted(CIRCUIT_STYLES)}, got {self.circuit_corners!r}")
        fewest, most = self.chicanes
        if not (isinstance(fewest, int) and isinstance(most, int) and 0 <= fewest <= most):
            raise ValueError(f"[procedural] chicanes must be (fewest, most) ints with "
                             f"0 <= fewest <= most, got {self.chicanes!r}")
        low, high = self.length
        if not 5.0 <= low <= high:
            raise ValueError(f"[procedural] length must be (low, high) laps with "
                             f"5 <= low <= high [m], got {self.length!r}")
        if not 0.5 <= self.narrowest <= TIGHT_WIDTH[1]:
            raise ValueError(f"[procedural] narrowest must be in [0.5, {TIGHT_WIDTH[1]}] m, got "
                             f"{self.narrowest!r}")
        if not self.narrowest <= self.widest <= 2.5:
            raise ValueError(f"[procedural] widest must be in [narrowest ({self.narrowest}), "
                             f"2.5] m, got {self.widest!r}")
        gap_low, gap_high = self.waypoint_gap
        if not 0.02 <= gap_low <= gap_high <= 1.0:
            raise ValueError(f"[procedural] waypoint_gap must be (low, high) with 0.02 <= low "
                             f"<= high <= 1 m, got {self.waypoint_gap!r}")
        self._check_funnel()
        if not 0.4 <= self.min_radius:
            raise ValueError(f"[procedural] min_radius must be >= 0.4 m (above the narrowest "
                             f"half-width, 0.38 m), got {self.min_radius!r}")

    def _check_funnel(self) -> None:
        """The funnel ranges: ``(low, high)`` pairs, each within its bounds, the narrow width
        under the entry's and the bend wide enough for its width (radius >= 0.6 x width,
        ``RADIUS_TO_HALF_WIDTH``)."""
        if not 0.0 <= self.funnel_share <= 1.0:
            raise ValueError(f"[procedural] funnel_share must be in [0, 1], got "
                             f"{self.funnel_share!r}")
        for name, (floor, top) in FUNNEL_BOUNDS.items():
            pair = getattr(self, f"funnel_{name}")
            if not (isinstance(pair, tuple) and len(pair) == 2
                    and floor <= pair[0] <= pair[1] <= top):
                raise ValueError(f"[procedural] funnel_{name} must be (low, high) with {floor} "
                                 f"<= low <= high <= {top} [m], got {pair!r}")
        if not self.funnel_width[1] < self.funnel_entry[0]:
            raise ValueError(f"[procedural] funnel_width {self.funnel_width!r} must stay under "
                             f"funnel_entry's low end ({self.funnel_entry[0]} m): a funnel "
                             f"narrows; lower funnel_width or raise funnel_entry")
        fewest, most = self.funnel_corners
        if not (isinstance(fewest, int) and isinstance(most, int)
                and ((fewest, most) == (0, 0) or 2 <= fewest <= most <= 6)):
            raise ValueError(f"[procedural] funnel_corners must be (0, 0) (one tight bend) or "
                             f"(fewest, most) ints with 2 <= fewest <= most <= 6 corners in the "
                             f"narrow part, got {self.funnel_corners!r}")
        if self.funnel_turns not in TURNS:
            raise ValueError(f"[procedural] funnel_turns must be one of {list(TURNS)}, got "
                             f"{self.funnel_turns!r}")
        if not self.funnel_radius[0] >= 0.6 * self.funnel_width[1]:
            raise ValueError(f"[procedural] funnel_radius's low end must be at least 0.6 x "
                             f"funnel_width's high end ({0.6 * self.funnel_width[1]:.3f} m: "
                             f"else the bend's inner border folds), got {self.funnel_radius!r}")

    def draw(self, rng: np.random.Generator) -> Track:
        """A random training track drawn from ``rng`` with these settings."""
        return random_training_track(rng, self.varying_share, self.min_radius, self.length,
                                     self.reverse_share, self.chicanes, self.tight_share,
                                     self.circuit_share, self.circuit_corners, self.narrowest,
                                     self.widest, self.waypoint_gap, self.funnel_share,
                                     {"entry": self.funnel_entry, "width": self.funnel_width,
                                      "ramp": self.funnel_ramp, "radius": self.funnel_radius},
                                     self.funnel_corners, self.funnel_turns)
