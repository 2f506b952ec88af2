"""Race rules (:mod:`h2h_racing.sim.race`, rules in :mod:`h2h_racing.sim.core`), with hand-computed cases.

Most cases run one or two cars on a 3 m radius circle (L = 400 * 6 sin(pi/400) = 18.8494 m).
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from h2h_racing.sim import race
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.policies import make_driver
from h2h_racing.envs.results import format_results, race_results

from conftest import circle_track

DT = 1.0 / 15.0
R = 3.0
TRACK = circle_track(R)
L = TRACK.length  # 18.849362... m
INF = math.inf


def make_core(num_cars: int = 1, num_envs: int = 1, **rules: Any) -> RaceCore:
    cfg = EnvConfig(track=TRACK.name, num_cars=num_cars, grid="fixed", rules=RaceRules(**rules))
    core = RaceCore(cfg, TRACK, num_envs=num_envs)
    core.reset(seed=0)
    return core


def command(core: RaceCore, steer: float, speed: float) -> Any:
    e, n = core.num_envs, core.num_cars
    return core.step(np.full((e, n), steer), np.full((e, n), speed))


def circle_steer(core: RaceCore, v: float, radius: float = R) -> float:
    """Steering angle whose steady-state yaw rate is v / radius (linear model, exact inverse)."""
    return (v / radius) / core.model.steady_state_yaw_rate(v, 1.0)


def launch(core: RaceCore, car: int, v: float, delta: float) -> None:
    """Put a car into steady cornering at speed v (no run-up), tangent to the centre line."""
    yaw = core.yaw[0, car]
    core.velocity[0, car] = v * np.array([math.cos(yaw), math.sin(yaw)])
    core.speed[0, car] = v
    core.steer[0, car] = delta
    core.yaw_rate[0, car] = v / R
    core._sync_physics()


def pursuit_step(core: RaceCore, driver: Any) -> Any:
    """One step with ``driver`` controlling car 0 (mapped exactly as the env maps actions)."""
    cfg = core.config
    act = np.clip(np.asarray(driver.act(core, 0), dtype=np.float64), -1.0, 1.0)
    mid, half = 0.5 * (cfg.max_speed + cfg.min_speed), 0.5 * (cfg.max_speed - cfg.min_speed)
    return core.step(act[:, 0:1] * cfg.car.max_steer, mid + half * act[:, 1:2])


class TestLapCounting:
    """Progress, lap completion and interpolated lap times on a circle of known length."""

    def test_lap_at_length_over_speed(self) -> None:
        core = make_core(laps=2, time_limit=100.0)
        v = 1.0
        delta = circle_steer(core, v)  # ~3.13 deg
        launch(core, 0, v, delta)
        distances, times = [0.0], [0.0]
        lap_step = None
        for k in range(1, 400):
            ev = command(core, delta, v)
            distances.append(float(core.distance[0, 0]))
            times.append(float(core.time[0]))
            # DeepRacer progress = % of a lap since the start.
            assert core.episode_progress[0, 0] == pytest.approx(distances[-1] * 100.0 / L)
            if ev.lap_completed[0, 0]:
                lap_step = k
                break
        assert lap_step is not None
        # At 1 m/s on the centre line the lap takes L / v = 18.849 s = 282.7 steps: the lap
        # completes on step 283 (the first step ending at or beyond L).
        assert lap_step == math.ceil(L / v / DT)
        lap_time = core.lap_times[0][0][0]
        assert lap_time == pytest.approx(L / v, abs=DT)
        # Interpolation by hand: the car went from d0 = distances[-2] to d1 = distances[-1]
        # during the last step ending at t1; it crossed L at t1 - dt (d1 - L) / (d1 - d0).
        d0, d1, t1 = distances[-2], distances[-1], times[-1]
        assert lap_time == pytest.approx(t1 - DT * (d1 - L) / (d1 - d0), abs=1e-9)
        assert core.laps[0, 0] == 1 and core.last_lap_time[0, 0] == lap_time
        assert core.best_lap_time[0, 0] == lap_time and not core.finished[0, 0]

    def test_finish_at_lap_target(self) -> None:
        core = make_core(laps=1, time_limit=100.0)
        v = 2.0
        delta = circle_steer(core, v)
        launch(core, 0, v, delta)
        for _ in range(200):
            ev = command(core, delta, v)
            if ev.finished.any():
                break
        assert ev.finished[0, 0] and ev.terminated[0, 0] and not ev.truncated[0, 0]
        assert core.finish_time[0, 0] == core.lap_times[0][0][0]
        # 1 lap at 2 m/s: 18.849 / 2 = 9.42 s (+- one step for the path and speed error).
        assert core.finish_time[0, 0] == pytest.approx(L / v, abs=DT)
        # The finished car is parked off the track and ignores commands.
        parked = core.position[0, 0].copy()
        ev = command(core, delta, v)
        assert np.array_equal(core.position[0, 0], parked)
        assert not ev.terminated.any() and ev.progress[0, 0] == 0.0

    def test_backwards_across_line_does_not_count(self) -> None:
        # Laps are floor((distance - origin) / L), never decreasing: 10 m back then forward.
        core = make_core(laps=3)
        core.distance[0, 0] = -10.0
        assert core.laps[0, 0] == 0

    @pytest.mark.parametrize(("time", "d", "step_d", "line", "expected"), [
        # crossed 0.2 of a 0.4 m step before the end: 1.0 - 0.1 * 0.2 / 0.4 = 0.95
        (1.0, 10.2, 0.4, 10.0, 0.95),
        # exactly on the line at the end of the step: 2.0 - 0.1 * 0 = 2.0
        (2.0, 10.0, 0.5, 10.0, 2.0),
        # the whole step beyond the line (fraction clipped to 1): 3.0 - 0.1 = 2.9
        (3.0, 11.0, 0.5, 10.0, 2.9),
        # zero step (no division by zero), beyond the line: clipped to 1 -> 0.9
        (1.0, 10.1, 0.0, 10.0, 0.9),
    ])
    def test_crossing_time(self, time: float, d: float, step_d: float, line: float,
                           expected: float) -> None:
        got = race.crossing_time(time, 0.1, np.array(d), np.array(step_d), np.array(line))
        assert float(got) == pytest.approx(expected, abs=1e-12)


class TestPenalties:
    """Race mode: freeze for the penalty while the clock runs, then re-place on a lane."""

    @staticmethod
    def _drive_off(core: RaceCore) -> tuple[int, Any]:
        # Straight at 2 m/s from the centre of a 3 m circle: the car leaves outwards.
        for k in range(1, 200):
            prev = float(core.distance[0, 0])
            ev = command(core, 0.0, 2.0)
            if ev.penalised[0, 0]:
                return k, prev
        raise AssertionError("the car never went off track")

    def test_off_track_penalty_freezes_then_replaces(self) -> None:
        core = make_core(off_track_penalty=5.0)
        k, prev_distance = self._drive_off(core)
        assert core.penalties[0, 0] == 1 and core.penalty_time[0, 0] == 5.0
        t_pen = float(core.time[0])
        assert core.frozen_until[0, 0] == t_pen + 5.0
        frozen_pos = core.position[0, 0].copy()
        replaced_at = None
        for j in range(1, 100):
            ev = command(core, 0.0, 2.0)
            # The clock runs while the car is frozen.
            assert core.time[0] == pytest.approx(t_pen + j * DT, abs=1e-9)
            if ev.replaced[0, 0]:
                replaced_at = j
                break
            assert np.array_equal(core.position[0, 0], frozen_pos), f"[{j}] frozen car moved"
            assert core.frozen[0, 0] and ev.progress[0, 0] == 0.0
        assert replaced_at is not None and replaced_at in (75, 76)
        # Re-placed at the last valid progress (the distance before the off-track step), on
        # the nearest lane: it left outwards (right of travel on a CCW circle), so the right
        # lane, d = -half_width / 2 = -0.25 m, at radius 3.25 m.
        assert core.distance[0, 0] == prev_distance
        assert core.d[0, 0] == pytest.approx(-0.25, abs=1e-9)
        assert np.linalg.norm(core.position[0, 0]) == pytest.approx(R + 0.25, abs=1e-3)
        assert core.resets[0, 0] == 1 and core.speed[0, 0] == 0.0
        # It races again on the next step.
        ev = command(core, 0.0, 1.0)
        assert ev.progress[0, 0] > 0.0

    def test_penalty_lasts_exactly_75_steps(self) -> None:
        core = make_core(off_track_penalty=5.0)
        self._drive_off(core)
        for j in range(1, 100):
            if command(core, 0.0, 2.0).replaced[0, 0]:
                break
        # 5 s / (1/15 s) = 75 steps.
        assert j == 75

    def test_training_mode_ends_at_first_infraction(self) -> None:
        core = make_core(mode="training")
        for _ in range(200):
            ev = command(core, 0.0, 2.0)
            if ev.off_track[0, 0]:
                break
        assert ev.terminated[0, 0] and not ev.truncated[0, 0]
        assert not ev.penalised.any() and core.done[0, 0] and core.penalties[0, 0] == 0

    def test_max_cycles_truncates(self) -> None:
        core = make_core(time_limit=100.0)
        core.max_cycles = 15
        for k in range(1, 16):
            ev = command(core, circle_steer(core, 0.5), 0.5)
            assert ev.truncated[0, 0] == (k == 15), f"[{k}]"
        assert not ev.terminated[0, 0]

    def test_time_limit_truncates(self) -> None:
        core = make_core(time_limit=1.0)
        for k in range(1, 20):
            ev = command(core, circle_steer(core, 0.5), 0.5)
            if ev.truncated[0, 0]:
                break
        # 1 s = 15 steps of 1/15 s.
        assert k in (15, 16) and not ev.terminated[0, 0]

    def test_time_limit_exact_step(self) -> None:
        core = make_core(time_limit=1.0)
        for k in range(1, 20):
            if command(core, circle_steer(core, 0.5), 0.5).truncated[0, 0]:
                break
        assert k == 15

    def test_reversed_after_15_steps(self) -> None:
        core = make_core(mode="training")
        core.yaw[0, 0] += math.pi  # facing the wrong way
        core._sync_physics()
        for k in range(1, 30):
            ev = command(core, -circle_steer(core, 1.0), 1.0)
            assert ev.progress[0, 0] < 0.0
            assert ev.reversed[0, 0] == (k == 15), f"[{k}]"
            if ev.terminated[0, 0]:
                break
        assert k == 15 and core.done[0, 0]

    def test_immobilised_after_15_steps(self) -> None:
        core = make_core()
        for k in range(1, 20):
            ev = command(core, 0.0, 0.0)
            assert ev.immobilised[0, 0] == (k == 15), f"[{k}]"
            if ev.penalised[0, 0]:
                break
        assert k == 15 and core.penalties[0, 0] == 1
        assert core.frozen_until[0, 0] == core.time[0] + 5.0

    def test_time_trial_lap_void_after_four_resets(self) -> None:
        # max_resets_per_lap = 3: 4 immobilised resets make lap 1 void; lap 2 is clean.
        core = make_core(laps=0, time_limit=240.0, ranking="best_lap", max_resets_per_lap=3,
                         immobilised_penalty=0.2)
        for _ in range(4):
            for _ in range(40):
                if command(core, 0.0, 0.0).replaced[0, 0]:
                    break
        assert core.resets[0, 0] == 4 and core.lap_resets[0, 0] == 4
        driver = make_driver("pure_pursuit")
        driver.reset(core)
        for _ in range(1500):
            pursuit_step(core, driver)
            if core.laps[0, 0] == 2:
                break
        assert core.laps[0, 0] == 2 and core.resets[0, 0] == 4
        assert core.lap_valid[0][0] == [False, True]
        first, second = core.lap_times[0][0]
        # The void lap is timed (last_lap_time) but never the best lap.
        assert core.best_lap_time[0, 0] == second and core.last_lap_time[0, 0] == second
        assert first > second


class TestReplacementAfterABox:
    """A crash into a box puts the car back 1 m behind the box on the other lane (DeepRacer's
    ``RESET_BEHIND_DIST``), or, where that spot is taken, on the box's lane."""

    BOX_FRACTION = 0.25  # of the lap: s = 0.25 L = 4.71234 m, on the left lane (d = +0.25 m)

    def _crash(self, extra_boxes: tuple[tuple[float, int], ...] = ()) -> RaceCore:
        cfg = EnvConfig(track=TRACK.name, num_cars=1, grid="fixed",
                        num_obstacles=1 + len(extra_boxes),
                        obstacle_positions=((self.BOX_FRACTION, 1), *extra_boxes),
                        rules=RaceRules(crash_penalty=1.0))
        core = RaceCore(cfg, TRACK, num_envs=1)
        core.reset(seed=0)
        # On the box's lane, 0.6 m behind it, heading along the track: the car (0.32 m long)
        # and the box (0.5 m) touch once the gap between centres is under 0.41 m.
        s0 = self.BOX_FRACTION * L - 0.6
        core.position[0, 0] = TRACK.point_at(np.array([s0]), np.array([0.25]))[0]
        core.yaw[0, 0] = TRACK.heading_at(np.array([s0]))[0]
        core._sync_physics()
        for _ in range(30):
            if command(core, circle_steer(core, 1.0, R - 0.25), 1.0).penalised[0, 0]:
                break
        assert core.crashes[0, 0] == 1, "the car never hit the box"
        for _ in range(30):  # 1 s penalty = 15 steps
            if command(core, 0.0, 0.0).replaced[0, 0]:
                return core
        raise AssertionError("the car was never put back")

    def test_one_metre_behind_the_box_on_the_other_lane(self) -> None:
        core = self._crash()
        # The lap started at distance 0 = s 0, so the box is at distance 0.25 L; the car goes
        # back to 0.25 L - 1 m = 3.71234 m, on the right lane (d = -0.5 / 2 = -0.25 m).
        assert core.distance[0, 0] == pytest.approx(0.25 * L - 1.0, abs=1e-9)
        assert core.d[0, 0] == pytest.approx(-0.25, abs=1e-9)
        assert core.resets[0, 0] == 1

    def test_up_the_clear_lane_when_a_second_box_is_one_metre_behind(self) -> None:
        # A second box on the right lane at 0.25 L - 1 m covers -1.25 .. -0.75 m. The car's
        # box grown by 7 cm reaches 0.16 + 0.07 = 0.23 m either way along the lane: the spot
        # 0.25 m nearer the hit box (-0.98 .. -0.52 m) overlaps it, 0.5 m nearer (-0.73 ..
        # -0.27 m) is clear. So: right lane, 0.5 m behind the hit box.
        core = self._crash(extra_boxes=((0.25 - 1.0 / L, -1),))
        assert core.distance[0, 0] == pytest.approx(0.25 * L - 0.5, abs=1e-9)
        assert core.d[0, 0] == pytest.approx(-0.25, abs=1e-9)

    def test_the_box_lane_when_the_clear_lane_is_taken_all_the_way_up(self) -> None:
        # The second box at 0.25 L - 0.6 m on the right lane covers -0.85 .. -0.35 m: every
        # spot up the right lane (-1.0, -0.75, -0.5, -0.25 m, each +-0.23 m) overlaps it. The
        # next candidate is 1 m behind the hit box on its own lane (the left), clear of both
        # (0.77 m to the hit box's back at -0.25 m is more than 0.23 m; the lanes are 0.5 m
        # apart, more than 0.098 + 0.07 + 0.2 = 0.37 m).
        core = self._crash(extra_boxes=((0.25 - 0.6 / L, -1),))
        assert core.distance[0, 0] == pytest.approx(0.25 * L - 1.0, abs=1e-9)
        assert core.d[0, 0] == pytest.approx(0.25, abs=1e-9)


class TestCrashJudging:
    """Car-car contacts: the car behind is at fault; obstacles: the car is at fault."""

    def test_judge_contacts_by_hand(self) -> None:
        # 2 envs x 3 cars, 2 obstacles per env. Flat car index = e * 3 + n; obstacles follow as
        # 6 + e * 2 + k.
        distance = np.array([[5.0, 4.0, 9.0], [1.0, 2.0, 3.0]])
        racing = np.array([[True, True, True], [True, False, True]])
        a = np.array([0, 4, 9, 6 + 2 + 1, 5])
        b = np.array([1, 3, 2, 5, 4])
        at_fault, collided, events = race.judge_contacts(a, b, 2, 3, 2, distance, racing)
        # (0,1) in env 0: car 1 (4.0 m) behind car 0 (5.0 m) -> car 1 at fault.
        # (4,3) in env 1: car 1 (2.0) ahead of car 0 (1.0) -> car 0 at fault.
        # (9,2): obstacle 9 = env 0 obstacle 1 vs car 2 of env 0 -> car 2 at fault.
        # (6+2+1=9... obstacle index 9 is env 1 obstacle 0? no: 6 + e*2 + k with 9 -> e=1,k=1),
        #   here body 9 is listed first against car 5 = env 1 car 2 -> env 1 car 2 at fault.
        # (5,4) in env 1: car 2 (3.0) vs car 1 (2.0, not racing, behind) -> nobody at fault,
        #   but both collided.
        assert at_fault.tolist() == [[False, True, True], [True, False, True]]
        assert collided.tolist() == [[True, True, True], [True, True, True]]
        assert events == [(0, 1, 0, False), (1, 0, 1, False), (0, 2, 1, True), (1, 2, 1, True)]

    def test_equal_distance_blames_first_body(self) -> None:
        # Ties: the first body reported (a) counts as behind.
        distance = np.array([[3.0, 3.0]])
        at_fault, _, events = race.judge_contacts(np.array([1]), np.array([0]), 1, 2, 0,
                                                  distance, np.ones((1, 2), bool))
        assert at_fault.tolist() == [[False, True]] and events == [(0, 1, 0, False)]

    @staticmethod
    def _rear_end() -> tuple[Any, Any]:
        # Two cars on one lane of the circle: slot 1 (0.75 m behind) runs into slot 0.
        core = make_core(num_cars=2, time_limit=60.0)
        core.d[0, :] = -0.25
        core.position[0] = TRACK.point_at(core.s[0], core.d[0])
        core._sync_physics()
        speeds = np.array([[0.5, 2.5]])
        for _ in range(60):
            steer = np.full((1, 2), circle_steer(core, 1.0, R + 0.25))
            ev = core.step(steer, speeds)
            if ev.collided.any():
                return core, ev
        raise AssertionError("no contact")

    def test_rear_end_in_core(self) -> None:
        core, found = self._rear_end()
        assert found.collided[0].tolist() == [True, True]
        assert found.crashed[0].tolist() == [False, True]
        assert found.penalised[0].tolist() == [False, True]
        assert (0, 1, 0, False) in found.collisions
        assert core.crashes[0].tolist() == [0, 1] and core.collisions[0].tolist() == [1, 1]

    def test_rear_end_rewards_crash_and_contact(self) -> None:
        from h2h_racing.sim import rewards
        from h2h_racing.config.env import RewardConfig

        core, found = self._rear_end()
        weights = rewards.weights_of(RewardConfig(crash=-5.0, contact=-2.0))
        terms, _ = rewards.reward_terms(weights, found, core.speed, np.ones((1, 2), bool))
        crash, contact = rewards.TERMS.index("crash"), rewards.TERMS.index("contact")
        # The car in front was run into: no crash, but the contact costs it -2 too; the car
        # behind is at fault: -5 for the crash and -2 for the contact.
        assert terms[crash, 0].tolist() == [0.0, -5.0]
        assert terms[contact, 0].tolist() == [-2.0, -2.0]


class TestOvertakesAndDefences:
    """Passes are counted once per pass; defences after sustained pressure."""

    @staticmethod
    def _run(seq: list[list[float]], speeds: list[list[float]] | None = None,
             eligible: list[list[bool]] | None = None, dt: float = 0.25, length: float = 100.0,
             ) -> tuple[np.ndarray, np.ndarray]:
        n = len(seq[0])
        pressure = np.zeros((1, n, n))
        faster = np.zeros((1, n, n), bool)
        prev = np.array([seq[0]])
        gap = prev[:, :, None] - prev[:, None, :]
        passes = np.zeros((1, n, n), int)
        defences = np.zeros((1, n, n), int)
        for t, dist in enumerate(seq[1:]):
            d = np.array([dist])
            v = np.array([speeds[t]]) if speeds else np.ones((1, n))
            ok = np.array([eligible[t]]) if eligible else np.ones((1, n), bool)
            gap, passed, defended = race.overtakes_and_defences(
                d, gap, ok, v, pressure, faster, length, dt, 1.0, 2.0)
            passes += passed
            defences += defended
        return passes[0], defences[0]

    def test_pass_counted_once(self) -> None:
        # Car 1 starts 0.5 m behind car 0, draws level, passes, and stays ahead.
        seq = [[10.0, 9.5], [10.2, 9.9], [10.4, 10.3], [10.6, 10.7], [10.8, 11.1], [11.0, 11.5]]
        passes, _ = self._run(seq)
        assert passes.tolist() == [[0, 0], [1, 0]]

    def test_equal_distance_is_not_a_pass_until_ahead(self) -> None:
        # Gap -0.5, 0.0 (level), +0.5: a single pass on the step the gap turns positive.
        passes, _ = self._run([[10.0, 9.5], [10.5, 10.5], [11.0, 11.5]])
        assert passes.tolist() == [[0, 0], [0, 0]]  # from 0.0 to +0.5 is not "from behind (< 0)"

    def test_pass_back_and_forth(self) -> None:
        # 1 passes 0, 0 passes back, 1 passes again: 2 passes by car 1, 1 by car 0.
        seq = [[10.0, 9.9], [10.1, 10.2], [10.4, 10.3], [10.5, 10.6]]
        passes, _ = self._run(seq)
        assert passes.tolist() == [[0, 1], [2, 0]]

    def test_lapped_car_or_replacement_is_not_a_pass(self) -> None:
        # On a 100 m lap a gap jumping from -60 to +55 (more than half a lap) is not a pass,
        # nor is a gap change while one car was ineligible (re-placed).
        passes, _ = self._run([[70.0, 10.0], [70.0, 125.0]])
        assert passes.sum() == 0
        passes, _ = self._run([[10.0, 9.5], [10.0, 10.5]], eligible=[[True, False]])
        assert passes.sum() == 0

    def test_defence_after_two_seconds_of_pressure(self) -> None:
        # Car 1 sits 0.5 m behind car 0 (inside the 1 m gap) for 8 steps of 0.25 s = 2.0 s,
        # faster at some moment, then drops back to 1.5 m: car 0 completed one defence.
        seq = [[10.0 + 0.1 * t, 9.5 + 0.1 * t] for t in range(9)] + [[11.0, 9.5]]
        speeds = [[1.0, 1.2]] * 9
        _, defences = self._run(seq, speeds=speeds)
        # defended[i, j]: j defended against i -> attacker 1, defender 0.
        assert defences.tolist() == [[0, 0], [1, 0]]

    def test_no_defence_when_short_or_never_faster(self) -> None:
        seq = [[10.0 + 0.1 * t, 9.5 + 0.1 * t] for t in range(5)] + [[11.0, 9.5]]
        _, defences = self._run(seq, speeds=[[1.0, 1.2]] * 5)  # 1.0 s < 2 s
        assert defences.sum() == 0
        seq = [[10.0 + 0.1 * t, 9.5 + 0.1 * t] for t in range(12)] + [[12.0, 9.5]]
        _, defences = self._run(seq, speeds=[[1.2, 1.0]] * 12)  # attacker never faster
        assert defences.sum() == 0


class TestRanksAndResults:
    """Race positions with ties, finishers and best-lap ranking; the results table order."""

    def test_total_time_ranks_with_ties(self) -> None:
        distance = np.array([[3.0, 5.0, 5.0, 9.0, 1.0]])
        finished = np.array([[False, False, False, True, True]])
        finish_time = np.array([[INF, INF, INF, 30.0, 20.0]])
        ranks = race.race_ranks(distance, finished, finish_time, np.full((1, 5), INF), "total_time")
        # Finishers first by time (car 4 at 20 s, car 3 at 30 s), then by distance; the tie at
        # 5.0 m goes to the lower index (car 1 before car 2), car 0 last.
        assert ranks.tolist() == [[5, 3, 4, 2, 1]]

    def test_best_lap_ranks(self) -> None:
        distance = np.array([[3.0, 50.0, 7.0, 7.0]])
        best = np.array([[12.0, INF, 11.5, 12.0]])
        ranks = race.race_ranks(distance, np.zeros((1, 4), bool), np.full((1, 4), INF), best,
                                "best_lap")
        # 11.5 s (car 2), then the 12.0 s tie -> car 0 before car 3, then car 1 without a lap.
        assert ranks.tolist() == [[2, 4, 1, 3]]

    def test_results_table_order(self) -> None:
        core = SimpleNamespace(
            distance=np.array([[40.0, 60.0, 60.0]]), finished=np.array([[False, True, True]]),
            finish_time=np.array([[INF, 41.0, 39.5]]), best_lap_time=np.array([[14.0, 13.0, 13.2]]),
            laps=np.array([[2, 3, 3]]), lap_times=[[[14.0, 15.0], [13.0, 14.0, 14.0], [13.2, 13.3, 13.0]]],
            resets=np.array([[1, 0, 0]]), penalties=np.array([[1, 0, 0]]),
            penalty_time=np.array([[5.0, 0.0, 0.0]]), off_tracks=np.array([[1, 0, 0]]),
            crashes=np.zeros((1, 3), int), collisions=np.zeros((1, 3), int),
            overtakes=np.array([[0, 1, 2]]), defences=np.zeros((1, 3), int),
            rules=RaceRules())
        rows = race_results(core, 0, ["car_0", "car_1", "car_2"])
        assert [r["agent"] for r in rows] == ["car_2", "car_1", "car_0"]
        assert [r["position"] for r in rows] == [1, 2, 3]
        assert rows[0]["total_time"] == 39.5 and rows[2]["total_time"] == INF
        text = format_results(rows, names={"car_2": "bot"}).splitlines()
        assert len(text) == 5 and "car_2 (bot)" in text[2] and "DNF" in text[4]
        assert " 39.50 " in text[2]

    def test_core_ranks_follow_distance(self) -> None:
        core = make_core(num_cars=3)
        # Fixed grid: car 0 at 0 m, car 1 at -0.75 m, car 2 at -1.5 m.
        assert core.rank[0].tolist() == [1, 2, 3]
