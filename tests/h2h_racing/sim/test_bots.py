"""Bot cars (``head_to_bot``): layout, open-loop motion, lane changes, judging, sensors, env.

Most cases run on the 3 m radius test circle, 1 m wide (L = 400 * 6 sin(pi/400) = 18.8494 m);
its lanes lie 0.25 m either side of the centre line, the left (inner, +1) lane on radius 2.75 m.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import h2h_racing
from h2h_racing.sim import bots, race, layouts as spawn
from h2h_racing.config.env import CarParams, EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.sensors.camera import BOT_SHADE, CAR_SHADES, FACE_FACTORS, CameraSensor
from h2h_racing.sensors.lidar import LidarSensor
from h2h_racing.sensors.state import state_observation

from conftest import circle_track

DT = 1.0 / 15.0
R = 3.0
TRACK = circle_track(R)
L = TRACK.length  # 18.849362 m
CAR = CarParams()
# A car that never moves is not "immobilised" in these tests (it is parked on purpose).
STILL = {"immobilised_steps": 100_000, "reversed_steps": 100_000}


def make_core(num_cars: int = 1, num_envs: int = 1, rules: RaceRules | None = None,
              seed: int = 0, **config: Any) -> RaceCore:
    cfg = EnvConfig(track=TRACK.name, num_cars=num_cars, grid="fixed",
                    rules=rules or RaceRules(laps=1, time_limit=100.0, **STILL), **config)
    core = RaceCore(cfg, TRACK, num_envs=num_envs)
    core.reset(seed=seed)
    return core


def place_car(core: RaceCore, car: int, s: float, d: float) -> None:
    """Teleport a car (env copy 0) to arc position s, offset d, along the track, at rest."""
    core.s[0, car] = s
    core.d[0, car] = d
    core.distance[0, car] = s
    core.position[0, car] = TRACK.point_at(s, d)
    core.yaw[0, car] = TRACK.heading_at(s)
    core._sync_physics()


def bench_car(core: RaceCore, car: int = 0) -> None:
    """Take a car (env copy 0) out of the bots' way: far off the track, frozen for good, so
    its clock runs but nothing touches it (a frozen car is not judged off track)."""
    core.position[0, car] = (0.0, 40.0)
    core.frozen_until[0, car] = 1e9
    core._racing[0, car] = False
    core._sync_physics()


def still(core: RaceCore) -> Any:
    """One step with every car commanded to stand still."""
    zeros = np.zeros((core.num_envs, core.num_cars))
    return core.step(zeros, zeros)


class TestConfig:
    """The bot fields: defaults by race type, overrides, validation."""

    def test_default_counts(self) -> None:
        assert EnvConfig(race_type="head_to_bot").bot_count == 3
        assert EnvConfig(race_type="head_to_head").bot_count == 0
        assert EnvConfig(race_type="object_avoidance").bot_count == 0

    def test_explicit_count_overrides_the_race_type(self) -> None:
        assert EnvConfig(race_type="head_to_bot", num_bots=0).bot_count == 0
        assert EnvConfig(race_type="head_to_head", num_bots=2).bot_count == 2

    def test_head_to_bot_rules_are_the_league_format(self) -> None:
        rules = RaceRules.preset("head_to_bot")
        assert (rules.laps, rules.ranking, rules.crash_penalty, rules.time_limit) == (
            3, "total_time", 5.0, 180.0)
        assert RaceRules.preset("head_to_bot", "training").mode == "training"

    @pytest.mark.parametrize(("kwargs", "field"), [
        ({"num_bots": -1}, "num_bots"),
        ({"num_bots": 13}, "num_bots"),
        ({"num_bots": 2.0}, "num_bots"),
        ({"num_bots": True}, "num_bots"),
        ({"bot_speed": 0.0}, "bot_speed"),
        ({"bot_speed": math.inf}, "bot_speed"),
        ({"bot_lane_change_min": 0.0}, "bot_lane_change_min"),
        ({"bot_lane_change_min": 5.0, "bot_lane_change_max": 3.0}, "bot_lane_change_max"),
        ({"bot_lane_change_distance": -1.0}, "bot_lane_change_distance"),
        ({"bot_penalty": -1.0}, "bot_penalty"),
        ({"bot_lane_change": 1}, "bot_lane_change"),
        ({"randomize_bots": "yes"}, "randomize_bots"),
    ])
    def test_bad_values_name_the_field(self, kwargs: dict[str, Any], field: str) -> None:
        with pytest.raises(ValueError, match=f"EnvConfig.*{field}"):
            EnvConfig(**kwargs)

    def test_round_trip_through_dict(self) -> None:
        cfg = EnvConfig(race_type="head_to_bot", num_bots=4, bot_speed=1.0, randomize_bots=True)
        assert EnvConfig.from_dict(cfg.to_dict()) == cfg

    def test_too_many_bots_for_the_lap(self) -> None:
        # 8 bots 2 m apart need 7 * 2 + 2 + 1 = 17 m plus the grid (0.32 m) of an 18.85 m lap:
        # fine; 9 need 19 m: refused when the core is built, naming the fix.
        make_core(num_bots=8)
        with pytest.raises(ValueError, match="9 bots need 19.0 m.*num_bots"):
            make_core(num_bots=9)


class TestLayout:
    """Start positions and lanes (DeepRacer: linspace(2, L - 1, n), alternating lanes)."""

    def test_even_layout_by_hand(self) -> None:
        core = make_core(num_bots=3)
        # One car: the grid reaches 0.3235 m (a car length) behind the line, so the span is
        # [2.0, L - 1.0 - 0.3235] = [2.0, 17.525862]; linspace over 3 bots:
        # 2.0, 9.762931, 17.525862.
        last = L - 1.0 - CAR.length
        np.testing.assert_allclose(core.bot_s[0], [2.0, (2.0 + last) / 2, last], atol=1e-12)
        # Inner lane first: the circle runs counter-clockwise, so the inner lane is +1 (left).
        assert core.bot_lane[0].tolist() == [1.0, -1.0, 1.0]
        np.testing.assert_allclose(core.bot_d[0], [0.25, -0.25, 0.25], atol=1e-12)

    def test_clockwise_track_starts_on_its_inner_lane(self) -> None:
        cw = circle_track(R, ccw=False)
        cfg = EnvConfig(track=cw.name, num_cars=1, num_bots=2)
        core = RaceCore(cfg, cw)
        core.reset(seed=0)
        # Clockwise, the inside of the loop is on the right of travel: lane -1.
        assert core.bot_lane[0].tolist() == [-1.0, 1.0]

    def test_span_leaves_room_for_the_grid(self) -> None:
        # Three cars: the grid reaches 2 * 0.75 + 0.3235 = 1.8235 m behind the line, so the
        # last bot starts at L - 1.0 - 1.8235 = 16.025862 m (1.0 m before the last slot's car).
        core = make_core(num_cars=3, num_bots=2)
        np.testing.assert_allclose(core.bot_s[0], [2.0, L - 2.8235], atol=1e-12)

    def test_layout_follows_the_start_point(self) -> None:
        core = make_core(num_bots=2)
        core.reset(start=np.array([5.0]))
        # Offsets 2.0 and L - 1.3235 from s = 5: 7.0 and (5 + 17.525862) mod L = 3.676500.
        np.testing.assert_allclose(core.bot_s[0], [7.0, 5.0 + L - 1.3235 - L], atol=1e-12)

    def test_randomised_layouts_keep_the_gap(self) -> None:
        s, lane = spawn.bot_layout(L, np.random.default_rng(3), 500, 4, True, 1,
                                   np.zeros(500), CAR.length)
        assert s.min() >= 2.0 and s.max() <= L - 1.0 - CAR.length
        assert np.diff(s, axis=1).min() >= spawn.BOT_MIN_GAP - 1e-12
        assert set(np.unique(lane).tolist()) == {-1.0, 1.0}
        # The draws spread over the span: the first bot is not always at 2.0.
        assert s[:, 0].std() > 0.3

    def test_randomised_layouts_are_seeded(self) -> None:
        a = make_core(num_bots=3, randomize_bots=True, seed=7)
        b = make_core(num_bots=3, randomize_bots=True, seed=7)
        c = make_core(num_bots=3, randomize_bots=True, seed=8)
        assert np.array_equal(a.bot_s, b.bot_s) and np.array_equal(a.bot_lane, b.bot_lane)
        assert not np.array_equal(a.bot_s, c.bot_s)
        # A later unseeded reset draws a new layout, the same one for both cores.
        a.reset()
        b.reset()
        assert np.array_equal(a.bot_s, b.bot_s)
        assert not np.array_equal(a.bot_s, c.bot_s)


class TestMotion:
    """Positions along the lane, lane changes and their timing, pauses."""

    def test_position_after_t_seconds(self) -> None:
        core = make_core(num_bots=2, bot_speed=0.5, bot_lane_change=False)
        bench_car(core)
        for _ in range(30):  # 2.0 s
            still(core)
        # s = s0 + v t: 2.0 + 0.5 * 2.0 = 3.0; 17.525862 + 1.0 = 18.525862 (< L, no wrap).
        np.testing.assert_allclose(core.bot_clock, [2.0], atol=1e-12)
        np.testing.assert_allclose(core.bot_s[0], [3.0, L - 1.3235 + 1.0], atol=1e-9)
        # Bot 0 on the inner lane, radius 2.75 m, at the angle 3.0 / 3 = 1 rad (the polygon's
        # arc length differs from the circle's by < 1e-4 m):
        # (2.75 cos 1, 2.75 sin 1) = (1.48583, 2.31405) (the 400-gon's chords and blended
        # normals move the lane point by < 1 mm). Its heading is that of the chord holding
        # s = 3.0: vertices lie every 6 sin(pi/400) = 0.0471234 m, 3.0 / 0.0471234 = 63.66, so
        # chord 63, at the angle 63.5 * 2 pi / 400 + pi/2 = 2.568252 rad, to within the
        # resampling of the track's 2 cm tables the bots are computed from (< 1e-3 rad; a
        # chord turns by 2 pi / 400 = 0.0157 rad).
        np.testing.assert_allclose(core.bot_position[0, 0], [1.48583, 2.31405], atol=1e-3)
        assert core.bot_yaw[0, 0] == pytest.approx(63.5 * math.pi / 200 + math.pi / 2, abs=1e-3)
        # The bodies pymunk moved are where the core says (body rows: car, then the 2 bots).
        np.testing.assert_allclose(core.world.state[1:3, 0:2], core.bot_position[0],
                                   atol=1e-9)
        np.testing.assert_allclose(core.bot_speed[0], [0.5, 0.5], atol=1e-12)

    def test_lane_change_by_hand(self) -> None:
        # min = max = 1 s: the first change starts at tau = 1.0, lasts T = 1.0 m / 0.5 m/s
        # = 2 s (until 3.0); the next starts at 3.0 + 1.0 = 4.0.
        core = make_core(num_bots=1, bot_speed=0.5, bot_lane_change_min=1.0,
                         bot_lane_change_max=1.0)
        bench_car(core)
        assert core.bot_next_change[0].tolist() == [1.0]
        d, yaw_offset, clock = [], [], []
        for _ in range(70):
            still(core)
            clock.append(float(core.bot_clock[0]))
            d.append(float(core.bot_d[0, 0]))
            yaw_offset.append(float(core.bot_yaw[0, 0] - TRACK.heading_at(core.bot_s[0, 0])))
        at = {round(t, 6): k for k, t in enumerate(clock)}
        # tau = 1.0 (step 15): still on the inner lane, d = +0.25.
        assert d[at[1.0]] == pytest.approx(0.25, abs=1e-9)
        # tau = 2.0, halfway (u = 0.5): lane = 1 + (-2)(1 - cos(pi/2))/2 = 0 -> d = 0; the
        # lateral rate is (-2)(pi / (2 * 2)) sin(pi/2) = -pi/2 lanes/s, times 0.25 m per lane
        # = -0.392699 m/s -> heading offset atan2(-0.392699, 0.5) = -0.665774 rad.
        assert d[at[2.0]] == pytest.approx(0.0, abs=1e-9)
        assert yaw_offset[at[2.0]] == pytest.approx(math.atan2(-math.pi / 8, 0.5), abs=1e-3)
        # tau = 3.0: on the outer lane, d = -0.25, heading back along the track.
        assert d[at[3.0]] == pytest.approx(-0.25, abs=1e-9)
        assert yaw_offset[at[3.0]] == pytest.approx(0.0, abs=1e-3)
        # tau = 4.4 (second change, u = 0.2): lane = -1 + 2 (1 - cos(0.2 pi)) / 2 = -0.809017
        # -> d = -0.202254.
        assert d[at[4.4]] == pytest.approx(-0.25 * (math.cos(0.2 * math.pi)), abs=1e-9)
        # The lateral offset moves monotonically between the lanes during the first change.
        first = np.array(d[at[1.0]:at[3.0] + 1])
        assert np.all(np.diff(first) < 0.0)

    def test_lane_change_gaps_are_drawn_in_range(self) -> None:
        core = make_core(num_envs=4, num_bots=2, bot_speed=0.75, bot_lane_change_min=1.0,
                         bot_lane_change_max=3.0)
        for e in range(4):
            core.position[e, 0] = (0.0, 40.0)
        core.frozen_until[:] = 1e9
        core._racing[:] = False
        core._sync_physics()
        duration = 1.0 / 0.75
        first = core.bot_next_change.copy()
        assert np.all((first >= 1.0) & (first <= 3.0))
        starts: list[list[float]] = [[] for _ in range(8)]
        for _ in range(300):  # 20 s
            still(core)
            for k, t in enumerate(core.bot_change_start.reshape(-1).tolist()):
                if t > -np.inf and (not starts[k] or starts[k][-1] != t):
                    starts[k].append(t)
        for k, times in enumerate(starts):
            assert times[0] == first.reshape(-1)[k]
            gaps = np.diff(times) - duration  # end of one change to the start of the next
            assert len(gaps) >= 3 and np.all((gaps >= 1.0 - 1e-9) & (gaps <= 3.0 + 1e-9)), (k, gaps)
        # Every bot is on one lane or between them, never beyond.
        assert np.all(np.abs(core.bot_d) <= 0.25 + 1e-12)

    def test_no_lane_changes_when_off(self) -> None:
        core = make_core(num_bots=2, bot_lane_change=False)
        bench_car(core)
        for _ in range(150):
            still(core)
        assert core.bot_lane[0].tolist() == [1.0, -1.0]
        np.testing.assert_allclose(core.bot_d[0], [0.25, -0.25], atol=1e-12)

    def test_bots_stop_when_every_car_is_done(self) -> None:
        core = make_core(num_bots=1, rules=RaceRules(mode="training", laps=1, time_limit=100.0))
        core.done[:] = True
        core._racing[:] = False
        s = core.bot_s.copy()
        still(core)
        assert np.array_equal(core.bot_s, s) and core.bot_speed[0, 0] == 0.0

    def test_seeded_motion_is_deterministic(self) -> None:
        a = make_core(num_envs=2, num_bots=3, randomize_bots=True, seed=11)
        b = make_core(num_envs=2, num_bots=3, randomize_bots=True, seed=11)
        for _ in range(100):
            still(a)
            still(b)
        for name in ("bot_s", "bot_d", "bot_yaw", "bot_lane", "bot_next_change"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name


class TestJudging:
    """Whoever is behind along the track is at fault (DeepRacer's bot_cars_agent_ctrl)."""

    def test_judge_bot_contacts_by_hand(self) -> None:
        # 2 envs x 2 cars, 1 obstacle and 2 bots per env: cars e * 2 + n (0..3), obstacles
        # 4 + e, bots 6 + e * 2 + j.
        s = np.array([[5.0, 18.5], [0.0, 1.0]])
        bot_s = np.array([[5.5, 0.2], [10.0, 0.8]])
        racing = np.ones((2, 2), bool)
        done = np.zeros((2, 2), bool)
        a = np.array([0, 9, 7, 4, 8])
        b = np.array([6, 3, 1, 6, 2])
        at_fault, collided, events, pause = race.judge_bot_contacts(
            a, b, 2, 2, 6, 2, s, bot_s, L, racing, done)
        # (0, 6): env 0 car 0 (5.0) behind bot 0 (5.5) -> car 0 at fault.
        # (9, 3): env 1 bot 1 (0.8) behind car 1 (1.0) -> the bots of env 1 pause.
        # (7, 1): env 0 bot 1 at 0.2, car 1 at 18.5: 0.2 - 18.5 = -18.3 wraps to
        #   -18.3 + 18.849 = +0.549 -> the bot is ahead, car 1 at fault.
        # (4, 6): obstacle vs bot -> ignored.
        # (8, 2): env 1 bot 0 (10.0) vs env 1 car 0 (0.0): the gap 10.0 is over half a lap and
        #   wraps to 10.0 - 18.849 = -8.849 -> the bot is behind -> pause env 1 again.
        assert at_fault.tolist() == [[True, True], [False, False]]
        assert collided.tolist() == [[True, True], [True, True]]
        assert pause.tolist() == [False, True]
        assert events == [(0, 0, 0, True), (1, 1, 1, False), (0, 1, 1, True),
                          (1, 0, 0, False)]

    def test_frozen_and_parked_cars_are_not_at_fault(self) -> None:
        s, bot_s = np.array([[1.0, 2.0]]), np.array([[1.5]])
        racing = np.array([[False, True]])
        done = np.array([[False, True]])
        at_fault, collided, events, pause = race.judge_bot_contacts(
            np.array([0, 1]), np.array([4, 4]), 1, 2, 4, 1, s, bot_s, L, racing, done)
        # Car 0 is frozen (not racing): touched, not judged; car 1 is parked: ignored.
        assert at_fault.tolist() == [[False, False]] and collided.tolist() == [[True, False]]
        assert events == [] and pause.tolist() == [False]

    def test_car_hitting_a_bot_from_behind_is_crashed(self) -> None:
        # Bot 0 starts at s = 2.0 on the inner lane at 0.2 m/s; the car starts on the same lane
        # at s = 0 and drives 1 m/s: it closes 0.8 m/s on a 2 - 0.3235 = 1.68 m gap.
        core = make_core(num_bots=1, bot_speed=0.2, bot_lane_change=False)
        place_car(core, 0, 0.0, 0.25)
        v = 1.0
        steer = (v / (R - 0.25)) / core.model.steady_state_yaw_rate(v, 1.0)
        found = None
        for _ in range(90):
            ev = core.step(np.full((1, 1), steer), np.full((1, 1), v))
            if ev.bot_contacts:
                found = ev
                break
        assert found is not None, "the car never reached the bot"
        assert found.bot_contacts == [(0, 0, 0, True)]
        assert found.crashed[0, 0] and found.collided[0, 0] and found.penalised[0, 0]
        assert found.bots_paused is None and core.bot_pauses[0] == 0
        assert core.crashes[0, 0] == 1 and core.collisions[0, 0] == 1
        # Race rules: the car is frozen for the crash penalty; the bot drives on.
        s = core.bot_s[0, 0]
        still(core)
        assert core.frozen[0, 0] and core.bot_s[0, 0] == pytest.approx(s + 0.2 * DT)

    def test_car_hitting_a_bot_ends_a_training_episode(self) -> None:
        core = make_core(num_bots=1, bot_speed=0.2, bot_lane_change=False,
                         rules=RaceRules(mode="training", laps=1, time_limit=100.0))
        place_car(core, 0, 0.0, 0.25)
        steer = (1.0 / (R - 0.25)) / core.model.steady_state_yaw_rate(1.0, 1.0)
        for _ in range(90):
            ev = core.step(np.full((1, 1), steer), np.ones((1, 1)))
            if ev.bot_contacts:
                break
        assert ev.bot_contacts == [(0, 0, 0, True)]
        assert ev.terminated[0, 0] and ev.crashed[0, 0]

    def test_bot_running_into_a_car_ahead_pauses_every_bot(self) -> None:
        # Bot 0 at s = 2.0 (inner lane), bot 1 on the outer lane further on; the car stands on
        # the inner lane at s = 2.6, 0.6 - 0.3235 = 0.28 m ahead of bot 0's nose.
        core = make_core(num_bots=2, bot_speed=0.75, bot_lane_change=False, bot_penalty=5.0)
        place_car(core, 0, 2.6, 0.25)
        found, hit_time = None, 0.0
        for _ in range(30):
            ev = still(core)
            if ev.bot_contacts:
                found, hit_time = ev, float(core.time[0])
                break
        assert found is not None, "the bot never reached the car"
        assert found.bot_contacts == [(0, 0, 0, False)]
        assert found.bots_paused is not None and found.bots_paused.tolist() == [True]
        assert not found.crashed[0, 0] and not found.penalised[0, 0] and found.collided[0, 0]
        assert core.crashes[0, 0] == 0 and core.bot_pauses[0] == 1
        assert core.bot_pause_until[0] == pytest.approx(hit_time + 5.0)
        # Every bot stands still for 5 s = 75 steps (bot 1 too, though it touched nothing).
        frozen = core.bot_s.copy()
        for _ in range(75):
            still(core)
            np.testing.assert_allclose(core.bot_s, frozen, atol=1e-9)
            assert np.all(core.bot_speed == 0.0)
        # Then they drive on: 0.75 m/s * 1/15 s = 0.05 m per step.
        still(core)
        np.testing.assert_allclose(core.bot_s[0, 1] - frozen[0, 1], 0.05, atol=1e-9)


class TestSensors:
    """The state vector, the lidar and the camera see bots as cars."""

    def test_state_opponent_slot_holds_the_bot(self) -> None:
        core = make_core(num_bots=1, bot_lane_change=False)
        obs = state_observation(core)[0, 0]
        # One car on the centre line at s = 0, the bot 2.0 m ahead on the inner lane (+0.25):
        # slot 0 = [present 1, gap 2.0 / 5 = 0.4, lateral 0.25 - 0 = 0.25, speed 0 - 0].
        np.testing.assert_allclose(obs[19:23], [1.0, 0.4, 0.25, 0.0], atol=1e-6)
        np.testing.assert_allclose(obs[23:27], 0.0)  # slot 1 empty
        for _ in range(15):
            still(core)
        # After 1 s: gap (2.75 - 0) / 5 = 0.55, relative speed (0.75 - 0) / 4 = 0.1875.
        obs = state_observation(core)[0, 0]
        np.testing.assert_allclose(obs[19:23], [1.0, 0.55, 0.25, 0.1875], atol=1e-5)

    def test_lidar_sees_a_bot_ahead(self) -> None:
        core = make_core(num_bots=1, bot_lane_change=False)
        place_car(core, 0, 1.3, 0.25)  # 0.7 m of centre line behind the bot, on its lane
        ranges = LidarSensor(core.config.lidar, CAR).ranges(core)[0, 0]
        # On the 2.75 m lane the bot is 0.7 / 3 = 0.2333 rad further round: its centre is the
        # chord 2 * 2.75 sin(0.11667) = 0.6402 m away, 0.11667 rad left of our heading, i.e.
        # (0.6358, 0.0746) in our frame, and it is turned by 0.2333 rad. Its rear face's centre
        # is half a length (0.16175 m) back: (0.4784, 0.0372); the face's normal is
        # (cos .2333, sin .2333) = (0.9729, 0.2312), so the face lies at the perpendicular
        # distance 0.9729 * 0.4784 + 0.2312 * 0.0372 = 0.4740 m from the scanner, and the foot
        # of that perpendicular falls on the face. The beam nearest to its bearing (13.37 deg)
        # is 11.90 deg, 1.46 deg off: range 0.4740 / cos(1.46 deg) = 0.4742 m.
        assert ranges.min() == pytest.approx(0.4742, abs=0.002)
        core_no_bots = make_core()
        place_car(core_no_bots, 0, 1.3, 0.25)
        assert np.isinf(LidarSensor(core.config.lidar, CAR).ranges(core_no_bots)).all()

    def test_camera_shades_cars_beyond_eight_and_bots(self) -> None:
        # 12 cars and 3 bots (15 boxes): only car 11 (shade CAR_SHADES[11 % 8] = 70) and
        # bot 0 (BOT_SHADE) are in view of car 0; the camera must draw each in its own shade.
        core = make_core(num_cars=12, num_bots=3, bot_lane_change=False)
        camera = CameraSensor(core.config.camera, TRACK, CAR)
        core.done[0, 1:11] = True
        place_car(core, 0, 0.0, 0.0)
        place_car(core, 11, 1.0, -0.2)
        empty = make_core(num_cars=12)
        empty.done[0, 1:] = True
        place_car(empty, 0, 0.0, 0.0)
        with_boxes = camera.render(core)[:, :, 0]
        background = camera.render(empty)[:, :, 0]
        drawn = with_boxes != background
        values = set(np.unique(with_boxes[drawn]).tolist())
        car_face = {round(70 * f) for f in FACE_FACTORS}  # {56, 43, 70}
        bot_face = {round(BOT_SHADE * f) for f in FACE_FACTORS}  # {140, 108, 175}
        assert CAR_SHADES[11 % 8] == 70
        assert 70 in values and BOT_SHADE in values, values
        assert values <= car_face | bot_face, values - car_face - bot_face


class TestParamsFromCore:
    """DeepRacer params of a core with obstacles, bots and cars."""

    def test_objects_in_insertion_order(self) -> None:
        from h2h_racing.deepracer.params import ParamsBuilder

        core = make_core(num_cars=2, num_obstacles=1, num_bots=2, bot_speed=0.6,
                         bot_lane_change=False)
        params = ParamsBuilder(TRACK, CAR, 2).from_core(core)
        p0 = params[0]
        # Obstacle, bot 0, bot 1, then car 1.
        expected = [core.obstacle_position[0, 0], core.bot_position[0, 0],
                    core.bot_position[0, 1], core.position[0, 1]]
        np.testing.assert_allclose(p0["objects_location"], expected)
        # With bots, every object reports the bots' speed (DeepRacer's BOT_CAR_SPEED quirk).
        assert p0["objects_speed"] == [0.6] * 4
        np.testing.assert_allclose(p0["objects_heading"][1:3], core.bot_yaw[0], atol=1e-12)


class TestEnv:
    """The PettingZoo env and the race runner with bots."""

    @pytest.mark.parametrize("kwargs", [
        {"num_cars": 2, "race_type": "head_to_bot"},
        {"num_cars": 1, "race_type": "head_to_bot", "rules": "training",
         "randomize_bots": True},
        {"num_cars": 2, "race_type": "head_to_head", "num_bots": 2,
         "sensors": ("state", "lidar")},
    ], ids=["h2b", "h2b-training-random", "h2h-with-bots-lidar"])
    def test_parallel_api(self, kwargs: dict[str, Any]) -> None:
        parallel_api_test(h2h_racing.parallel_env(track="oval", **kwargs), num_cycles=200)

    def test_no_bots_when_overridden(self) -> None:
        env = h2h_racing.parallel_env(track="oval", race_type="head_to_bot", num_bots=0)
        env.reset(seed=0)
        assert env.core.num_bots == 0 and env.core.bot_position.shape == (1, 0, 2)

    def test_render_shows_bots(self) -> None:
        with_bots = h2h_racing.parallel_env(track="oval", race_type="head_to_bot",
                                            render_mode="rgb_array")
        without = h2h_racing.parallel_env(track="oval", render_mode="rgb_array")
        with_bots.reset(seed=0)
        without.reset(seed=0)
        from h2h_racing.viz.render import BOT

        frame = with_bots.render()
        assert np.all(frame == np.array(BOT), axis=-1).sum() > 20
        assert np.all(without.render() == np.array(BOT), axis=-1).sum() == 0

    def test_run_race_lists_only_cars(self) -> None:
        from h2h_racing.match import run_race

        result = run_race("oval", ["racing_line", "pure_pursuit"], race_type="head_to_bot",
                          laps=1, seed=0, num_bots=2)
        assert [r["agent"] for r in sorted(result.rows, key=lambda r: r["agent"])] == [
            "car_0", "car_1"]
        assert result.bots == 2 and result.bot_speed == 0.75

    def test_rollout_is_deterministic(self) -> None:
        from h2h_racing.policies import make_driver

        def rollout(seed: int) -> tuple[list[Any], list[Any]]:
            env = h2h_racing.parallel_env(track="oval", num_cars=2, race_type="head_to_bot",
                                          num_bots=4, randomize_bots=True,
                                          sensors=("state", "lidar"))
            env.reset(seed=seed)
            drivers = [make_driver("racing_line"), make_driver("pure_pursuit")]
            for d in drivers:
                d.reset(env.core)
            trace, contacts = [], []
            for _ in range(400):
                if not env.agents:
                    break
                obs, rew, term, trunc, info = env.step(
                    {a: drivers[i].act(env.core, i)[0]
                     for i, a in enumerate(env.possible_agents) if a in env.agents})
                trace.append((obs, rew, term, trunc, info, env.core.bot_position.copy()))
                contacts += env.last_events.bot_contacts
            return trace, contacts

        a, contacts = rollout(5)
        b, _ = rollout(5)
        assert len(a) == len(b) and contacts, "the rollout must exercise bot contacts"
        for step, (ra, rb) in enumerate(zip(a, b)):
            for agent in ra[0]:
                for key in ra[0][agent]:
                    assert np.array_equal(ra[0][agent][key], rb[0][agent][key]), (step, key)
            assert ra[1:5] == rb[1:5], step
            assert np.array_equal(ra[5], rb[5]), step

    def test_pickled_env_continues(self) -> None:
        import pickle

        env = h2h_racing.parallel_env(track="oval", race_type="head_to_bot")
        env.reset(seed=0)
        for _ in range(10):
            env.step({a: np.array([0.0, -0.5]) for a in env.agents})
        clone = pickle.loads(pickle.dumps(env))
        for _ in range(10):
            actions = {a: np.array([0.0, -0.5]) for a in env.agents}
            env.step(actions)
            clone.step(actions)
        assert np.array_equal(env.core.bot_position, clone.core.bot_position)
        assert np.array_equal(env.core.position, clone.core.position)

    def test_lane_blend_doctest_values(self) -> None:
        assert bots.lane_blend(np.array([0.25]))[0] == pytest.approx(
            (1 - math.cos(math.pi / 4)) / 2)
