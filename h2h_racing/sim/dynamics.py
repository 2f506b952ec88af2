"""Car dynamics: a dynamic single-track (bicycle) model with tyre slip, batched in numpy.

The model is the classic linear-tyre single-track model (Rajamani, *Vehicle Dynamics and
Control*, 2nd ed. 2012, sec. 2.3; the "ST" model of Althoff et al., *CommonRoad: Vehicle
Models*, 2017) with a friction limit on each axle's lateral force. In the body frame, with
forward speed v_x, lateral speed v_y, yaw rate r and front steering angle delta:

    alpha_f = delta - (v_y + l_f r) / v_x          slip angle of the front axle
    alpha_r =       - (v_y - l_r r) / v_x          slip angle of the rear axle
    F_f = sat(C_f alpha_f, mu F_zf)                 lateral tyre forces, C = c_alpha * F_z
    F_r = sat(C_r alpha_r, mu F_zr)                 sat(x, m) = min(max(x, -m), m)
    m (dv_y/dt + v_x r) = F_f + F_r
    I_z dr/dt           = l_f F_f - l_r F_r

with static axle loads F_zf = m g l_r / L and F_zr = m g l_f / L. For a 1.5 kg car the
lateral dynamics are stiff (time constants of about 10 ms at 1 m/s), so the lateral state is
advanced with backward (implicit) Euler, which is stable at the env's 1/15 s step:
(I - dt A) x' = x + dt b for the linear part. The axle forces evaluated at that solution
are then saturated at mu F_z and the state is re-advanced with the saturated forces; when
no axle saturates this reproduces the implicit solution exactly, and when one does, the car
slides: cornering too fast runs wide (understeer, front saturated) or spins (rear).

At low speed the slip angles are singular (division by v_x), so below about 0.6 m/s the
state is blended into the kinematic bicycle model, r = v_x tan(delta) / L, v_y = l_r r,
as CommonRoad's ST model switches to the kinematic model at low speed.

The step is a compiled (numba) loop over the flat car arrays: for a single 2-car env the
per-call overhead of ~70 numpy operations (about 1 us each on tiny arrays) would cost more
than the physics itself, while the compiled loop costs about 1 us in total.

The longitudinal speed follows a proportional speed controller with acceleration limits,
as the real car's ESC tracks a commanded wheel speed. The step works on flat arrays
of any length (one entry per car, over all env copies).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing.config.env import CarParams

FloatArray = npt.NDArray[np.float64]

GRAVITY = 9.81
"""Standard gravity [m/s^2]."""
LOW_SPEED = 0.2
"""Below this forward speed [m/s] the kinematic model is used alone."""
BLEND_SPEED = 0.4
"""Width of the kinematic-to-dynamic blend above LOW_SPEED [m/s]."""


class SingleTrackModel:
    """Precomputed constants of the single-track model for one set of car parameters.

    Args:
        car: Car parameters (SI units).
    """

    def __init__(self, car: CarParams) -> None:
        self.car = car
        m, iz = car.mass, car.yaw_inertia
        lf, lr, wb = car.cg_to_front, car.cg_to_rear, car.wheelbase
        self.load_front = m * GRAVITY * lr / wb
        self.load_rear = m * GRAVITY * lf / wb
        cf = car.cornering_stiffness * self.load_front
        cr = car.cornering_stiffness * self.load_rear
        self.cf, self.cr = cf, cr
        self.max_force_front = car.friction * self.load_front
        self.max_force_rear = car.friction * self.load_rear
        # Coefficients of (I - dt A) that multiply dt / u (u = forward speed).
        self._k11 = (cf + cr) / m
        self._k12 = (cf * lf - cr * lr) / m
        self._k21 = (lf * cf - lr * cr) / iz
        self._k22 = (lf * lf * cf + lr * lr * cr) / iz
        self._b1 = cf / m
        self._b2 = lf * cf / iz
        self.params = np.array([
            car.max_steer_rate, car.speed_gain, car.max_brake, car.max_accel, self._k11,
            self._k12, self._k21, self._k22, self._b1, self._b2, cf, cr, self.max_force_front,
            self.max_force_rear, lf, lr, m, iz, wb, car.max_steer])
        """Constants of the kernel, in the order ``_single_track_step`` unpacks them."""

    def step(
        self,
        yaw: FloatArray,
        velocity: FloatArray,
        yaw_rate: FloatArray,
        steer: FloatArray,
        steer_command: FloatArray,
        speed_command: FloatArray,
        racing: npt.NDArray[np.bool_],
        dt: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Advance velocities, yaw rate and steering by one control step.

        Args:
            yaw: Heading of each car, shape (C,), radians.
            velocity: World-frame velocity, shape (C, 2), m/s.
            yaw_rate: Yaw rate, shape (C,), rad/s.
            steer: Current front steering angle, shape (C,), radians (left positive).
            steer_command: Commanded steering angle, shape (C,), radians (clipped to
                +-max_steer).
            speed_command: Commanded forward speed, shape (C,), m/s.
            racing: Cars that move; the others are held still, shape (C,).
            dt: Step length [s].

        Returns:
            ``(velocity, yaw_rate, steer)`` after the step: world-frame velocity (C, 2) to
            hold during the step (rotated to the mid-step heading, so that the chord driven
            during the step follows the arc), yaw rate (C,) and steering angle (C,).
        """
        command = np.empty((len(yaw), 3))
        new_steer = steer.copy()
        self.step_into(yaw, velocity, yaw_rate, new_steer, steer_command, speed_command, racing,
                       dt, command)
        return command[:, :2], command[:, 2], new_steer

    def step_into(self, yaw: FloatArray, velocity: FloatArray, yaw_rate: FloatArray,
                  steer: FloatArray, steer_command: FloatArray, speed_command: FloatArray,
                  racing: npt.NDArray[np.bool_], dt: float, command: FloatArray) -> None:
        """Like :meth:`step`, but update ``steer`` in place and write (vx, vy, omega) of each
        car into ``command`` (C, 3), e.g. the physics world's velocity buffer."""
        _single_track_step(yaw, velocity, yaw_rate, steer, steer_command, speed_command, racing,
                           dt, self.params, command)

    def steady_state_yaw_rate(self, speed: float, steer: float) -> float:
        """Return the linear model's steady-state yaw rate [rad/s] (for tests and docs).

        r_ss = v delta / (L + K_us v^2) with understeer gradient
        K_us = m (l_r C_r - l_f C_f) / (L C_f C_r)  (Rajamani eq. 3.15, in rad per m/s^2).
        """
        car = self.car
        k_us = car.mass * (car.cg_to_rear * self.cr - car.cg_to_front * self.cf) / (
            car.wheelbase * self.cf * self.cr)
        return speed * steer / (car.wheelbase + k_us * speed * speed)


@njit(cache=True, fastmath=False)
def _single_track_step(yaw, velocity, yaw_rate, steer, steer_command, speed_command, racing,
                       dt, params, command):  # pragma: no cover
    """Compiled loop over cars of the single-track step (see the module docstring)."""
    (steer_rate, gain, brake, accel_max, k11, k12, k21, k22, b1, b2, cf, cr, fmax_f, fmax_r,
     lf, lr, mass, iz, wheelbase, max_steer) = params
    max_delta = steer_rate * dt
    for i in range(yaw.shape[0]):
        if not racing[i]:
            command[i, 0] = 0.0
            command[i, 1] = 0.0
            command[i, 2] = 0.0
            steer[i] = 0.0
            continue
        c = math.cos(yaw[i])
        s = math.sin(yaw[i])
        vx = c * velocity[i, 0] + s * velocity[i, 1]
        vy = c * velocity[i, 1] - s * velocity[i, 0]
        r = yaw_rate[i]
        # Steering servo with a rate limit, toward the command clipped to the steering lock.
        target = min(max(steer_command[i], -max_steer), max_steer)
        delta = steer[i] + min(max(target - steer[i], -max_delta), max_delta)
        # Speed controller: a_x = k (v_cmd - v_x), limited to [-brake, accel].
        ax = min(max(gain * (speed_command[i] - vx), -brake), accel_max)
        vx = vx + ax * dt
        # Implicit Euler of the linear lateral dynamics: solve (I - dt A) x' = x + dt b.
        u = max(abs(vx), LOW_SPEED)
        p = dt / u
        m11 = 1.0 + k11 * p
        m12 = k12 * p + dt * vx
        m21 = k21 * p
        m22 = 1.0 + k22 * p
        rhs1 = vy + dt * b1 * delta
        rhs2 = r + dt * b2 * delta
        inv_det = 1.0 / (m11 * m22 - m12 * m21)
        vy_lin = (rhs1 * m22 - m12 * rhs2) * inv_det
        r_lin = (m11 * rhs2 - m21 * rhs1) * inv_det
        # Axle forces at the implicit solution, saturated by the friction limit; the state is
        # re-advanced with them (identical to the implicit solution when nothing saturates).
        force_f = cf * (delta - (vy_lin + lf * r_lin) / u)
        force_r = cr * (lr * r_lin - vy_lin) / u
        force_f = min(max(force_f, -fmax_f), fmax_f)
        force_r = min(max(force_r, -fmax_r), fmax_r)
        r_dyn = r + dt / iz * (lf * force_f - lr * force_r)
        vy_dyn = vy + dt / mass * (force_f + force_r) - dt * vx * r_dyn
        # Kinematic bicycle at low speed, blended linearly over [LOW_SPEED, LOW + BLEND].
        r_kin = vx * math.tan(delta) / wheelbase
        w = min(max((abs(vx) - LOW_SPEED) / BLEND_SPEED, 0.0), 1.0)
        r_new = r_kin + w * (r_dyn - r_kin)
        vy_new = lr * r_kin + w * (vy_dyn - lr * r_kin)
        # Back to the world frame at the mid-step heading.
        mid = yaw[i] + 0.5 * dt * r_new
        cm = math.cos(mid)
        sm = math.sin(mid)
        command[i, 0] = cm * vx - sm * vy_new
        command[i, 1] = sm * vx + cm * vy_new
        command[i, 2] = r_new
        steer[i] = delta
