"""Where a car is put back on the track after its penalty: the first clear candidate spot.

A spot is clear when the re-placed car's box, grown by ``REPLACE_GAP`` on every side, does
not overlap any other body of its env copy: the other cars (wherever they are: racing, frozen
or parked), the obstacle boxes and the bot cars, each with its own box and heading (the
separating-axis test of two rectangles, exact). On a narrow track such as ``technical`` (lanes
0.38 m apart) the other lane beside a box or a car is then still free, as it is for a car
that drives past.

Cars re-placed in the same step are placed one after the other, each checked against the new
positions of those placed before it. A car with no clear spot is not placed (the core keeps it
frozen, out of the way, and tries again next step).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

REPLACE_STEP = 0.5
"""Candidate spots are this far apart along the track, back from the re-placement point [m]."""
REPLACE_TRIES = 8
"""Candidate distances (each on the car's lane, then the other): up to 3.5 m back, room to get
behind two boxes a metre apart on a narrow track (where a box closes both lanes)."""
RESET_BEHIND_OBSTACLE = 1.0
"""After a crash into a box the car is put back this far behind it, on the other lane:
DeepRacer's ``RESET_BEHIND_DIST`` [m]."""
OBSTACLE_APPROACH = 0.75
"""Where another body takes that spot, the next candidates move up the clear lane towards
the box, in steps of 0.25 m up to this far (its centre 0.25 m behind the box's, beside it),
before the usual ones step back on either lane [m]: a car put back 1 m behind the box in
the box's own lane (a second box on the clear lane just behind) cannot steer round it from
a standstill, and hits it again at every reset."""
REPLACE_GAP = 0.07
"""Room a re-placed car keeps round its box to every other body [m]: more than a bot travels
in one step at its default 0.75 m/s (0.05 m), so a bot behind does not touch it before it can
move."""


@njit(cache=True)
def _apart(x: float, y: float, yaw: float, half_l: float, half_w: float, ox: float, oy: float,
           oyaw: float, other_l: float, other_w: float) -> bool:  # pragma: no cover
    """Whether two rectangles (centre, heading, half length, half width) do not overlap: some
    axis of either separates their projections (touching counts as apart)."""
    c, s = math.cos(yaw), math.sin(yaw)
    oc, os_ = math.cos(oyaw), math.sin(oyaw)
    dx, dy = ox - x, oy - y
    for ux, uy in ((c, s), (-s, c), (oc, os_), (-os_, oc)):
        reach = (half_l * abs(ux * c + uy * s) + half_w * abs(-ux * s + uy * c)
                 + other_l * abs(ux * oc + uy * os_) + other_w * abs(-ux * os_ + uy * oc))
        if abs(dx * ux + dy * uy) >= reach:
            return True
    return False


@njit(cache=True)
def _clear(x: float, y: float, yaw: float, half_l: float, half_w: float, others: FloatArray,
           others_yaw: FloatArray, skip: int, other_l: float, other_w: float) -> bool:
    """Whether the rectangle at (x, y, yaw) is apart from every body of ``others`` (K, 2) /
    ``others_yaw`` (K,) (all of half size ``other_l`` x ``other_w``) but ``skip``."""
    for j in range(others.shape[0]):
        if j != skip and not _apart(x, y, yaw, half_l, half_w, others[j, 0], others[j, 1],
                                    others_yaw[j], other_l, other_w):
            return False
    return True


@njit(cache=True)
def place_kernel(env_idx: IntArray, car_idx: IntArray, cand_pos: FloatArray,
                 cand_yaw: FloatArray, position: FloatArray, yaw: FloatArray,
                 obstacle_position: FloatArray, obstacle_yaw: FloatArray,
                 bot_position: FloatArray, bot_yaw: FloatArray, car_size: FloatArray,
                 obstacle_size: FloatArray, gap: float, choice: IntArray) -> int:
    """Put each car on its first clear candidate spot, in row order.

    Args:
        env_idx, car_idx: Env copy and car of each car to re-place, (R,).
        cand_pos: Candidate centres in order of preference, (R, C, 2) [m].
        cand_yaw: Candidate headings, (R, C) [rad].
        position: Every car's centre, (E, N, 2) [m]; the placed cars' rows are overwritten,
            so later rows see them where they now are.
        yaw: Every car's heading, (E, N) [rad]; overwritten like ``position``.
        obstacle_position, obstacle_yaw: Obstacle poses, (E, K, 2) [m] and (E, K) [rad].
        bot_position, bot_yaw: Bot poses, (E, B, 2) [m] and (E, B) [rad].
        car_size: (length, width) of a car and of a bot [m].
        obstacle_size: (length, width) of an obstacle [m].
        gap: Room kept round the re-placed car's box [m].
        choice: Output, (R,): the candidate taken, or -1 where none was clear.

    Returns:
        How many cars were placed.
    """
    placed = 0
    car_l, car_w = 0.5 * car_size[0], 0.5 * car_size[1]
    obs_l, obs_w = 0.5 * obstacle_size[0], 0.5 * obstacle_size[1]
    half_l, half_w = car_l + gap, car_w + gap
    for r in range(env_idx.shape[0]):
        e = env_idx[r]
        i = car_idx[r]
        choice[r] = -1
        for c in range(cand_pos.shape[1]):
            x = cand_pos[r, c, 0]
            y = cand_pos[r, c, 1]
            h = cand_yaw[r, c]
            if (_clear(x, y, h, half_l, half_w, position[e], yaw[e], i, car_l, car_w)
                    and _clear(x, y, h, half_l, half_w, bot_position[e], bot_yaw[e], -1, car_l,
                               car_w)
                    and _clear(x, y, h, half_l, half_w, obstacle_position[e], obstacle_yaw[e],
                               -1, obs_l, obs_w)):
                choice[r] = c
                position[e, i, 0] = x
                position[e, i, 1] = y
                yaw[e, i] = h
                placed += 1
                break
    return placed
