"""Start grids, obstacle layouts and re-placement poses (pure numpy, explicit rng)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from h2h_racing.track import Track

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

OBSTACLE_CLEAR_START = 3.0
"""No obstacle is placed within this many metres after the start line [m]."""
OBSTACLE_CLEAR_END = 1.0
"""No obstacle is placed within this many metres behind the start grid's last slot [m]."""


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
                    inner_sign: int, grid_length: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """Place ``count`` obstacles per env copy on the lanes.

    Fixed ``positions`` are (fraction of the lap, lane). Otherwise obstacles are spaced
    evenly over the lap, clear of the start, on alternating lanes starting with the inner
    lane (DeepRacer's ``obstacles_agent_ctrl``); with ``randomize`` each one is re-drawn
    uniformly within its share of the lap, on a random lane, per env copy. ``grid_length``
    [m] is how far the start grid reaches behind the line; obstacles keep clear of it.

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
        # Uniform within the middle 60 % of each share, so neighbours stay >= 40 % apart.
        u = 0.2 + 0.6 * rng.random((num_envs, count))
        lane = np.where(rng.random((num_envs, count)) < 0.5, 1.0, -1.0)
    else:
        u = np.full((num_envs, count), 0.5)
        lane = np.broadcast_to(np.where(k % 2 == 0, inner_sign, -inner_sign),
                               (num_envs, count)).astype(np.float64)
    s = OBSTACLE_CLEAR_START + share * (k[None, :] + u)
    return s, lane


def replacement_candidates(track: Track, s: FloatArray, lane: FloatArray,
                           step_back: float, tries: int) -> tuple[FloatArray, FloatArray]:
    """Candidate re-placement arc positions and lanes for each car, in order of preference.

    Candidate ``2t`` is ``t * step_back`` metres behind ``s`` on ``lane``, candidate
    ``2t + 1`` the same on the other lane.

    Returns:
        ``(s (R, 2 * tries), lane (R, 2 * tries))``.
    """
    back = np.repeat(np.arange(tries, dtype=np.float64) * step_back, 2)
    flip = np.tile(np.array([1.0, -1.0]), tries)
    cand_s = s[:, None] - back[None, :]
    cand_lane = lane[:, None] * flip[None, :]
    return cand_s, cand_lane
