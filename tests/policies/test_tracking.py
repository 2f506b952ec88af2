"""Tests for the planner's path tracking (:mod:`h2h_racing.policies.tracking`): the control
law on hand-worked states, the slide brake, and the grip it makes drivable (a setting of
``planner`` that pure pursuit could not hold)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.policies import make_driver, tracking
from h2h_racing.track.io import load_track
from h2h_racing.training.evaluate import evaluate


def rolling_core(speed: float) -> RaceCore:
    """A one-car core on ``oval`` (3 copies), reset and then set to drive at ``speed`` along
    the centre line's heading with no yaw rate and the wheels straight."""
    track = load_track("oval")
    cfg = EnvConfig(track="oval", num_cars=1, race_type="time_trial",
                    rules=RaceRules(laps=1, time_limit=60.0))
    core = RaceCore(cfg, track, num_envs=3)
    core.reset(seed=0, start=np.zeros(3))
    yaw = core.yaw[:, 0]
    core.velocity[:, 0] = speed * np.stack([np.cos(yaw), np.sin(yaw)], axis=1)
    core.speed[:, 0] = speed
    core.yaw_rate[:, 0] = 0.0
    core.steer[:, 0] = 0.0
    return core


def report(offset: float, slope: float, curvature: float) -> np.ndarray:
    """The kernel's path report (3 copies, 2 points): the same path at both points."""
    return np.broadcast_to(np.array([offset, slope, curvature]), (3, 2, 3)).copy()


def test_on_the_path_it_steers_the_paths_curvature() -> None:
    # No offset or heading error, yaw rate already v kappa: the damper adds nothing and the
    # steering is atan(L kappa), of which STEER_SMOOTH is commanded from straight wheels.
    core = rolling_core(2.0)
    kappa = 0.5
    core.yaw_rate[:, 0] = 2.0 * kappa
    path = report(0.0, 0.0, kappa)
    path[:, :, 0] = core.d[:, 0][:, None]
    steer, command = tracking.track_path(core, 0, np.zeros(3), np.zeros(3), path,
                                         np.full(3, 3.0))
    wheelbase = core.config.car.wheelbase
    np.testing.assert_allclose(steer, tracking.STEER_SMOOTH * math.atan(wheelbase * kappa))
    # sqrt(0.95 * 1 * 9.81 / 0.5) = 4.32 m/s is above the plan's 3 m/s: the plan's stands.
    np.testing.assert_allclose(command, 3.0)


def test_an_offset_to_the_left_steers_right() -> None:
    # 0.1 m left of a straight path: kappa = -k_e 0.1 = -0.2 1/m; the damper adds
    # -0.1 (0 - 2 * -0.2) = -0.04 rad.
    core = rolling_core(2.0)
    path = report(0.0, 0.0, 0.0)
    path[:, :, 0] = core.d[:, 0][:, None] - 0.1
    steer, _ = tracking.track_path(core, 0, np.zeros(3), np.zeros(3), path, np.full(3, 3.0))
    wheelbase = core.config.car.wheelbase
    kappa = -tracking.OFFSET_GAIN * 0.1
    expected = tracking.STEER_SMOOTH * (math.atan(wheelbase * kappa)
                                        - tracking.YAW_DAMPING * (0.0 - 2.0 * kappa))
    np.testing.assert_allclose(steer, expected)
    assert np.all(steer < 0.0)


def test_a_heading_error_to_the_left_steers_right() -> None:
    # Heading 0.2 rad left of the path and moving that way (no sideslip): kappa =
    # -k_theta sin(0.2).
    core = rolling_core(2.0)
    path = report(0.0, 0.0, 0.0)
    path[:, :, 0] = core.d[:, 0][:, None]
    steer, _ = tracking.track_path(core, 0, np.zeros(3), np.full(3, 0.2), path,
                                   np.full(3, 3.0))
    kappa = -tracking.HEADING_GAIN * math.sin(0.2)
    wheelbase = core.config.car.wheelbase
    expected = tracking.STEER_SMOOTH * (math.atan(wheelbase * kappa)
                                        - tracking.YAW_DAMPING * (0.0 - 2.0 * kappa))
    np.testing.assert_allclose(steer, expected)


def test_more_curvature_than_the_tyres_give_brakes() -> None:
    # A 2 1/m bend at 3 m/s asks 18 m/s^2; the command is sqrt(0.95 * 9.81 / 2) = 2.16 m/s.
    core = rolling_core(3.0)
    core.yaw_rate[:, 0] = 6.0  # turning as asked: not a slide
    path = report(0.0, 0.0, 2.0)
    path[:, :, 0] = core.d[:, 0][:, None]
    _, command = tracking.track_path(core, 0, np.zeros(3), np.zeros(3), path, np.full(3, 4.0))
    np.testing.assert_allclose(command, math.sqrt(0.95 * 9.81 / 2.0))


def test_a_slide_brakes() -> None:
    # Yaw rate 2 rad/s on a straight path at 3 m/s: 2 > 0 + SLIDE_RATE, a slide; the command
    # is the speed less SLIDE_BRAKE. At 0.5 rad/s it is not one.
    core = rolling_core(3.0)
    path = report(0.0, 0.0, 0.0)
    path[:, :, 0] = core.d[:, 0][:, None]
    core.yaw_rate[:, 0] = [2.0, 0.5, -2.0]
    _, command = tracking.track_path(core, 0, np.zeros(3), np.zeros(3), path, np.full(3, 4.0))
    np.testing.assert_allclose(command, [3.0 - tracking.SLIDE_BRAKE, 4.0,
                                         3.0 - tracking.SLIDE_BRAKE])


def test_preview_stays_inside_the_look_ahead() -> None:
    at = tracking.preview(np.array([0.0, 4.0, 40.0]), np.array([0.5, 0.5, 0.5]))
    np.testing.assert_allclose(at[:, 0], 0.0)
    np.testing.assert_allclose(at[:, 1], [0.0, tracking.CURVATURE_PREVIEW * 4.0, 0.45])


@pytest.mark.parametrize("name", ["technical", "kidney"])
def test_full_grip_laps_clean(name: str) -> None:
    # With pure pursuit the planner left these tracks 45 and 30 times in 10 two-lap races
    # at grip 0.85 (experiments/planner/README.md); the tracking holds it at mu g.
    result = evaluate(make_driver("planner:grip_factor=1.0"), name, episodes=10)
    assert result.off_tracks == 0, result
    assert result.lap_completion == 1.0, result
