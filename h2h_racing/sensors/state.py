"""The compact, normalised state observation, batched over env copies and cars.

Every feature is a pure function of the core's state arrays (never of the spectator
renderer) and is clipped to [-OBS_BOUND, OBS_BOUND]. Layout of the vector for one car:

==========  ============================================================  =================
index       feature                                                       scale
==========  ============================================================  =================
0           forward speed                                                 / max speed
1           lateral (sideslip) speed                                      / max speed
2           yaw rate                                                      / 2*pi rad/s
3           steering angle                                                / max steer
4           lateral offset from the centre line (left +)                  / half-width
5, 6        sin, cos of the heading error (car yaw - track heading)       -
7 .. 14     centre-line curvature 0, .5, 1, 1.5, 2, 3, 4, 5 m ahead       * 0.5 m
15, 16      track half-width left, right                                  / 0.5 m
17          race position (0 = leader, 1 = last)                          -
18          frozen by a penalty (1) or racing (0)                         -
then per opponent slot (nearest first by track distance, ``opponent_slots`` of them):
+0          present (1) or empty slot (0)                                 -
+1          arc gap to it, ahead positive                                 / 5 m
+2          its lateral offset minus ours                                 / 1 m
+3          its forward speed minus ours                                  / max speed
then per obstacle slot (nearest ahead within 5 m first, ``obstacle_slots`` of them):
+0          present (1) or empty slot (0)                                 -
+1          arc distance ahead                                            / 5 m
+2          its lateral offset minus ours                                 / 1 m
==========  ============================================================  =================
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from h2h_racing.race import wrap_arc

if TYPE_CHECKING:
    from h2h_racing.core import RaceCore

OBS_BOUND = 5.0
"""Every feature is clipped to [-OBS_BOUND, OBS_BOUND]."""
LOOKAHEAD = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0])
"""Distances ahead at which the centre-line curvature is observed [m]."""
SENSE_RANGE = 5.0
"""Opponents and obstacles are described within this arc distance [m]."""
BASE_FEATURES = 19
OPPONENT_FEATURES = 4
OBSTACLE_FEATURES = 3


def state_size(opponent_slots: int, obstacle_slots: int) -> int:
    """Length of the state vector for the given numbers of slots."""
    return BASE_FEATURES + OPPONENT_FEATURES * opponent_slots + OBSTACLE_FEATURES * obstacle_slots


def state_observation(core: RaceCore) -> npt.NDArray[np.float32]:
    """Return the state observation of every car, shape (E, N, F), float32."""
    cfg, track = core.config, core.track
    e, n = core.num_envs, core.num_cars
    m_slots, k_slots = cfg.opponent_slots, cfg.obstacle_slots
    out = np.zeros((e, n, state_size(m_slots, k_slots)), dtype=np.float64)
    inv_v = 1.0 / cfg.car.max_speed
    s, d = core.s, core.d
    heading = track.heading_at(s)
    sin_yaw, cos_yaw = np.sin(core.yaw), np.cos(core.yaw)
    lateral_speed = cos_yaw * core.velocity[..., 1] - sin_yaw * core.velocity[..., 0]
    error = core.yaw - heading
    left, right = track.half_widths_at(s)
    out[..., 0] = core.speed * inv_v
    out[..., 1] = lateral_speed * inv_v
    out[..., 2] = core.yaw_rate * (1.0 / (2.0 * np.pi))
    out[..., 3] = core.steer * (1.0 / cfg.car.max_steer)
    out[..., 4] = d / np.where(d >= 0.0, left, right)
    out[..., 5] = np.sin(error)
    out[..., 6] = np.cos(error)
    out[..., 7:15] = 0.5 * track.curvature_at(s[..., None] + LOOKAHEAD)
    out[..., 15] = left * 2.0
    out[..., 16] = right * 2.0
    if n > 1:
        out[..., 17] = (core.rank - 1) * (1.0 / (n - 1))
    out[..., 18] = core.frozen
    col = BASE_FEATURES
    if m_slots and n > 1:
        gap = wrap_arc(s[:, None, :] - s[:, :, None], track.length)  # gap[e, i, j]: j ahead of i
        hidden = np.eye(n, dtype=bool)[None] | core.done[:, None, :] | (np.abs(gap) > SENSE_RANGE)
        order = np.argsort(np.where(hidden, np.inf, np.abs(gap)), axis=2)[:, :, :m_slots]
        pick_gap = np.take_along_axis(gap, order, axis=2)
        present = ~np.take_along_axis(hidden, order, axis=2)
        other_d = np.take_along_axis(np.broadcast_to(d[:, None, :], (e, n, n)), order, axis=2)
        other_v = np.take_along_axis(np.broadcast_to(core.speed[:, None, :], (e, n, n)),
                                     order, axis=2)
        slots = out[..., col:col + OPPONENT_FEATURES * order.shape[2]].reshape(
            e, n, order.shape[2], OPPONENT_FEATURES)
        slots[..., 0] = present
        slots[..., 1] = pick_gap * (1.0 / SENSE_RANGE) * present
        slots[..., 2] = (other_d - d[..., None]) * present
        slots[..., 3] = (other_v - core.speed[..., None]) * inv_v * present
    col += OPPONENT_FEATURES * m_slots
    if k_slots and core.num_obstacles:
        ahead = np.mod(core.obstacle_s[:, None, :] - s[..., None], track.length)
        hidden = ahead > SENSE_RANGE
        order = np.argsort(np.where(hidden, np.inf, ahead), axis=2)[:, :, :k_slots]
        present = ~np.take_along_axis(hidden, order, axis=2)
        od = np.take_along_axis(np.broadcast_to(core.obstacle_d[:, None, :],
                                                (e, n, core.num_obstacles)), order, axis=2)
        slots = out[..., col:col + OBSTACLE_FEATURES * order.shape[2]].reshape(
            e, n, order.shape[2], OBSTACLE_FEATURES)
        slots[..., 0] = present
        slots[..., 1] = np.take_along_axis(ahead, order, axis=2) * (1.0 / SENSE_RANGE) * present
        slots[..., 2] = (od - d[..., None]) * present
    np.minimum(out, OBS_BOUND, out=out)
    np.maximum(out, -OBS_BOUND, out=out)
    return out.astype(np.float32)
