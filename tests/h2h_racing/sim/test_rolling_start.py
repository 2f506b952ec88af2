"""Rolling starts: ``RaceCore.reset(rolling=...)`` and ``evaluate --rolling``."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore

circle_track = sys.modules["conftest"].circle_track

RADIUS = 3.0


def two_car_core(gap: float, num_envs: int = 1) -> RaceCore:
    """Two cars on the test circle (radius 3 m, CCW from (3, 0)), ``gap`` metres apart."""
    config = EnvConfig(track="oval", num_cars=2, race_type="head_to_head", grid_spacing=gap,
                       rules=RaceRules(laps=1))
    return RaceCore(config, circle_track(RADIUS), num_envs=num_envs)


class TestRollingReset:
    """Cars start moving along the track at the asked speed, on the asked grid."""

    def test_speed_heading_and_gap_by_hand(self) -> None:
        core = two_car_core(gap=1.5)
        # Car 0 in slot 1 (behind), car 1 in slot 0, slot 0 at the start line s = 0.
        core.reset(seed=0, slots=np.array([1, 0]), start=np.array([0.0]), rolling=2.0)
        # On a CCW circle the heading at arc s is s / R + pi/2: at s = 0 it points along +y;
        # 1.5 m behind (s = -1.5) it is -0.5 + pi/2 rad, so v = 2 (sin 0.5, cos 0.5).
        front = np.array([0.0, 2.0])
        behind = 2.0 * np.array([math.sin(1.5 / RADIUS), math.cos(1.5 / RADIUS)])
        # The test circle is a 400-gon: its heading is within half a side's turn (pi / 400
        # rad) of the circle's, 2 m/s * pi / 400 < 0.02 m/s.
        assert np.allclose(core.velocity[0, 1], front, atol=0.02)
        assert np.allclose(core.velocity[0, 0], behind, atol=0.02)
        # Forward (body-frame) speed: the velocity along each car's yaw.
        heading = np.stack([np.cos(core.yaw), np.sin(core.yaw)], axis=-1)
        assert np.allclose((core.velocity * heading).sum(axis=-1), 2.0)
        assert np.allclose(core.speed, 2.0) and np.allclose(core.speed_command, 2.0)
        assert np.allclose(core.steer, 0.0) and np.allclose(core.yaw_rate, 0.0)
        # The gap is the asked 1.5 m of track: slot 0 at distance 0, slot 1 at -1.5.
        assert core.distance[0].tolist() == [-1.5, 0.0]

    def test_cars_keep_rolling_on_the_first_step(self) -> None:
        core = two_car_core(gap=1.5)
        core.reset(seed=0, slots=np.array([1, 0]), start=np.array([0.0]), rolling=2.0)
        before = core.distance.copy()
        core.step(core.steer_command.copy(), core.speed_command.copy())
        # The speed controller was already asking for 2 m/s: no braking. 2 m/s * dt driven on
        # a lane d off the centre line (left positive, the inside of this CCW circle) is
        # 2 dt R / (R - d) metres of centre line.
        assert np.allclose(core.speed, 2.0, atol=0.05)
        expected = 2.0 * core.dt * RADIUS / (RADIUS - core.d)
        assert np.allclose(core.distance - before, expected, rtol=0.02)

    def test_standing_start_is_unchanged(self) -> None:
        core = two_car_core(gap=1.5, num_envs=2)
        core.reset(seed=0, rolling=3.0)
        core.reset(seed=0)
        for field in (core.velocity, core.speed, core.speed_command, core.yaw_rate):
            assert np.all(field == 0.0)

    def test_reset_envs_rolls_only_the_reset_copies(self) -> None:
        core = two_car_core(gap=1.0, num_envs=2)
        core.reset(seed=0)
        core.reset_envs(np.array([False, True]), rolling=1.5)
        assert np.all(core.speed[0] == 0.0) and np.allclose(core.speed[1], 1.5)

    @pytest.mark.parametrize("bad", [-0.5, 4.01, float("nan"), float("inf"), True, "2"])
    def test_bad_speed_is_refused(self, bad: object) -> None:
        core = two_car_core(gap=1.0)
        core.reset(seed=0, start=np.array([2.0]))
        position = core.position.copy()
        with pytest.raises(ValueError, match=r"rolling must be a start speed in \[0, 4\] m/s"):
            core.reset(seed=0, rolling=bad)
        # Refused before anything was rebuilt: the cars are where they were.
        assert np.array_equal(core.position, position)

    def test_top_speed_is_allowed(self) -> None:
        core = two_car_core(gap=1.0)
        core.reset(seed=0, rolling=core.config.car.max_speed)
        assert np.allclose(core.speed, 4.0)


class TestRollingHeadToHead:
    """``head_to_head(rolling=...)`` and ``evaluate --rolling``."""

    def test_both_cars_start_moving_gap_apart(self) -> None:
        from h2h_racing.policies import make_driver
        from h2h_racing.training.evaluate import head_to_head

        class Spy:
            """The racing line, noting the cars' speeds and distances at the start."""

            name = "spy"

            def __init__(self) -> None:
                self.inner = make_driver("racing_line")
                self.speed = self.distance = np.zeros(0)

            def reset(self, core) -> None:
                self.speed, self.distance = core.speed.copy(), core.distance.copy()
                self.inner.reset(core)

            def act(self, core, car):
                return self.inner.act(core, car)

        spy = Spy()
        result = head_to_head(spy, "pure_pursuit", "oval", races=2, laps=1, start="behind",
                              gap=2.0, rolling=2.5)
        assert np.allclose(spy.speed, 2.5)
        assert np.allclose(spy.distance[:, 0] - spy.distance[:, 1], -2.0)
        assert result.rolling == 2.5 and "rolling start at 2.5 m/s" in result.summary()

    def test_cli_help_shows_the_default(self, capsys) -> None:
        from h2h_racing.cli.command import main

        with pytest.raises(SystemExit):
            main(["evaluate", "--help"])
        help_text = " ".join(capsys.readouterr().out.split())
        assert "--rolling M/S" in help_text
        assert "0 is a standing start (default: 0.0)" in help_text

    def test_cli_rolling_race(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "1", "--laps", "1", "--start", "behind",
                     "--gap", "2", "--rolling", "2"]) == 0
        out = capsys.readouterr().out
        assert "the policy starts behind, 2 m grid gap, rolling start at 2 m/s" in out
        row = next(line for line in out.splitlines() if line.startswith("oval"))
        assert row.split()[2:5] == ["1", "/", "1"]

    def test_cli_refuses_a_bad_speed(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "2", "--rolling", "9"]) == 2
        assert "rolling must be a start speed in [0, 4] m/s" in capsys.readouterr().err
