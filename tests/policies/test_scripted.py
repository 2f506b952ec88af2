"""Tests for the scripted drivers and racing lines (:mod:`h2h_racing.policies`)."""

from __future__ import annotations

import numpy as np
import pytest

import h2h_racing
from h2h_racing.config.env import EnvConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.policies import (
    Blocker,
    PurePursuit,
    RacingLine,
    Random,
    compute_race_line,
    drive,
    make_driver,
    race_core,
    speed_profile,
    to_action,
)
from h2h_racing.track.io import list_tracks, load_track

TRACKS = list_tracks()
CAR_HALF_WIDTH = 0.1  # [m]


def lap_time(core, car: int, env: int = 0) -> float:
    """First completed lap time of ``car`` [s] (inf when it did not complete one)."""
    laps = core.lap_times[env][car]
    return laps[0] if laps else float("inf")


class TestHelpers:
    """to_action, the registry and the speed profile, with hand-computed values."""

    def test_to_action_inverts_env_mapping(self) -> None:
        core = race_core("oval", 1)
        cfg = core.config
        # 15 deg of 30 deg -> 0.5; 4 m/s on [0.5, 4] -> +1; 0.5 m/s -> -1; 2.25 m/s -> 0.
        act = to_action(core, np.radians([15.0, -60.0, 0.0]), np.array([4.0, 0.5, 2.25]))
        assert act.dtype == np.float32 and act.shape == (3, 2)
        np.testing.assert_allclose(act, [[0.5, 1.0], [-1.0, -1.0], [0.0, 0.0]], atol=1e-6)
        # Round trip through the env's linear map.
        speed = 0.5 * (cfg.max_speed + cfg.min_speed) + 0.5 * (cfg.max_speed - cfg.min_speed) * act[0, 1]
        assert speed == pytest.approx(4.0)

    def test_make_driver_known_and_unknown(self) -> None:
        assert isinstance(make_driver("racing_line"), RacingLine)
        assert isinstance(make_driver("blocker", lane="outer"), Blocker)
        assert isinstance(make_driver("random", rng=np.random.default_rng(0)), Random)
        with pytest.raises(ValueError,
                           match=r"known drivers are \['blocker', 'planner', 'pure_pursuit'"):
            make_driver("fast")

    def test_random_needs_generator(self) -> None:
        with pytest.raises(TypeError, match="default_rng"):
            Random(rng=0)  # type: ignore[arg-type]

    def test_speed_profile_hand_computed(self) -> None:
        # Square loop of 1 m segments, one corner of curvature 1 at point 1, a_lat = 1:
        # limit = [4, 1, 4, 4]; braking into point 1 from point 0: sqrt(1 + 2) = 1.732;
        # accelerating out: point 2 sqrt(1 + 2) = 1.732, point 3 sqrt(3 + 2) = 2.236;
        # point 0 is also capped by braking for point 1 (1.732 < sqrt(5 + 2)).
        v = speed_profile(np.array([0.0, 1.0, 0.0, 0.0]), np.ones(4), 4.0, 1.0, 1.0, 1.0)
        np.testing.assert_allclose(v, [3**0.5, 1.0, 3**0.5, 5**0.5])


class TestRaceLine:
    """The precomputed racing line stays on the track and is smoother than the centre."""

    @pytest.mark.parametrize("name", TRACKS)
    def test_line_within_margin_and_faster_profile(self, name: str) -> None:
        track = load_track(name)
        car = h2h_racing.CarParams()
        line = compute_race_line(track, car, 4.0)
        left, right = track.half_widths_at(line.s)
        assert np.all(line.d <= left - 0.12 + 1e-6) and np.all(line.d >= -right + 0.12 - 1e-6)
        assert np.all(line.speed > 0) and np.all(line.speed <= 4.0 + 1e-9)
        # Same profile on the centre line (margin = half-width minus a hair) is slower.
        centre = compute_race_line(track, car, 4.0, margin=float(np.min(np.minimum(left, right))) - 1e-3)
        assert line.lap_time < centre.lap_time
        assert compute_race_line(track, car, 4.0) is line  # cached per track


class TestSoloLaps:
    """Every driver completes a clean lap alone on every catalogue track."""

    @pytest.mark.parametrize("name", TRACKS)
    def test_drivers_finish_clean_lap(self, name: str) -> None:
        times = {}
        for driver in (PurePursuit(), RacingLine(), Blocker()):
            core = race_core(name, 1)
            drive(core, [driver])
            assert core.finished[0, 0], f"{driver.name} did not finish on {name}"
            assert core.off_tracks[0, 0] == 0, f"{driver.name} went off track on {name}"
            assert core.penalties[0, 0] == 0, f"{driver.name} was penalised on {name}"
            times[driver.name] = lap_time(core, 0)
        assert times["racing_line"] < 0.85 * times["pure_pursuit"], times

    def test_batched_copies_agree(self) -> None:
        # Two env copies from the same grid drive the same lap: act() is batched, not per copy.
        # The copies sit at different offsets of one pymunk Space, so their coordinates round
        # differently in the last bits: equal to 1e-9 s, not bit for bit.
        core = race_core("kidney", 1, num_envs=2)
        drive(core, [RacingLine()])
        assert core.finished.all()
        assert core.lap_times[0][0] == pytest.approx(core.lap_times[1][0], abs=1e-9)


class TestRaces:
    """Two-car races in race rules: both finish; the racing line wins."""

    @pytest.mark.parametrize("name", TRACKS)
    def test_racing_line_beats_pure_pursuit(self, name: str) -> None:
        # Copy 0: racing_line starts in front; copy 1: it starts behind and must pass.
        core = race_core(name, 2, num_envs=2)
        core.reset(seed=0, slots=np.array([[0, 1], [1, 0]]))
        drive(core, [RacingLine(), PurePursuit()])
        assert core.finished.all(), f"not all finished on {name}: {core.finished}"
        assert core.rank[0, 0] == 1
        assert lap_time(core, 0, 0) < 0.85 * lap_time(core, 1, 0)
        # Starting behind, it never causes a crash or goes off; on tracks wide enough to go
        # side by side (>= 1 m) it also gets past and wins. On the 0.76 m wide ones it may
        # have to follow.
        assert core.off_tracks[:, 0].sum() == 0 and core.penalties[:, 0].sum() == 0
        if core.track.min_width >= 1.0:
            assert core.rank[1, 0] == 1

    @pytest.mark.parametrize("name", ["oval", "technical"])
    def test_blocker_race_finishes(self, name: str) -> None:
        core = race_core(name, 2, num_envs=2)
        core.reset(seed=0, slots=np.array([[0, 1], [1, 0]]))
        drive(core, [Blocker(), RacingLine()])
        assert core.finished.all()

    def test_blocker_covers_attacker(self) -> None:
        # Blocker in front on the inner lane; an attacker 1 m behind on the outer lane
        # pulls the blocker's target to the attacker's offset; without it, the lane.
        core = race_core("oval", 2)
        blocker = Blocker()
        lane = blocker.lateral_target(core, 0)
        # Grid: car 0 at the start line (outer lane), car 1 0.75 m behind (inner lane).
        assert core.distance[0, 0] - core.distance[0, 1] == pytest.approx(0.75)
        np.testing.assert_allclose(blocker.lateral_target(core, 0), core.d[:, 1], atol=1e-9)
        core.distance[0, 1] -= 1.0  # now 1.75 m behind: out of range, back to the lane
        assert blocker.lateral_target(core, 0)[0] == pytest.approx(0.5 * 0.535, abs=0.01)
        assert lane.shape == (1,)


class TestEnvIntegration:
    """The drivers run through the PettingZoo ParallelEnv."""

    def test_parallel_env_race(self) -> None:
        env = h2h_racing.parallel_env(track="oval", num_cars=2, race_type="head_to_head",
                                      rules=h2h_racing.RaceRules(laps=1), grid="fixed")
        env.reset(seed=0)
        drivers = [RacingLine(), PurePursuit()]
        for d in drivers:
            d.reset(env.core)
        steps = 0
        while env.agents:
            acts = {a: drivers[i].act(env.core, i)[0] for i, a in enumerate(env.possible_agents)
                    if a in env.agents}
            for a, act in acts.items():
                assert env.action_space(a).contains(act), act
            env.step(acts)
            steps += 1
        assert env.core.finished.all()
        assert env.core.rank[0].tolist() == [1, 2]

    def test_random_is_reproducible(self) -> None:
        outs = []
        for _ in range(2):
            core = race_core("oval", 2)
            drive(core, [Random(np.random.default_rng(3)), Random(np.random.default_rng(4))],
                  max_steps=50)
            outs.append(core.position.copy())
        np.testing.assert_array_equal(outs[0], outs[1])


class TestActionMapping:
    """One map from continuous actions to car commands (EnvConfig.commands), inverted by to_action."""

    def test_commands_by_hand_with_a_custom_steering_range(self) -> None:
        import math

        from h2h_racing.config.env import EnvConfig

        cfg = EnvConfig(min_steer_deg=-10.0, max_steer_deg=30.0, min_speed=1.0, max_speed=3.0)
        # Steering: mid 10 deg, half 20 deg; speed: mid 2 m/s, half 1 m/s. a = (0.5, -1) ->
        # 10 + 0.5 * 20 = 20 deg and 2 - 1 = 1 m/s; (2.0, 5.0) is clipped to (1, 1) -> 30 deg, 3 m/s.
        steer, speed = cfg.commands(np.array([[0.5, -1.0], [2.0, 5.0]]))
        assert np.allclose(steer, [math.radians(20.0), math.radians(30.0)])
        assert np.allclose(speed, [1.0, 3.0])

    def test_to_action_inverts_commands(self) -> None:
        core = race_core("oval", 1, min_steer_deg=-20.0, max_steer_deg=25.0)
        actions = np.array([[-0.6, 0.3]], dtype=np.float32)
        steer, speed = core.config.commands(actions)
        assert np.allclose(to_action(core, steer, speed), actions, atol=1e-6)


class TestBotAvoidance:
    """RacingLine treats bot cars like cars when it keeps clear (by hand on the circle)."""

    @staticmethod
    def car_behind_a_bot() -> RaceCore:
        """One car and one bot on the circle track (R = 3 m, half-width 0.5 m): the bot starts
        at s = 2.0 on the inner lane (d = +0.25), at rest; the car is on that lane 0.8 m
        behind it."""
        import sys

        track = sys.modules["conftest"].circle_track()
        core = RaceCore(EnvConfig(track=track.name, num_cars=1, num_bots=1,
                                  bot_lane_change=False), track)
        core.reset(seed=0)
        core.s[0, 0], core.d[0, 0], core.distance[0, 0] = 1.2, 0.25, 1.2
        return core

    def test_bot_ahead_on_the_line_is_passed_and_followed(self) -> None:
        core = self.car_behind_a_bot()
        offset, speed = RacingLine()._avoid(core, 0, np.array([1.6]), np.array([0.25]),
                                            np.array([3.0]))
        # The bot overlaps the line 0.8 m ahead (> 0.3235 + 0.15: not alongside). Room: 0.5 -
        # 0.25 = 0.25 m on its left, 0.25 + 0.5 = 0.75 m on its right -> pass on the right, a
        # car width + 0.15 = 0.3461 m from it: 0.25 - 0.3461 = -0.0961 m (inside the 0.12 m
        # margins). Speed: the bot's 0 m/s plus 0.5 * (0.8 - 0.3235 - 0.1) / 1.2 = 0.1569 m/s.
        assert offset[0] == pytest.approx(0.25 - (0.1961 + 0.15))
        assert speed[0] == pytest.approx(0.5 * (0.8 - 0.3235 - 0.1) / 1.2)

    def test_a_bot_changing_lanes_is_passed_clear_of_its_new_lane(self) -> None:
        core = self.car_behind_a_bot()
        # The same bot, just starting a change from the inner lane (+0.25) to the outer one:
        # its new lane is -1 x half the 0.5 m half-width = -0.25, so it will sweep
        # [-0.25, +0.25]. The pass on the right (to -0.0961 m, above) would cross its path.
        core.bot_lane[0, 0] = -1.0
        offset, speed = RacingLine()._avoid(core, 0, np.array([1.6]), np.array([0.25]),
                                            np.array([3.0]))
        # Room beside that span: 0.5 - 0.25 = 0.25 m on each side; a tie goes left, where a
        # car width + 0.15 m beyond +0.25 is outside the track: the target stops at the
        # margin, 0.5 - 0.12 = 0.38 m. The line at +0.25 lies in the span: follow, as above.
        assert offset[0] == pytest.approx(0.38)
        assert speed[0] == pytest.approx(0.5 * (0.8 - 0.3235 - 0.1) / 1.2)


def test_random_driver_needs_a_seed_or_a_generator() -> None:
    from h2h_racing.policies import make_driver

    with pytest.raises(ValueError, match="random driver needs a generator"):
        make_driver("random")
    core = race_core("oval", num_cars=1, num_envs=3)
    first = make_driver("random", seed=5)
    second = make_driver("random", rng=np.random.default_rng(5))
    first.reset(core)
    second.reset(core)
    # seed=5 is shorthand for rng=np.random.default_rng(5): the same draws.
    assert np.array_equal(first.act(core, 0), second.act(core, 0))
