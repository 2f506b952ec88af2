"""Steering and speed helpers the scripted drivers share: pure pursuit and the action map.

Steering is pure pursuit (Coulter, *Implementation of the Pure Pursuit Path Tracking
Algorithm*, CMU-RI-TR-92-01, 1992): with the rear axle at ``p``, a target point ``q`` on the
path at distance ``l_d`` and ``alpha`` the angle of ``q - p`` from the car's heading, the arc
through ``p`` and ``q`` has curvature ``2 sin(alpha) / l_d``, hence the steering angle
``delta = atan(2 L sin(alpha) / l_d)`` with ``L`` the wheelbase. The car model is close to
neutral steer (``l_f C_f = l_r C_r``), so the kinematic angle holds up to the grip limit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from h2h_racing.sim.core import RaceCore

FloatArray = npt.NDArray[np.float64]
ActionArray = npt.NDArray[np.float32]


def to_action(core: RaceCore, steer_rad: FloatArray, speed_mps: FloatArray) -> ActionArray:
    """Map a steering angle and a speed to the env's continuous action, with clipping.

    The inverse of ``EnvConfig.commands``: ``steer = (delta - steer_mid) / steer_half`` and
    ``speed = (v - speed_mid) / speed_half`` (``EnvConfig.action_affine``), both clipped to
    [-1, 1].

    Args:
        core: The simulation core (for the car and speed limits).
        steer_rad: Steering angles, shape (E,) [rad], left positive.
        speed_mps: Commanded speeds, shape (E,) [m/s].

    Returns:
        Actions, shape (E, 2), float32.
    """
    steer_mid, steer_half, speed_mid, speed_half = core.config.action_affine
    steer = (np.asarray(steer_rad, dtype=np.float64) - steer_mid) / steer_half
    speed = (np.asarray(speed_mps, dtype=np.float64) - speed_mid) / speed_half
    steer, speed = np.broadcast_arrays(steer, speed)
    out = np.stack([steer, speed], axis=-1)
    return np.clip(out, -1.0, 1.0).astype(np.float32)


def pursuit_steer(core: RaceCore, car: int, target: FloatArray) -> FloatArray:
    """Return the pure-pursuit steering angle towards world points ``target`` (E, 2) [rad].

    ``delta = atan(2 L sin(alpha) / l_d)`` from the rear axle (see the module docstring).
    """
    params = core.config.car
    yaw = core.yaw[:, car]
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    rear_x = core.position[:, car, 0] - params.cg_to_rear * cos_yaw
    rear_y = core.position[:, car, 1] - params.cg_to_rear * sin_yaw
    dx = target[:, 0] - rear_x
    dy = target[:, 1] - rear_y
    distance = np.maximum(np.hypot(dx, dy), 1e-6)
    # sin(alpha) = cross(heading, q - p) / |q - p|.
    sin_alpha = (cos_yaw * dy - sin_yaw * dx) / distance
    return np.arctan2(2.0 * params.wheelbase * sin_alpha, distance)


def lookahead(speed: FloatArray, base: float, gain: float, limit: float) -> FloatArray:
    """Return the look-ahead distance ``min(base + gain |v|, limit)`` [m], shape of ``speed``."""
    return np.minimum(base + gain * np.abs(speed), limit)
