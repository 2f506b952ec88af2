"""Scripted bot cars (DeepRacer's HEAD_TO_BOT): open-loop lane motion, batched over (E, B).

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
works on ``(E, B)`` arrays (env copies, bots) at once; the poses are evaluated in compiled
kernels from the track's uniform tables (``TrackLookup``: centre point, heading, widths), each
copy's from its own track's (``TrackTables``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing.track import tables as tt
from h2h_racing.track.lookup import lookup_span, wrap_angle

if TYPE_CHECKING:
    from h2h_racing.track.tables import TrackTables

FloatArray = npt.NDArray[np.float64]


def lane_blend(u: FloatArray) -> FloatArray:
    """Return the cosine blend ``(1 - cos(pi u)) / 2`` of ``u`` clipped to [0, 1].

    >>> lane_blend(np.array([-1.0, 0.0, 0.5, 1.0, 2.0])).round(12).tolist()
    [0.0, 0.0, 0.5, 1.0, 1.0]
    """
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(u, 0.0, 1.0))


def bot_poses(tables: TrackTables, track_index: npt.NDArray[np.int64], start: FloatArray,
              lane_from: FloatArray, lane_to: FloatArray, change_start: FloatArray,
              clock: FloatArray, duration: float, speed: float,
              ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Return where the bots are at their copy's bot clock.

    Args:
        tables: The tracks' tables (``TrackTables``), in driving order.
        track_index: The track of each copy, (E,).
        start: Unwrapped arc position of each bot at clock 0, (E, B) [m].
        lane_from: Lane each bot's last lane change started from, (E, B) (+1 / -1).
        lane_to: Lane it goes to (or is in), (E, B).
        change_start: Bot clock at which that change started, (E, B) [s] (-inf: none yet).
        clock: Bot clock of each copy, (E,) [s].
        duration: Length of a lane change T [s].
        speed: Bot speed v [m/s].

    Returns:
        ``(distance (E, B) [m, unwrapped], s (E, B) [m in [0, L)], d (E, B) [m, left +],
        position (E, B, 2) [m], yaw (E, B) [rad in [-pi, pi)])``.
    """
    shape = np.shape(start)
    distance, s, d, yaw = (np.empty(shape) for _ in range(4))
    position = np.zeros((*shape, 2))
    moved = np.zeros(shape[0])
    scratch = np.zeros((shape[0], shape[1], 2))
    command = np.zeros((shape[0] * shape[1], 3))
    move_kernel(np.ascontiguousarray(start, dtype=np.float64), lane_from, lane_to,
                change_start, np.asarray(clock, dtype=np.float64), moved, duration, speed, 0.0,
                np.asarray(track_index, dtype=np.int64), tables.scalars, tables.fields,
                distance, s, d, position, yaw, scratch, np.zeros(shape), command)
    return distance, s, d, position, yaw


@njit(cache=True)
def advance_clock_kernel(time, steps, done, pause_until, dt, clock, moved,
                         next_change):  # pragma: no cover
    """Advance each copy's bot clock over the coming step; return whether a change is due.

    The copy's sim clock goes from ``time[e]`` to ``(steps[e] + 1) dt`` when one of its cars
    is not done (else it stops); the bots drive the part of that interval after
    ``pause_until[e]``: ``moved[e] = max(0, t_after - max(time[e], pause_until[e]))`` [s].
    """
    any_due = False
    for e in range(clock.shape[0]):
        active = False
        for i in range(done.shape[1]):
            active = active or not done[e, i]
        t_after = (steps[e] + 1) * dt if active else time[e]
        m = max(t_after - max(time[e], pause_until[e]), 0.0)
        moved[e] = m
        clock[e] += m
        for j in range(next_change.shape[1]):
            if next_change[e, j] <= clock[e]:
                any_due = True
    return any_due


@njit(cache=True)
def move_kernel(start, lane_from, lane_to, change_start, clock, moved, duration, speed,
                inv_dt, track_index, track_scalars, fields, distance, s, d, position, yaw,
                velocity, bot_speed, command):  # pragma: no cover
    """The bots' poses at their clocks (module docstring), from the tables of each copy's
    track (``track_index`` (E,) into a ``TrackTables``' ``scalars`` and ``fields``).

    ``position`` and ``yaw`` are read (the poses at the start of the step) and overwritten;
    ``velocity`` (E, B, 2) [m/s] and ``command`` (E * B, 3) = (vx, vy, omega) get the
    velocities that carry each bot from the old pose to the new one in ``1 / inv_dt``
    seconds, and ``bot_speed`` (E, B) [m/s] the speed along the track, ``speed * moved *
    inv_dt`` (with ``inv_dt = 0`` all three are zero: a placement, not a step).
    """
    num_envs, num_bots = start.shape
    half_pi_t = 0.5 * math.pi / duration
    x_tab, y_tab, heading_tab = fields[tt.X], fields[tt.Y], fields[tt.HEADING]
    left_tab, right_tab = fields[tt.WIDTH_LEFT], fields[tt.WIDTH_RIGHT]
    for e in range(num_envs):
        t = track_index[e]
        length = track_scalars[t, tt.LENGTH]
        inv_ds = track_scalars[t, tt.INV_DS]
        first = int(track_scalars[t, tt.LUT_FIRST])
        count = int(track_scalars[t, tt.LUT_COUNT])
        for j in range(num_bots):
            dist = start[e, j] + speed * clock[e]
            distance[e, j] = dist
            sj = dist - length * math.floor(dist / length)
            s[e, j] = sj
            u = (clock[e] - change_start[e, j]) / duration
            uc = min(max(u, 0.0), 1.0)
            step = lane_to[e, j] - lane_from[e, j]
            lane = lane_from[e, j] + step * (0.5 - 0.5 * math.cos(math.pi * uc))
            rate = step * half_pi_t * math.sin(math.pi * uc) if 0.0 < u < 1.0 else 0.0
            if lane >= 0.0:
                half = 0.5 * lookup_span(left_tab, first, count, sj, inv_ds, length)
            else:
                half = 0.5 * lookup_span(right_tab, first, count, sj, inv_ds, length)
            dj = lane * half
            d[e, j] = dj
            psi = lookup_span(heading_tab, first, count, sj, inv_ds, length)
            px = lookup_span(x_tab, first, count, sj, inv_ds, length) - dj * math.sin(psi)
            py = lookup_span(y_tab, first, count, sj, inv_ds, length) + dj * math.cos(psi)
            new_yaw = wrap_angle(psi + math.atan2(rate * half, speed))
            k = e * num_bots + j
            vx = (px - position[e, j, 0]) * inv_dt
            vy = (py - position[e, j, 1]) * inv_dt
            velocity[e, j, 0] = vx
            velocity[e, j, 1] = vy
            command[k, 0] = vx
            command[k, 1] = vy
            command[k, 2] = wrap_angle(new_yaw - yaw[e, j]) * inv_dt
            bot_speed[e, j] = speed * moved[e] * inv_dt
            position[e, j, 0] = px
            position[e, j, 1] = py
            yaw[e, j] = new_yaw


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
