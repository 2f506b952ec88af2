"""Scripted bot cars (DeepRacer's HEAD_TO_BOT): open-loop motion along the lanes, pure numpy.

A bot drives a DeepRacer lane (the mid-line between the centre line and a border) at a
constant speed ``v`` and never reacts to the cars (``bot_cars_agent_ctrl``). Everything about
it is a function of its env copy's **bot clock** ``tau``: the seconds the bots of that copy
have driven, which stops while they are paused. With ``s0`` the bot's start position::

    distance(tau) = s0 + v tau                              [m, unwrapped; s = distance mod L]

A lane change from lane ``a`` to lane ``b`` (+1 left, -1 right) that starts at ``tau_c`` lasts
``T = lane_change_distance / v`` seconds. Its lane coordinate follows a cosine blend, which
starts and ends with zero lateral speed::

    u = clip((tau - tau_c) / T, 0, 1)
    lane(tau) = a + (b - a) (1 - cos(pi u)) / 2
    d = lane * half_width(s) / 2                            (half_width: left for lane >= 0,
                                                             right for lane < 0)

and the bot's heading is the track's plus the angle of its lateral motion::

    d_dot = (b - a) (pi / 2T) sin(pi u) * half_width(s) / 2   (0 outside 0 < u < 1)
    yaw = heading(s) + atan2(d_dot, v)

The next change starts a uniform draw from [``gap_min``, ``gap_max``] seconds after the end
of the last one (the first one that long after the start), as in DeepRacer. Every function
works on ``(E, B)`` arrays (env copies, bots) at once.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from h2h_racing.track import Track

FloatArray = npt.NDArray[np.float64]


def lane_blend(u: FloatArray) -> FloatArray:
    """Return the cosine blend ``(1 - cos(pi u)) / 2`` of ``u`` clipped to [0, 1].

    >>> lane_blend(np.array([-1.0, 0.0, 0.5, 1.0, 2.0])).round(12).tolist()
    [0.0, 0.0, 0.5, 1.0, 1.0]
    """
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(u, 0.0, 1.0))


def bot_poses(track: Track, distance: FloatArray, lane_from: FloatArray,
              lane_to: FloatArray, change_start: FloatArray, clock: FloatArray,
              duration: float, speed: float,
              ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return where the bots are at their copy's bot clock.

    Args:
        track: The track in driving order.
        distance: Unwrapped arc position of each bot, (E, B) [m].
        lane_from: Lane each bot's last lane change started from, (E, B) (+1 / -1).
        lane_to: Lane it goes to (or is in), (E, B).
        change_start: Bot clock at which that change started, (E, B) [s] (-inf: none yet).
        clock: Bot clock of each copy, (E,) [s].
        duration: Length of a lane change T [s].
        speed: Bot speed v [m/s].

    Returns:
        ``(s (E, B) [m in [0, L)], d (E, B) [m, left +], position (E, B, 2) [m],
        yaw (E, B) [rad in [-pi, pi)])``.
    """
    u = (clock[:, None] - change_start) / duration
    moving = (u > 0.0) & (u < 1.0)
    step = lane_to - lane_from
    lane = lane_from + step * lane_blend(u)
    rate = np.where(moving, step * (0.5 * math.pi / duration)
                    * np.sin(math.pi * np.clip(u, 0.0, 1.0)), 0.0)
    s = np.mod(distance, track.length)
    left, right = track.half_widths_at(s)
    half = 0.5 * np.where(lane >= 0.0, left, right)
    d = lane * half
    yaw = track.heading_at(s) + np.arctan2(rate * half, speed)
    yaw = yaw - 2.0 * math.pi * np.floor((yaw + math.pi) / (2.0 * math.pi))
    return s, d, track.point_at(s, d), yaw


def schedule_lane_changes(clock: FloatArray, next_change: FloatArray, lane_from: FloatArray,
                          lane_to: FloatArray, change_start: FloatArray, duration: float,
                          gap_min: float, gap_max: float, rng: np.random.Generator) -> int:
    """Start the lane changes that are due by the bot clock ``clock`` (E,), in place.

    A bot whose ``next_change`` (E, B) [s] is at most its copy's clock starts a change then:
    ``lane_from`` takes its lane, ``lane_to`` the other lane, ``change_start`` the scheduled
    time (not the step's time, so the motion does not depend on the step length), and
    ``next_change`` moves to the end of the change plus a gap drawn from
    ``rng.uniform(gap_min, gap_max)`` (one draw per change started, in row-major order).

    Returns:
        The number of lane changes started.
    """
    started = 0
    due = next_change <= clock[:, None]
    # Usually no bot is due; a gap is at least gap_min > 0, so the loop ends.
    while due.any():
        count = int(due.sum())
        start = next_change[due]
        lane_from[due] = lane_to[due]
        lane_to[due] = -lane_to[due]
        change_start[due] = start
        next_change[due] = start + duration + rng.uniform(gap_min, gap_max, count)
        started += count
        due = next_change <= clock[:, None]
    return started
