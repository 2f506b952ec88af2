"""The compact, normalised state observation, batched over env copies and cars.

Every feature is a pure function of the core's state arrays (never of the spectator
renderer) and is clipped to [-OBS_BOUND, OBS_BOUND]. Layout of the vector for one car:

==========  ============================================================  =================
index       feature                                                       scale
==========  ============================================================  =================
0           forward speed                                                 / max speed
1           lateral (sideslip) speed                                      / max speed
2           yaw rate                                                      / 2 pi rad/s
3           steering angle                                                / max steer
4           lateral offset from the centre line (left +)                  / half-width
5, 6        sin, cos of the heading error (car yaw - track heading)       -
7 .. 14     centre-line curvature 0, .5, 1, 1.5, 2, 3, 4, 5 m ahead       * 0.5 m
15, 16      track half-width left, right                                  / 0.5 m
17          race position (0 = leader, 1 = last)                          -
18          frozen by a penalty (1) or racing (0)                         -
then per opponent slot (nearest first by track distance within 5 m, ``opponent_slots``;
the other cars and the bot cars compete for the slots alike):
+0          present (1) or empty slot (0)                                 -
+1          arc gap to it, ahead positive                                 / 5 m
+2          its lateral offset minus ours                                 / 1 m
+3          its forward speed minus ours                                  / max speed
then per obstacle slot (nearest first from 0.5 m behind to 5 m ahead, ``obstacle_slots``):
+0          present (1) or empty slot (0)                                 -
+1          arc distance ahead (negative: beside or just behind)          / 5 m
+2          its lateral offset minus ours                                 / 1 m
==========  ============================================================  =================

Empty slots are all zeros. Ties in distance go to the lower car or obstacle index (cars
before bots). A bot's speed is its speed along the track over the last step (0 while paused).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing.track import tables as tt
from h2h_racing.track.lookup import lookup_span, wrap_angle, wrap_arc

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore

OBS_BOUND = 5.0
"""Every feature is clipped to [-OBS_BOUND, OBS_BOUND]."""
LOOKAHEAD = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0])
"""Distances ahead at which the centre-line curvature is observed [m]."""
SENSE_RANGE = 5.0
"""Opponents and obstacles are described within this arc distance [m]."""
OBSTACLE_BEHIND = 0.5
"""Obstacles stay in the obstacle slots until this far behind the car's centre [m]: a box
(0.5 m long) is past a car (0.32 m) once its centre is 0.41 m behind the car's, and a car
that steered round it must know it is beside it until then, or it steers back into it."""
BASE_FEATURES = 19
OPPONENT_FEATURES = 4
OBSTACLE_FEATURES = 3
MOTION_FEATURES = (0, 3)
"""Indices of the car's own forward speed and steering angle in the state vector: what a car
knows of itself without seeing the world (odometry and its steering servo). Camera-only
policies get these beside the image (``h2h_racing.training.vec_env``'s ``motion`` group)."""


def state_size(opponent_slots: int, obstacle_slots: int) -> int:
    """Length of the state vector for the given numbers of slots."""
    return BASE_FEATURES + OPPONENT_FEATURES * opponent_slots + OBSTACLE_FEATURES * obstacle_slots


def state_observation(core: RaceCore) -> npt.NDArray[np.float32]:
    """Return the state observation of every car, shape (E, N, F), float32."""
    cfg = core.config
    tables = core.tables
    out = np.empty((core.num_envs, core.num_cars,
                    state_size(cfg.opponent_slots, cfg.obstacle_slots)), dtype=np.float32)
    _state_kernel(core._car_vectors, core._car_floats, core._car_counts, core._racing,
                  core._car_flags, core.obstacle_s,
                  core.obstacle_d, core.bot_s, core.bot_d, core.bot_speed, core.track_index,
                  tables.scalars, tables.fields,
                  cfg.car.max_speed, cfg.car.max_steer,
                  cfg.opponent_slots, cfg.obstacle_slots, LOOKAHEAD, out)
    return out


@njit(cache=True, inline="always")
def _clip(value: float) -> float:  # pragma: no cover
    return min(max(value, -OBS_BOUND), OBS_BOUND)


@njit(cache=True)
def _take_nearest(distance):  # pragma: no cover
    """Return the index of the smallest finite entry (lowest index on ties) and mark it taken
    (set to inf); -1 when every entry is inf."""
    best = -1
    for j in range(distance.shape[0]):
        if distance[j] < np.inf and (best < 0 or distance[j] < distance[best]):
            best = j
    if best >= 0:
        distance[best] = np.inf
    return best


@njit(cache=True)
def _state_kernel(car_vectors, car_floats, car_counts, racing, car_flags, obstacle_s,
                  obstacle_d, bot_s, bot_d, bot_speed, track_index, track_scalars, fields,
                  max_speed, max_steer, m_slots, k_slots, lookahead, out):  # pragma: no cover
    """Compiled loop over env copies and cars filling ``out`` (E, N, F); the car fields come
    as the core's blocks (rows as in ``race.CAR_*``), the tracks' lookup tables as a
    ``TrackTables``' ``scalars`` and ``fields``, copy e on track ``track_index[e]``."""
    heading, curvature = fields[tt.HEADING], fields[tt.CURVATURE]
    width_left, width_right = fields[tt.WIDTH_LEFT], fields[tt.WIDTH_RIGHT]
    velocity = car_vectors[1]
    yaw, yaw_rate, steer, speed = car_floats[0], car_floats[1], car_floats[2], car_floats[3]
    s, d = car_floats[4], car_floats[5]
    rank = car_counts[8]
    done = car_flags[0]
    num_envs, num_cars = s.shape
    num_obstacles = obstacle_s.shape[1]
    num_bots = bot_s.shape[1]
    inv_v = 1.0 / max_speed
    gaps = np.empty(num_cars + num_bots)
    ahead = np.empty(max(num_obstacles, 1))
    ahead_distance = np.empty(max(num_obstacles, 1))
    for e in range(num_envs):
        t = track_index[e]
        length = track_scalars[t, tt.LENGTH]
        inv_ds = track_scalars[t, tt.INV_DS]
        first = int(track_scalars[t, tt.LUT_FIRST])
        count = int(track_scalars[t, tt.LUT_COUNT])
        for i in range(num_cars):
            si = s[e, i]
            di = d[e, i]
            c = math.cos(yaw[e, i])
            sn = math.sin(yaw[e, i])
            left = lookup_span(width_left, first, count, si, inv_ds, length)
            right = lookup_span(width_right, first, count, si, inv_ds, length)
            error = wrap_angle(yaw[e, i] - lookup_span(heading, first, count, si, inv_ds,
                                                       length))
            row = out[e, i]
            row[0] = _clip(speed[e, i] * inv_v)
            row[1] = _clip((c * velocity[e, i, 1] - sn * velocity[e, i, 0]) * inv_v)
            row[2] = _clip(yaw_rate[e, i] / (2.0 * math.pi))
            row[3] = _clip(steer[e, i] / max_steer)
            row[4] = _clip(di / (left if di >= 0.0 else right))
            row[5] = math.sin(error)
            row[6] = math.cos(error)
            for k in range(lookahead.shape[0]):
                row[7 + k] = _clip(0.5 * lookup_span(curvature, first, count, si + lookahead[k],
                                                     inv_ds, length))
            row[15] = _clip(2.0 * left)
            row[16] = _clip(2.0 * right)
            row[17] = (rank[e, i] - 1) / (num_cars - 1) if num_cars > 1 else 0.0
            row[18] = 0.0 if (racing[e, i] or done[e, i]) else 1.0
            col = 19
            # Opponents: the m_slots nearest other cars and bots by |arc gap| within
            # SENSE_RANGE (candidate j >= num_cars is bot j - num_cars).
            for j in range(num_cars):
                gap = wrap_arc(s[e, j] - si, length)
                gaps[j] = abs(gap) if (j != i and not done[e, j]
                                       and abs(gap) <= SENSE_RANGE) else np.inf
            for j in range(num_bots):
                gap = wrap_arc(bot_s[e, j] - si, length)
                gaps[num_cars + j] = abs(gap) if abs(gap) <= SENSE_RANGE else np.inf
            for slot in range(m_slots):
                best = _take_nearest(gaps)
                base = col + 4 * slot
                if best < 0:
                    for f in range(4):
                        row[base + f] = 0.0
                    continue
                if best < num_cars:
                    other_s, other_d, other_v = s[e, best], d[e, best], speed[e, best]
                else:
                    other_s = bot_s[e, best - num_cars]
                    other_d = bot_d[e, best - num_cars]
                    other_v = bot_speed[e, best - num_cars]
                gap = wrap_arc(other_s - si, length)
                row[base] = 1.0
                row[base + 1] = _clip(gap / SENSE_RANGE)
                row[base + 2] = _clip(other_d - di)
                row[base + 3] = _clip((other_v - speed[e, i]) * inv_v)
            col += 4 * m_slots
            # Obstacles: the k_slots nearest from OBSTACLE_BEHIND behind to SENSE_RANGE
            # ahead (a = arc distance from the back of that window, in [0, L)).
            for k in range(num_obstacles):
                a = obstacle_s[e, k] - si + OBSTACLE_BEHIND
                a = a - length * math.floor(a / length)
                ahead[k] = a if a <= SENSE_RANGE + OBSTACLE_BEHIND else np.inf
                ahead_distance[k] = a - OBSTACLE_BEHIND
            for slot in range(k_slots):
                base = col + 3 * slot
                best = _take_nearest(ahead[:num_obstacles])
                if best < 0:
                    for f in range(3):
                        row[base + f] = 0.0
                    continue
                row[base] = 1.0
                row[base + 1] = _clip(ahead_distance[best] / SENSE_RANGE)
                row[base + 2] = _clip(obstacle_d[e, best] - di)
