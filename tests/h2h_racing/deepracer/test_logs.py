"""DeepRacer simtrace CSV and metrics JSON: the column contract, hand-checked values, and
deepracer-utils (the community's analysis library) loading our logs unchanged."""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import h2h_racing
from h2h_racing.config.env import EnvConfig, RaceRules
from h2h_racing.sim.core import RaceCore
from h2h_racing.deepracer.logs import SIMTRACE_COLUMNS, STATUS_LABELS, SimtraceWriter
from h2h_racing.match import run_race
from h2h_racing.policies import make_driver
from h2h_racing.track.shape import Track
from h2h_racing.track.io import save_track

circle_track = sys.modules["conftest"].circle_track
DT = 1.0 / 15.0


def square_track() -> Track:
    """10 x 10 m square centre line, CCW, 1 m each side (the params tests' square): waypoints
    (0,0) (5,0) (5,0) (10,0) (10,10) (0,10) (0,0), normalised arc positions
    [0, .125, .125, .25, .5, .75, 1.0], L = 40 m."""
    centre = [(0, 0), (5, 0), (5, 0), (10, 0), (10, 10), (0, 10)]
    left = [(1, 1), (5, 1), (5, 1), (9, 1), (9, 9), (1, 9)]
    right = [(-1, -1), (5, -1), (5, -1), (11, -1), (11, 11), (-1, 11)]
    return Track(np.array(centre, float), 1.0, 1.0, name="square",
                 left_border=np.array(left, float), right_border=np.array(right, float))


def read_rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open() as f:
        reader = csv.DictReader(f)
        return list(reader.fieldnames or []), list(reader)


def drive(core: RaceCore, writer: SimtraceWriter, steer: float, speed: float,
          steps: int) -> list[float]:
    """Step one car with a constant command, logging every step; return the rewards given."""
    given = []
    for k in range(steps):
        if core.done.all():
            break
        racing = core.racing
        events = core.step(np.full((1, 1), steer), np.full((1, 1), speed))
        reward = np.full((1, 1), 0.25 * (k + 1))
        given.append(float(reward[0, 0]))
        writer.log_step(core, events, racing, reward=reward)
    return given


class TestStraightDrive:
    """One car drives straight along the square's first side (+x): every column by hand."""

    def setup_method(self) -> None:
        self.track = square_track()
        self.config = EnvConfig(track="square", num_cars=1, race_type="time_trial",
                                rules=RaceRules.preset("time_trial", "training"))
        self.core = RaceCore(self.config, self.track, num_envs=1)

    def test_rows_columns_and_values(self, tmp_path: Path) -> None:
        # Start 1 m along the first side, at (1, 0) heading +x (the corner's heading would
        # be the bisector).
        self.core.reset(seed=0, start=np.array([1.0]))
        writer = SimtraceWriter(tmp_path, self.config, self.track)
        writer.start(self.core)
        rewards = drive(self.core, writer, 0.0, 1.0, 20)
        x_car = self.core.position[0, 0, 0]
        writer.close()
        columns, rows = read_rows(tmp_path / "car_0" / "training-simtrace" / "0-iteration.csv")
        assert tuple(columns) == SIMTRACE_COLUMNS and len(columns) == 19
        # The prepare row and 20 steps.
        assert len(rows) == 21
        first, last = rows[0], rows[-1]
        assert first["episode_status"] == "prepare" and float(first["steps"]) == 1.0
        assert float(first["reward"]) == 0.0 and float(first["tstamp"]) == 0.0
        # The car starts at (1, 0) heading +x: the model point is 0.14 m ahead, which is
        # 100 * 0.14 / 40 = 0.35 % of the 40 m lap from the start.
        assert float(first["X"]) == pytest.approx(1.14, abs=1e-9)
        assert float(first["progress"]) == pytest.approx(0.35, abs=1e-9)
        # DRfC's numbering: the prepare row is step 1.0, the first action's row 2.0.
        assert [float(r["steps"]) for r in rows] == [float(k) for k in range(1, 22)]
        assert [float(r["reward"]) for r in rows[1:]] == pytest.approx(rewards)
        # Steps are 1/15 s: the 20th row is at 20/15 s.
        assert float(last["tstamp"]) == pytest.approx(20 / 15, abs=1e-9)
        # Straight along +x: X = car x + 0.14, Y = 0, yaw 0; progress = 100 (X - 1) / 40.
        x = float(last["X"])
        assert x == pytest.approx(x_car + 0.14, abs=1e-9)
        assert abs(float(last["Y"])) < 1e-6 and abs(float(last["yaw"])) < 1e-4
        assert float(last["progress"]) == pytest.approx(100.0 * (x - 1.0) / 40.0, abs=1e-6)
        # Between waypoints 0 (0, 0) and 1 (5, 0): the nearer one by distance.
        assert 1.5 < x < 5.0
        assert int(last["closest_waypoint"]) == (1 if 5.0 - x < x else 0)
        assert float(last["track_len"]) == pytest.approx(40.0)
        assert float(last["steer"]) == 0.0 and float(last["throttle"]) == 1.0
        assert last["action"] == "[0.0 1.0]"
        assert {r["episode_status"] for r in rows[1:]} == {"in_progress"}
        assert {r["done"] for r in rows} == {"False"}
        assert {r["all_wheels_on_track"] for r in rows} == {"True"}
        assert {r["episode"] for r in rows} == {"0"}
        assert all(float(r["wall_clock"]) > 1e9 for r in rows)

    def test_off_track_row_ends_the_episode(self, tmp_path: Path) -> None:
        self.core.reset(seed=0, start=np.array([1.0]))
        writer = SimtraceWriter(tmp_path, self.config, self.track)
        writer.start(self.core)
        # Full left lock at 2 m/s leaves the 2 m wide road within a few metres.
        drive(self.core, writer, math.radians(30), 2.0, 200)
        assert self.core.done[0, 0] and self.core.off_tracks[0, 0] == 1
        writer.close()
        _, rows = read_rows(tmp_path / "car_0" / "training-simtrace" / "0-iteration.csv")
        last = rows[-1]
        assert last["episode_status"] == "off_track" and last["done"] == "True"
        # Off track = all four wheels off, so certainly not all on; and the row is where
        # the car left the road, not where it was parked afterwards (beyond x = 11 m).
        assert last["all_wheels_on_track"] == "False"
        assert -2.0 < float(last["X"]) < 11.0 and -2.0 < float(last["Y"]) < 11.0
        metrics = json.loads((tmp_path / "car_0" / "metrics" / "TrainingMetrics.json")
                             .read_text())
        (entry,) = metrics["metrics"]
        assert set(entry) == {"reward_score", "metric_time", "start_time",
                              "elapsed_time_in_milliseconds", "episode", "trial", "phase",
                              "completion_percentage", "episode_status"}
        steps = len(rows) - 1
        assert entry["episode_status"] == STATUS_LABELS["off_track"] == "Off track"
        assert entry["elapsed_time_in_milliseconds"] == round(1000 * steps / 15)
        assert entry["episode"] == 1 and entry["trial"] == 1 and entry["phase"] == "training"
        assert entry["completion_percentage"] == int(float(last["progress"]))
        # Rewards 0.25, 0.5, ... 0.25 k: total 0.25 k (k + 1) / 2.
        assert entry["reward_score"] == round(0.25 * steps * (steps + 1) / 2)
        assert metrics["best_model_metric"] == "progress"


class TestEpisodes:
    """Lap completions, iterations, clocks, and the evaluation layout of races."""

    def test_lap_complete_and_iteration_files(self, tmp_path: Path) -> None:
        track = circle_track()
        env = h2h_racing.parallel_env(track=track, num_cars=1, race_type="time_trial",
                                      rules="training")
        driver = make_driver("pure_pursuit")
        writer = SimtraceWriter(tmp_path, env.config, env.track, episodes_per_iteration=2)
        durations = []
        for episode in range(3):
            env.reset(seed=episode)
            driver.reset(env.core)
            writer.start(env.core)
            while env.agents:
                racing = env.core.racing
                _, reward, *_ = env.step({"car_0": driver.act(env.core, 0)[0]})
                writer.log_step(env.core, env.last_events, racing,
                                reward=np.array([[reward["car_0"]]]))
            assert env.core.laps[0, 0] == 1
            durations.append(float(env.core.time[0]))
        writer.close()
        folder = tmp_path / "car_0" / "training-simtrace"
        _, it0 = read_rows(folder / "0-iteration.csv")
        _, it1 = read_rows(folder / "1-iteration.csv")
        assert sorted({r["episode"] for r in it0}) == ["0", "1"]
        assert {r["episode"] for r in it1} == {"2"}
        ends = [r for r in it0 + it1 if r["done"] == "True"]
        assert [r["episode_status"] for r in ends] == ["lap_complete"] * 3
        # Every training episode restarts its numbering at the prepare row's 1.0.
        for episode in ("0", "1", "2"):
            steps = [float(r["steps"]) for r in it0 + it1 if r["episode"] == episode]
            assert steps == [float(k) for k in range(1, len(steps) + 1)]
        assert [float(r["progress"]) for r in ends] == [100.0] * 3
        # The clock runs on across episodes: episode 2 ends at the sum of the three durations.
        assert float(ends[-1]["tstamp"]) == pytest.approx(sum(durations), abs=1e-9)
        metrics = json.loads((tmp_path / "car_0" / "metrics" / "TrainingMetrics.json")
                             .read_text())["metrics"]
        assert [m["trial"] for m in metrics] == [1, 2, 1]
        assert [m["episode"] for m in metrics] == [1, 2, 3]
        assert [m["episode_status"] for m in metrics] == ["Lap complete"] * 3
        assert [m["elapsed_time_in_milliseconds"] for m in metrics] == [
            round(1000 * d) for d in durations]

    def test_race_writes_one_trial_per_lap(self, tmp_path: Path) -> None:
        result = run_race("oval", ["racing_line", "pure_pursuit"], laps=2, seed=1,
                          simtrace=tmp_path)
        assert result.simtrace == (str(tmp_path / "car_0"), str(tmp_path / "car_1"))
        for car, name in enumerate(("car_0", "car_1")):
            (csv_path,) = (tmp_path / name).glob("evaluation-*/evaluation-simtrace/"
                                                 "0-iteration.csv")
            _, rows = read_rows(csv_path)
            ends = [r for r in rows if r["done"] == "True"]
            assert [r["episode_status"] for r in ends] == ["lap_complete"] * 2
            assert [r["episode"] for r in ends] == ["0", "1"]
            # As in DRfC's continuous evaluations, steps run on across the trials: one
            # prepare row (1.0) at the start, then 2.0, 3.0, ... through both laps.
            assert [r["episode_status"] for r in rows].count("prepare") == 1
            assert [float(r["steps"]) for r in rows] == [float(k)
                                                         for k in range(1, len(rows) + 1)]
            (metrics_path,) = (tmp_path / name / "metrics").glob("EvaluationMetrics-*.json")
            metrics = json.loads(metrics_path.read_text())["metrics"]
            assert [m["trial"] for m in metrics] == [1, 2]
            assert set(metrics[0]) == {
                "completion_percentage", "metric_time", "start_time",
                "elapsed_time_in_milliseconds", "episode_status", "crash_count",
                "immobilized_count", "off_track_count", "reversed_count", "reset_count",
                "trial"}
            # The second trial is the second lap. It runs from the end of the step that
            # crossed the line to the end of the step that crossed it again; each of those
            # is within one step (66.7 ms) after its crossing, so the trial and the lap time
            # (crossing to crossing) differ by less than a step (+1 ms for the rounding).
            row = next(r for r in result.rows if r["agent"] == name)
            lap2 = 1000 * row["lap_times"][1]
            assert abs(metrics[1]["elapsed_time_in_milliseconds"] - lap2) < 1000 * DT + 1
        assert result.rewards is None

    def test_bad_arguments_are_clear_errors(self, tmp_path: Path) -> None:
        config = EnvConfig(track="oval", num_cars=2)
        track = circle_track()
        with pytest.raises(ValueError, match="phase must be"):
            SimtraceWriter(tmp_path, config, track, phase="racing")  # type: ignore[arg-type]
        with pytest.raises(ValueError, match="at most 10 env copies"):
            SimtraceWriter(tmp_path, config, track, envs=range(11))
        with pytest.raises(ValueError, match="at most 1 env copies"):
            SimtraceWriter(tmp_path, config, track, envs=(0, 1), phase="evaluation")
        with pytest.raises(ValueError, match=r"cars must list distinct car indices in \[0, 1\]"):
            SimtraceWriter(tmp_path, config, track, cars=(2,))


class TestDeepracerUtils:
    """deepracer-utils (pip install -e '.[logs]') loads our logs and aggregates episodes."""

    def test_training_trace_aggregates_match_the_core(self, tmp_path: Path) -> None:
        logs = pytest.importorskip("deepracer.logs")
        track = circle_track()
        path = tmp_path / "circle.json"
        save_track(track, path)
        env = h2h_racing.parallel_env(track=str(path), num_cars=1, race_type="time_trial",
                                      rules="training")
        driver = make_driver("pure_pursuit")
        writer = SimtraceWriter(tmp_path / "logs", env.config, env.track,
                                episodes_per_iteration=2)
        expected = []  # (steps, time, lap complete, total reward) per episode, from the core
        for episode in range(4):
            env.reset(seed=episode)
            driver.reset(env.core)
            writer.start(env.core)
            total = 0.0
            steps = 0
            while env.agents:
                action = driver.act(env.core, 0)[0]
                if episode == 1 and steps >= 20:
                    action = np.array([1.0, 1.0])  # full left lock: off track
                racing = env.core.racing
                _, reward, *_ = env.step({"car_0": action})
                total += reward["car_0"]
                steps += 1
                writer.log_step(env.core, env.last_events, racing,
                                reward=np.array([[reward["car_0"]]]))
            expected.append((steps, float(env.core.time[0]), int(env.core.laps[0, 0]), total))
        writer.close()
        assert [e[2] for e in expected] == [1, 0, 1, 1]
        log = logs.DeepRacerLog(str(tmp_path / "logs" / "car_0"))
        log.load_training_trace()
        df = log.dataframe()
        agg = logs.AnalysisUtils.simulation_agg(df, "iteration", "unique_episode")
        agg = agg.sort_values("unique_episode").reset_index(drop=True)
        assert len(agg) == 4
        for k, (steps, duration, laps, total) in enumerate(expected):
            # deepracer-utils counts rows (the prepare row + one per step) and sums the
            # tstamp steps after the prepare row: the episode's simulated duration.
            assert agg.loc[k, "steps"] == steps + 1
            assert agg.loc[k, "time"] == pytest.approx(duration, abs=1e-9)
            assert agg.loc[k, "complete"] == laps
            assert agg.loc[k, "reward"] == pytest.approx(total, abs=1e-9)
            if laps:
                assert agg.loc[k, "progress"] == 100.0
        assert 0.0 < agg.loc[1, "progress"] < 100.0
        metrics = logs.TrainingMetrics(
            None, fname=str(tmp_path / "logs" / "car_0" / "metrics" / "TrainingMetrics.json"))
        training = metrics.getTraining()
        assert training["complete"].tolist() == [1, 0, 1, 1]
        assert training["time"].tolist() == pytest.approx([e[1] for e in expected], abs=1e-3)
        assert training["iteration"].tolist() == [0, 0, 1, 1]

    def test_race_evaluation_trace_loads(self, tmp_path: Path) -> None:
        logs = pytest.importorskip("deepracer.logs")
        result = run_race("oval", ["racing_line", "pure_pursuit"], laps=2, seed=1,
                          simtrace=tmp_path)
        for folder in result.simtrace:
            log = logs.DeepRacerLog(folder)
            log.load_evaluation_trace()
            agg = logs.AnalysisUtils.simulation_agg(log.dataframe(), "stream", "episode",
                                                    is_eval=True)
            assert agg["complete"].tolist() == [1, 1]
            assert agg["progress"].tolist() == [100.0, 100.0]
            # The whole race: the trials' times add up to the time of the last lap row.
            row = next(r for r in result.rows if str(Path(folder).name) == r["agent"])
            assert agg["time"].sum() == pytest.approx(row["total_time"], abs=DT + 1e-9)



# (episode, steps, episode_status) of rows of deepracer-utils' own DRfC sample simtraces
# (aws-deepracer-community/deepracer-utils, tests/deepracer/logs/sample-drfc-1-logs/),
# transcribed: the first two rows of episodes 0 and 1 of training-simtrace/0-iteration.csv,
# and the rows around the end of the first lap of the continuous evaluation
# evaluation-20220709200242/evaluation-simtrace/0-iteration.csv.
DRFC_TRAINING_ROWS = [(0, 1.0, "prepare"), (0, 2.0, "in_progress"),
                      (1, 1.0, "prepare"), (1, 2.0, "in_progress")]
DRFC_EVALUATION_ROWS = [(0, 1.0, "prepare"), (0, 2.0, "in_progress"),
                        (0, 222.0, "in_progress"), (1, 223.0, "in_progress")]


class TestDrfcStepNumbering:
    """``steps`` is numbered as in the DRfC simtraces deepracer-utils ships as samples."""

    def test_training_episodes_number_like_drfc(self, tmp_path: Path) -> None:
        env = h2h_racing.parallel_env(track=circle_track(), num_cars=1,
                                      race_type="time_trial", rules="training")
        writer = SimtraceWriter(tmp_path, env.config, env.track)
        for episode in range(2):
            env.reset(seed=episode)
            writer.start(env.core)
            for _ in range(5):
                racing = env.core.racing
                env.step({"car_0": np.array([0.0, 0.0], dtype=np.float32)})
                writer.log_step(env.core, env.last_events, racing)
            # Cut the episode short: the next start() ends it.
        writer.close()
        _, rows = read_rows(tmp_path / "car_0" / "training-simtrace" / "0-iteration.csv")
        ours = [(int(r["episode"]), float(r["steps"]), r["episode_status"]) for r in rows]
        firsts = [row for k, row in enumerate(ours) if k == 0 or row[0] != ours[k - 1][0]]
        seconds = [ours[ours.index(f) + 1] for f in firsts]
        drfc = sorted(DRFC_TRAINING_ROWS)
        assert sorted(firsts + seconds) == drfc

    def test_race_trials_number_like_a_drfc_continuous_evaluation(self, tmp_path: Path
                                                                    ) -> None:
        run_race("oval", ["pure_pursuit"], race_type="time_trial", laps=2, seed=0,
                 simtrace=tmp_path)
        (csv_path,) = (tmp_path / "car_0").glob("evaluation-*/evaluation-simtrace/"
                                                "0-iteration.csv")
        _, rows = read_rows(csv_path)
        ours = [(int(r["episode"]), float(r["steps"]), r["episode_status"]) for r in rows]
        # The first two rows, and the last row of trial 0 with the first of trial 1.
        turn = next(k for k, row in enumerate(ours) if row[0] == 1)
        picked = [ours[0], ours[1], ours[turn - 1], ours[turn]]
        shape = [(e, s if k < 2 else s - picked[2][1], st) for k, (e, s, st) in enumerate(picked)]
        drfc = [(e, s if k < 2 else s - DRFC_EVALUATION_ROWS[2][1], st)
                for k, (e, s, st) in enumerate(DRFC_EVALUATION_ROWS)]
        # The lap rows differ only in status: ours marks the lap (lap_complete, as the
        # newer simapp does), the 2022 sample leaves it in_progress at progress 100.
        assert [row[:2] for row in shape] == [row[:2] for row in drfc]
        assert [row[2] for row in shape][:2] == [row[2] for row in drfc][:2]
        assert shape[3][2] == drfc[3][2] == "in_progress"
