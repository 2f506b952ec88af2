"""Tight boxes for object-avoidance training (``[race] tight_box_share``): a share of each
copy's box layouts gets one box moved to a place of the lap where the room beside it is
tight, as on ``Bowtie_track``'s waists (a box on the inside lane of a 0.61 m wide, 0.85-0.95 m
bend leaves 0.22-0.23 m for a 0.196 m wide car).

DeepRacer's layouts (``h2h_racing.sim.layouts.obstacle_layout``) land a box in such a place
rarely: 2.9 % of the layouts on ``obstacle_generalist``'s step 7 training tracks have one,
76.8 % of Bowtie's (``experiments/routes/retrain/obstacle_fine/bowtie/box_room.py``). A
student passes tight boxes 3-4 cm nearer than its teacher, and there that is a crash.

Training only: the env, ``evaluate`` and DeepRacer-compatible races place boxes as DeepRacer
does and never read this. The move keeps the layout's rules: the box stays in the part of the
lap where the env places boxes (clear of the start and of the grid) and at least
``obstacle_min_gap`` from every other box; where no tight place satisfies them, or the track
has none, the layout stays as drawn.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from h2h_racing.config.checks import _check, _is_number
from h2h_racing.sim import layouts
from h2h_racing.track.shape import FloatArray, Track

STEP = 0.05
"""Spacing of the candidate places along the lap [m]."""


@dataclass(frozen=True)
class TightBoxes:
    """How often and where ``RacingVecEnv`` moves a box to a tight place."""

    share: float
    """Share of layouts (one per copy and episode) with one box moved, in [0, 1]."""
    room: tuple[float, float]
    """``(low, high)`` free width beside a moved box [m]: above the car's 0.196 m width, so
    that the layout stays passable."""

    def __post_init__(self) -> None:
        owner = "[race]"
        _check(_is_number(self.share) and 0.0 <= self.share <= 1.0, owner, "tight_box_share",
               self.share, "a number in [0, 1] (share of box layouts with a box moved to a "
               "tight place)")
        pair = self.room
        _check(isinstance(pair, tuple) and len(pair) == 2 and all(_is_number(v) for v in pair)
               and 0.2 <= pair[0] <= pair[1] <= 1.0, owner, "tight_box_room", pair,
               "(low, high) free width beside the box with 0.2 <= low <= high <= 1 [m] (the "
               "car is 0.196 m wide)")


def box_room(track: Track, s: FloatArray, lane: FloatArray, box_length: float,
             box_width: float) -> FloatArray:
    """Free width [m] beside boxes centred on lane ``lane`` (+1 left, -1 right) at arc
    positions ``s`` (same shapes): the other side's half-width plus the gap between the centre
    line and the box's near side, less how far a straight box on the inside lane of a bend
    sticks out at its ends (``sqrt(R^2 + (L/2)^2) - R``, R the radius of its outer side). The
    measure of ``obstacle_fine/bowtie/box_room.py``.

    On a straight 0.6 m wide track: 0.3 + 0.15 - 0.2 = 0.25 m beside a 0.4 m wide box."""
    s = np.asarray(s, dtype=np.float64)
    flat = np.mod(s.ravel(), track.length)
    left, right = track.half_widths_at(flat)
    k = track.curvature_at(flat)
    d = layouts.lane_offset(track, flat, np.asarray(lane, dtype=np.float64).ravel())
    other = np.where(d > 0, right, left)
    inside = (np.sign(d) == np.sign(k)) & (np.abs(k) > 1e-6)
    with np.errstate(divide="ignore", invalid="ignore"):
        r_edge = 1.0 / np.abs(k) - np.abs(d) + 0.5 * box_width
        bulge = np.where(inside, np.sqrt(r_edge ** 2 + (0.5 * box_length) ** 2) - r_edge, 0.0)
    return (other + np.abs(d) - 0.5 * box_width - bulge).reshape(s.shape)


def tight_places(track: Track, room: tuple[float, float], box_length: float,
                 box_width: float, grid_length: float) -> tuple[FloatArray, FloatArray]:
    """``(s, lane)`` of every place ``STEP`` apart, on either lane, in the part of the lap
    where the env places boxes (``layouts.OBSTACLE_CLEAR_START`` to the grid's
    ``grid_length`` [m] plus ``OBSTACLE_CLEAR_END`` before the lap's end) whose ``box_room``
    is within ``room`` [m]."""
    last = track.length - layouts.OBSTACLE_CLEAR_END - grid_length
    s = np.arange(layouts.OBSTACLE_CLEAR_START, last, STEP)
    s2 = np.concatenate([s, s])
    lane = np.concatenate([np.ones(len(s)), -np.ones(len(s))])
    free = box_room(track, s2, lane, box_length, box_width)
    keep = (free >= room[0]) & (free <= room[1])
    return s2[keep], lane[keep]


def tighten(s: FloatArray, lane: FloatArray, places: tuple[FloatArray, FloatArray],
            rng: np.random.Generator, share: float,
            min_gap: float) -> tuple[FloatArray, FloatArray, int]:
    """The layouts ``(s, lane)`` (M, K) with, in a ``share`` of them (one draw each), the box
    nearest a tight place moved there: a place drawn uniformly among ``places`` whose other
    boxes are all ``min_gap`` [m] or more away from it. Returns copies and the number moved.

    Moving the nearest box is the one move that can work: if moving box j to c keeps the
    others ``min_gap`` away, the nearest one is either j or itself ``min_gap`` away, and then
    so is j."""
    s, lane = np.array(s, dtype=np.float64), np.array(lane, dtype=np.float64)
    m, count = s.shape
    chosen = rng.random(m) < share
    place_s, place_lane = places
    moved = 0
    if count == 0 or not len(place_s):
        return s, lane, moved
    for row in np.flatnonzero(chosen).tolist():
        dist = np.abs(place_s[:, None] - s[row][None, :])
        nearest = np.argmin(dist, axis=1)
        clear = np.sort(dist, axis=1)[:, 1] >= min_gap if count > 1 else np.ones(len(dist), bool)
        ok = np.flatnonzero(clear)
        if not len(ok):
            continue
        c = int(ok[rng.integers(len(ok))])
        s[row, nearest[c]] = place_s[c]
        lane[row, nearest[c]] = place_lane[c]
        moved += 1
    return s, lane, moved
