"""Where a car is put back on the track after its penalty: the first clear candidate spot.

A spot is clear when the re-placed car's footprint keeps ``REPLACE_GAP`` from every other
body of its env copy: the other cars (wherever they are: racing, frozen, waiting or parked),
the obstacle boxes and the bot cars. Footprints are the bodies' bounding circles (radius half
the box diagonal), which contain the boxes whatever their headings, so a clear spot can never
overlap a box (conservative: two cars nose to tail need a little more room than their boxes).

Cars re-placed in the same step are placed one after the other, each checked against the new
positions of those placed before it. A car with no clear spot is not placed (the core keeps it
frozen and tries again next step).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

REPLACE_GAP = 0.07
"""Room a re-placed car keeps between its bounding circle and every other body's [m]: more
than a bot travels in one step at its default 0.75 m/s (0.05 m), so a bot behind does not
touch it before it can move (for the default car, two cars' centres are then >= 0.45 m apart)."""


def footprint_radius(length: float, width: float) -> float:
    """Radius of the circle round a ``length`` x ``width`` box (half its diagonal) [m]."""
    return 0.5 * math.hypot(length, width)


@njit(cache=True)
def _clear(x: float, y: float, others: FloatArray, skip: int, min_dist: float) -> bool:
    """Whether (x, y) is at least ``min_dist`` from every point of ``others`` (K, 2) but
    ``skip``."""
    limit = min_dist * min_dist
    for j in range(others.shape[0]):
        if j == skip:
            continue
        dx = others[j, 0] - x
        dy = others[j, 1] - y
        if dx * dx + dy * dy < limit:
            return False
    return True


@njit(cache=True)
def place_kernel(env_idx: IntArray, car_idx: IntArray, cand_pos: FloatArray,
                 cand_yaw: FloatArray, position: FloatArray, yaw: FloatArray,
                 obstacle_position: FloatArray, bot_position: FloatArray, car_radius: float,
                 obstacle_radius: float, gap: float, choice: IntArray) -> int:
    """Put each car on its first clear candidate spot, in row order.

    Args:
        env_idx, car_idx: Env copy and car of each car to re-place, (R,).
        cand_pos: Candidate centres in order of preference, (R, C, 2) [m].
        cand_yaw: Candidate headings, (R, C) [rad].
        position: Every car's centre, (E, N, 2) [m]; the placed cars' rows are overwritten,
            so later rows see them where they now are.
        yaw: Every car's heading, (E, N) [rad]; overwritten like ``position``.
        obstacle_position: Obstacle centres, (E, K, 2) [m].
        bot_position: Bot centres, (E, B, 2) [m].
        car_radius: Footprint radius of a car (and bot) [m].
        obstacle_radius: Footprint radius of an obstacle [m].
        gap: Room to keep between footprints [m].
        choice: Output, (R,): the candidate taken, or -1 where none was clear.

    Returns:
        How many cars were placed.
    """
    placed = 0
    car_dist = 2.0 * car_radius + gap
    obstacle_dist = car_radius + obstacle_radius + gap
    for r in range(env_idx.shape[0]):
        e = env_idx[r]
        i = car_idx[r]
        choice[r] = -1
        for c in range(cand_pos.shape[1]):
            x = cand_pos[r, c, 0]
            y = cand_pos[r, c, 1]
            if (_clear(x, y, position[e], i, car_dist)
                    and _clear(x, y, bot_position[e], -1, car_dist)
                    and _clear(x, y, obstacle_position[e], -1, obstacle_dist)):
                choice[r] = c
                position[e, i, 0] = x
                position[e, i, 1] = y
                yaw[e, i] = cand_yaw[r, c]
                placed += 1
                break
    return placed
