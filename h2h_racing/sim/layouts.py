"""Start grids, obstacle layouts and re-placement poses (pure numpy, explicit rng)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from h2h_racing.track.shape import Track

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

OBSTACLE_CLEAR_START = 3.0
"""No obstacle is placed within this many metres after the start line [m]."""
OBSTACLE_CLEAR_END = 1.0
"""No obstacle is placed within this many metres behind the start grid's last slot [m]."""
MIDDLE_MARGIN = 0.2
"""A randomised obstacle keeps at least this fraction of its share of the lap from either end
of the share, so neighbours stay at least 2 x 0.2 = 40 % of a share apart."""
BOT_CLEAR_START = 2.0
"""The first bot starts this far ahead of the start point [m] (DeepRacer's
``MIN_DISTANCE_BETWEEN_BOT_CARS`` doubles as the first position)."""
BOT_CLEAR_END = 1.0
"""The last bot starts at least this far before the start grid's last slot [m] (DeepRacer:
``L - 1.0``)."""
BOT_MIN_GAP = 2.0
"""Smallest distance between neighbouring bots at the start [m]
(``MIN_DISTANCE_BETWEEN_BOT_CARS``)."""


def lane_offset(track: Track, s: FloatArray, lane: FloatArray) -> FloatArray:
    """Return the lateral offset of a lane at arc positions ``s``.

    Lane +1 is the left lane (mid-line between centre and left border), -1 the right lane,
    0 the centre line, following DeepRacer's lanes.
    """
    left, right = track.half_widths_at(s)
    return 0.5 * np.where(lane > 0, left, -right) * (lane != 0)


def grid_slots(num_cars: int, spacing: float, inner_sign: int) -> tuple[FloatArray, FloatArray]:
    """Return the arc offset (<= 0, from the start) and lane of each grid slot.

    Slot k starts ``k * spacing`` metres behind the start line (DeepRacer's
    ``START_POS_OFFSET``); odd slots on the inner lane, even slots on the outer lane, and a
    single car on the centre line (``TrackData.get_racecar_start_pose``).

    Args:
        num_cars: Number of slots.
        spacing: Distance between consecutive slots [m].
        inner_sign: +1 when the inside of the loop is on the left of travel, else -1.

    Returns:
        ``(offset (N,), lane (N,))``.
    """
    k = np.arange(num_cars)
    offset = -spacing * k.astype(np.float64)
    if num_cars == 1:
        return offset, np.zeros(1)
    lane = np.where(k % 2 == 1, inner_sign, -inner_sign).astype(np.float64)
    return offset, lane


def grid_assignment(rng: np.random.Generator, num_envs: int, num_cars: int,
                    random: bool) -> IntArray:
    """Return the grid slot of each car, shape (M, N): a random permutation per env copy
    when ``random`` (seat fairness), else car i in slot i."""
    if not random:
        return np.broadcast_to(np.arange(num_cars), (num_envs, num_cars)).copy()
    return np.argsort(rng.random((num_envs, num_cars)), axis=1)


def poses_on_track(track: Track, s: FloatArray, d: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return world positions (..., 2) and headings (...) at arc positions and offsets."""
    return track.point_at(s, d), track.heading_at(s)


def obstacle_layout(track: Track, rng: np.random.Generator, num_envs: int, count: int,
                    positions: tuple[tuple[float, int], ...] | None, randomize: bool,
                    inner_sign: int, grid_length: float = 0.0,
                    min_gap: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """Place ``count`` obstacles per env copy on the lanes.

    Fixed ``positions`` are (fraction of the lap, lane). Otherwise obstacles are spaced
    evenly over the lap, clear of the start, on alternating lanes starting with the inner
    lane (DeepRacer's ``obstacles_agent_ctrl``); with ``randomize`` each one is re-drawn
    uniformly within the middle of its share of the lap, on a random lane, per env copy, so
    that neighbours stay at least ``min_gap`` [m] and 40 % of a share apart (evenly spaced
    where a share is shorter than ``min_gap``). ``grid_length`` [m] is how far the start grid
    reaches behind the line; obstacles keep clear of it.

    Returns:
        ``(s (M, K), lane (M, K))``.
    """
    if count == 0:
        return np.zeros((num_envs, 0)), np.zeros((num_envs, 0))
    length = track.length
    if positions is not None and not randomize:
        fixed = np.array(positions[:count], dtype=np.float64).reshape(-1, 2)
        s = np.broadcast_to(fixed[:, 0] * length, (num_envs, len(fixed))).copy()
        lane = np.broadcast_to(fixed[:, 1], (num_envs, len(fixed))).copy()
        return s, lane
    usable = length - OBSTACLE_CLEAR_START - OBSTACLE_CLEAR_END - grid_length
    share = usable / count
    k = np.arange(count, dtype=np.float64)
    if randomize:
        # Obstacle k sits at share (k + u_k) with u_k uniform on [a, 1 - a]; neighbours are
        # share (1 + u_k+1 - u_k) >= 2 a share apart, so a = min_gap / (2 share), at least
        # 0.2 (40 % of a share) and at most 0.5 (even spacing).
        a = min(max(MIDDLE_MARGIN, min_gap / (2.0 * share)), 0.5)
        u = a + (1.0 - 2.0 * a) * rng.random((num_envs, count))
        lane = np.where(rng.random((num_envs, count)) < 0.5, 1.0, -1.0)
    else:
        u = np.full((num_envs, count), 0.5)
        lane = np.broadcast_to(np.where(k % 2 == 0, inner_sign, -inner_sign),
                               (num_envs, count)).astype(np.float64)
    s = OBSTACLE_CLEAR_START + share * (k[None, :] + u)
    return s, lane


def bot_layout(length: float, rng: np.random.Generator, num_envs: int, count: int,
               randomize: bool, inner_sign: int, start: FloatArray,
               grid_length: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """Place ``count`` bot cars per env copy on the lanes, ahead of the start grid.

    DeepRacer's ``bot_cars_agent_ctrl`` spaces bots evenly, ``linspace(2.0, L - 1.0, n)``
    metres, on alternating lanes starting with the inner lane. Here the span is measured
    from each copy's start point ``start`` (so bots stay clear of the grid wherever the
    episode starts) and ends ``BOT_CLEAR_END + grid_length`` metres before it comes round
    again. With ``randomize`` the positions are drawn uniformly among the layouts whose
    neighbours are at least ``BOT_MIN_GAP`` apart (sorted uniform draws in the span shortened
    by the gaps, then the gaps added back), and each lane is drawn as a fair coin.

    Args:
        length: Lap length L [m].
        rng: Source of the random draws (used only with ``randomize``).
        num_envs: Env copies M to lay out.
        count: Bots per copy B.
        randomize: Draw positions and lanes instead of spacing them evenly.
        inner_sign: +1 when the inside of the loop is on the left of travel, else -1.
        start: Arc position of each copy's start point, shape (M,) [m].
        grid_length: How far the start grid reaches behind the start point [m].

    Returns:
        ``(s (M, B), lane (M, B))``: unwrapped arc positions [m] (``start`` plus the
        offset; wrap them modulo L) and lanes (+1 left, -1 right).

    Raises:
        ValueError: The lap is too short for ``count`` bots ``BOT_MIN_GAP`` apart.

    >>> s, lane = bot_layout(20.0, np.random.default_rng(0), 1, 3, False, 1, np.zeros(1))
    >>> s.tolist(), lane.tolist()
    ([[2.0, 10.5, 19.0]], [[1.0, -1.0, 1.0]])
    """
    if count == 0:
        return np.zeros((num_envs, 0)), np.zeros((num_envs, 0))
    first = BOT_CLEAR_START
    last = length - BOT_CLEAR_END - grid_length
    span = last - first
    if span < (count - 1) * BOT_MIN_GAP or span < 0.0:
        raise ValueError(
            f"{count} bots need {(count - 1) * BOT_MIN_GAP + BOT_CLEAR_START + BOT_CLEAR_END:.1f} "
            f"m of lap plus the start grid ({grid_length:.2f} m), but the lap is {length:.2f} m; "
            f"use fewer bots (num_bots) or a longer track")
    k = np.arange(count, dtype=np.float64)
    start = np.asarray(start, dtype=np.float64).reshape(num_envs, 1)
    if randomize:
        free = span - (count - 1) * BOT_MIN_GAP
        offset = np.sort(rng.uniform(0.0, free, (num_envs, count)), axis=1) + k * BOT_MIN_GAP
        lane = np.where(rng.random((num_envs, count)) < 0.5, 1.0, -1.0)
    else:
        even = np.linspace(0.0, span, count) if count > 1 else np.zeros(1)
        offset = np.broadcast_to(even, (num_envs, count))
        lane = np.broadcast_to(np.where(k % 2 == 0, inner_sign, -inner_sign),
                               (num_envs, count)).astype(np.float64)
    return start + first + offset, lane


def replacement_candidates(track: Track, s: FloatArray, lane: FloatArray,
                           step_back: float, tries: int, forward: FloatArray | None = None,
                           forward_step: float = 0.25,
                           ) -> tuple[FloatArray, FloatArray]:
    """Candidate re-placement arc positions and lanes for each car, in order of preference.

    Candidate ``2t`` is ``t * step_back`` metres behind ``s`` on ``lane``, candidate
    ``2t + 1`` the same on the other lane. With ``forward`` (R,), candidates ``forward_step``,
    ``2 forward_step``, ... up to ``forward`` metres ahead of ``s`` on ``lane`` come right
    after the first (rows with a shorter or no reach repeat their last spot).

    Returns:
        ``(s (R, C), lane (R, C))``: C = 2 * tries, plus the forward candidates.
    """
    back = np.repeat(np.arange(tries, dtype=np.float64) * step_back, 2)
    flip = np.tile(np.array([1.0, -1.0]), tries)
    cand_s = s[:, None] - back[None, :]
    cand_lane = lane[:, None] * flip[None, :]
    if forward is not None and len(s):
        reach = int(np.ceil(forward.max() / forward_step - 1e-9))
        ahead = np.minimum(np.arange(1, reach + 1) * forward_step, forward[:, None])
        cand_s = np.concatenate([cand_s[:, :1], s[:, None] + ahead, cand_s[:, 1:]], axis=1)
        cand_lane = np.concatenate([cand_lane[:, :1], np.repeat(lane[:, None], reach, axis=1),
                                    cand_lane[:, 1:]], axis=1)
    return cand_s, cand_lane
