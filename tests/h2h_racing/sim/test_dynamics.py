"""Tests for :mod:`h2h_racing.sim.dynamics`: the single-track model against hand-derived values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from h2h_racing.config.env import CarParams
from h2h_racing.sim.dynamics import GRAVITY, SingleTrackModel

DT = 1.0 / 15.0
CAR = CarParams()
WHEELBASE = CAR.wheelbase  # 0.0823 + 0.0817 = 0.164 m


def simulate(model: SingleTrackModel, v_cmd: float, steer_cmd: float, steps: int,
             v0: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate one car with the model alone (yaw += r dt), returning the forward speed (along
    the mid-step heading), yaw rate and world velocity histories."""
    yaw = np.zeros(1)
    vel = np.array([[v0, 0.0]])
    r = np.zeros(1)
    steer = np.zeros(1)
    racing = np.ones(1, bool)
    speeds, rates, vels = [], [], []
    for _ in range(steps):
        vel, r, steer = model.step(yaw, vel, r, steer, np.array([steer_cmd]), np.array([v_cmd]),
                                   racing, DT)
        # The returned velocity is held during the step at the mid-step heading.
        mid = yaw[0] + 0.5 * r[0] * DT
        c, s = math.cos(mid), math.sin(mid)
        yaw = yaw + r * DT
        speeds.append(c * vel[0, 0] + s * vel[0, 1])
        rates.append(r[0])
        vels.append(vel[0].copy())
    return np.array(speeds), np.array(rates), np.array(vels)


class TestCornering:
    """Steady-state cornering and the friction limit."""

    @pytest.mark.parametrize(("v", "steer_deg"), [(1.0, 3.0), (1.5, 2.0), (2.0, 1.0)])
    def test_steady_state_yaw_rate(self, v: float, steer_deg: float) -> None:
        model = SingleTrackModel(CAR)
        delta = math.radians(steer_deg)
        _, rates, _ = simulate(model, v, delta, 90, v0=v)
        expected = model.steady_state_yaw_rate(v, delta)
        # Kinematic estimate v tan(delta) / L: at 1 m/s and 3 deg, 0.0524 / 0.164 = 0.319 rad/s;
        # lateral acceleration v r ~ 0.32 m/s^2, far below mu g = 9.81 (linear range).
        assert expected == pytest.approx(v * math.tan(delta) / WHEELBASE, rel=0.05)
        assert rates[-1] == pytest.approx(expected, rel=0.03)

    def test_friction_limit_runs_wide(self) -> None:
        model = SingleTrackModel(CAR)
        v, delta = 4.0, CAR.max_steer
        speeds, rates, _ = simulate(model, v, delta, 60, v0=v)
        radius = speeds[-1] / abs(rates[-1])
        kinematic = WHEELBASE / math.tan(delta)  # 0.164 / tan(30 deg) = 0.284 m
        assert radius > 2.0 * kinematic
        # The lateral acceleration v r cannot exceed the grip mu g = 9.81 m/s^2 (+ 5 %), so the
        # radius is at least v^2 / (mu g) = 16 / 9.81 = 1.63 m.
        assert abs(speeds[-1] * rates[-1]) <= 1.05 * CAR.friction * GRAVITY
        assert radius >= 0.95 * v**2 / (CAR.friction * GRAVITY)


    @pytest.mark.xfail(strict=True, reason=(
        "known issue (experiments/physics/README.md): the velocity held at the mid-step "
        "heading is read back at the end-of-step heading, so half a step's turn is counted "
        "twice and the car corners at about mu g / 1.5 (0.68 g here); when the dynamics are "
        "fixed this passes, and strict xfail fails until the marker is removed"))
    @pytest.mark.parametrize("v", [2.5, 3.5])
    def test_full_lock_reaches_the_friction_limit(self, v: float) -> None:
        # At 2.5 and 3.5 m/s a 20 degree lock asks for far more than the tyres give
        # (kinematic curvature tan(20 deg) / 0.164 = 2.22 /m: 13.9 and 27.2 m/s^2), so the
        # car settles at the friction limit: both axles saturated at mu times their load,
        # m v r = mu m g, a lateral acceleration v r of mu g = 9.81 m/s^2 (within 5 %).
        model = SingleTrackModel(CAR)
        speeds, rates, _ = simulate(model, v, math.radians(20.0), 45, v0=v)
        assert abs(speeds[-1] * rates[-1]) >= 0.95 * CAR.friction * GRAVITY


class TestSpeedController:
    """The speed controller: a = gain (v_cmd - v), limited to [-max_brake, max_accel]."""

    def test_accel_limited_run_up(self) -> None:
        model = SingleTrackModel(CAR)
        speeds, _, _ = simulate(model, 3.0, 0.0, 45)
        # a = min(6 (3 - v), 3): accel-limited while v <= 2.5, i.e. v_k = 3 k / 15 = 0.2 k for
        # k <= 12 (v_12 = 2.4), then 2.4 + 3/15 = 2.6, then 2.6 + 6 * 0.4 / 15 = 2.76.
        np.testing.assert_allclose(speeds[:12], 0.2 * np.arange(1, 13), atol=1e-12)
        assert speeds[12] == pytest.approx(2.6, abs=1e-12)
        assert speeds[13] == pytest.approx(2.76, abs=1e-12)
        # Time ~ v / a = 1 s plus the proportional tail: within 1 % of 3 m/s after 1.5 s.
        assert speeds[22] == pytest.approx(3.0, rel=0.01)
        assert speeds[-1] == pytest.approx(3.0, abs=1e-3)

    def test_brake_limit(self) -> None:
        model = SingleTrackModel(CAR)
        speeds, _, _ = simulate(model, 0.5, 0.0, 10, v0=4.0)
        # a = max(6 (0.5 - v), -5) = -5 while v > 1.33: v_k = 4 - k / 3 for k <= 7 (1.667).
        np.testing.assert_allclose(speeds[:7], 4.0 - np.arange(1, 8) / 3.0, atol=1e-12)

    def test_steering_rate_limit(self) -> None:
        model = SingleTrackModel(CAR)
        yaw, vel, r, steer = np.zeros(1), np.zeros((1, 2)), np.zeros(1), np.zeros(1)
        # 360 deg/s * 1/15 s = 24 deg per step: 0 -> 24 -> 30 (command 30 deg).
        for expected in (24.0, 30.0, 30.0):
            vel, r, steer = model.step(yaw, vel, r, steer, np.array([CAR.max_steer]),
                                       np.zeros(1), np.ones(1, bool), DT)
            assert math.degrees(steer[0]) == pytest.approx(expected, abs=1e-9)


class TestLowSpeed:
    """Below 0.2 m/s the model is the kinematic bicycle; at standstill nothing spins."""

    def test_no_spin_at_standstill_full_lock(self) -> None:
        model = SingleTrackModel(CAR)
        speeds, rates, vels = simulate(model, 0.0, CAR.max_steer, 60)
        assert np.all(rates == 0.0) and np.all(vels == 0.0) and np.all(speeds == 0.0)

    def test_kinematic_at_low_speed(self) -> None:
        model = SingleTrackModel(CAR)
        v = 0.1
        speeds, rates, _ = simulate(model, v, CAR.max_steer, 30, v0=v)
        # r = v tan(delta) / L = 0.1 * tan(30 deg) / 0.164 = 0.352 rad/s (to the speed
        # controller's small tracking error: the velocity is re-read in the rotated body frame).
        assert speeds[-1] == pytest.approx(v, rel=0.01)
        assert rates[-1] == pytest.approx(v * math.tan(CAR.max_steer) / WHEELBASE, rel=0.01)
        # Pure kinematics: r / v_x = tan(delta) / L with no slip.
        assert rates[-1] / speeds[-1] == pytest.approx(math.tan(CAR.max_steer) / WHEELBASE, rel=0.01)

    def test_not_racing_holds_still(self) -> None:
        model = SingleTrackModel(CAR)
        vel, r, steer = model.step(np.zeros(2), np.ones((2, 2)), np.ones(2), np.ones(2) * 0.1,
                                   np.ones(2) * 0.3, np.ones(2) * 4.0, np.array([False, True]), DT)
        assert vel[0].tolist() == [0.0, 0.0] and r[0] == 0.0 and steer[0] == 0.0
        assert np.all(np.isfinite(vel))
