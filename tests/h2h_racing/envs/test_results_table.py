"""The results table (time trials, long names), race videos and evaluation labels."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from h2h_racing.config.env import RaceRules
from h2h_racing.envs.results import format_results, race_results

INF = math.inf


def _core(rules: RaceRules, finished: list[bool], finish_time: list[float],
          lap_times: list[list[float]]) -> SimpleNamespace:
    n = len(finished)
    laps = [len(t) for t in lap_times]
    best = [min(t) if t else INF for t in lap_times]
    return SimpleNamespace(
        distance=np.array([[30.0 * k + 1 for k in laps]]), finished=np.array([finished]),
        finish_time=np.array([finish_time]), best_lap_time=np.array([best]),
        laps=np.array([laps]), lap_times=[lap_times], resets=np.zeros((1, n), int),
        penalties=np.zeros((1, n), int), penalty_time=np.zeros((1, n)),
        off_tracks=np.zeros((1, n), int), crashes=np.zeros((1, n), int),
        collisions=np.zeros((1, n), int), overtakes=np.zeros((1, n), int),
        defences=np.zeros((1, n), int), rules=rules)


def test_a_time_trial_totals_the_laps_driven() -> None:
    # A time trial has no lap target: nobody "finishes", six laps are six laps, not a DNF.
    laps = [6.0, 5.5, 5.5, 5.25, 5.5, 5.75]  # 33.5 s
    core = _core(RaceRules.preset("time_trial"), [False, False], [INF, INF], [laps, []])
    rows = race_results(core, 0, ["car_0", "car_1"])
    assert rows[0]["total_time"] == 33.5 and rows[0]["laps"] == 6
    assert rows[1]["total_time"] == INF  # no lap at all
    text = format_results(rows).splitlines()
    assert " 33.50 " in text[2] and "DNF" not in text[2]
    assert "DNF" in text[3]


def test_a_race_with_a_lap_target_still_shows_dnf() -> None:
    core = _core(RaceRules.preset("head_to_head"), [True, False], [20.0, INF],
                 [[7.0, 6.5, 6.5], [7.5, 7.0]])
    text = format_results(race_results(core, 0, ["car_0", "car_1"])).splitlines()
    assert " 20.00 " in text[2] and "DNF" in text[3]
    assert race_results(core, 0, ["car_0", "car_1"])[1]["total_time"] == INF


def test_long_driver_names_keep_the_columns() -> None:
    core = _core(RaceRules.preset("head_to_head"), [True, True], [20.0, 21.0],
                 [[7.0, 6.5, 6.5], [7.5, 7.0, 6.5]])
    rows = race_results(core, 0, ["car_0", "car_1"])
    long = "runs/a_long_experiment_name/learners/main/latest.pt"
    lines = format_results(rows, {"car_0": long, "car_1": "racing_line"}).splitlines()
    assert len({len(line) for line in lines}) == 1, lines  # every line as wide as the header
    laps_column = lines[0].index("laps") + len("laps") - 1  # right-aligned under its header
    assert lines[2][laps_column] == "3" and lines[3][laps_column] == "3"
    assert f"car_0 ({long})" in lines[2]


@pytest.mark.parametrize("suffix", [".webm", ".mp4"])
def test_race_video_names_its_file_and_codec(tmp_path: Path, suffix: str) -> None:
    import cv2

    from h2h_racing.match import VIDEO_CODECS, run_race

    path = tmp_path / f"race{suffix}"
    result = run_race("oval", ["racing_line"], laps=1, video=path, max_cycles=30)
    assert result.video == str(path)
    fourccs = dict((name, fourcc) for fourcc, name in VIDEO_CODECS[suffix])
    assert result.video_codec in fourccs  # H.264 where OpenCV has it, else the fallback
    capture = cv2.VideoCapture(str(path))
    frames = 0
    while capture.read()[0]:
        frames += 1
    assert frames == result.steps + 1  # the start and one frame per step
    if suffix == ".webm":
        assert result.video_codec == "VP8"  # OpenCV's wheels carry libvpx


def test_race_video_refuses_other_containers(tmp_path: Path) -> None:
    from h2h_racing.match import run_race

    with pytest.raises(ValueError, match=r"must end in one of \.mp4, \.webm"):
        run_race("oval", ["racing_line"], laps=1, video=tmp_path / "race.avi")


def test_cli_says_where_the_video_went(tmp_path: Path, capsys) -> None:
    from h2h_racing.cli.command import main

    path = tmp_path / "race.webm"
    assert main(["race", "--track", "oval", "--drivers", "racing_line", "--race-type",
                 "time_trial", "--laps", "1", "--video", str(path)]) == 0
    assert f"video -> {path.resolve()} (VP8)" in capsys.readouterr().out


def test_a_policy_file_is_labelled_by_its_path_not_its_folder() -> None:
    pytest.importorskip("torch")
    from h2h_racing.training.evaluate import Evaluation
    from h2h_racing.policies.trained import TrainedPolicy, shipped_policies

    path = shipped_policies()["ppo_generalist"]
    assert TrainedPolicy(path).name == str(path)  # not "ppo_generalist"'s folder alone
    assert TrainedPolicy(path, name="mine").name == "mine"
    row = Evaluation(driver=str(path), track="oval", episodes=1, lap_completion=1.0,
                     mean_lap_time=8.5,
                     best_lap_time=8.4, off_tracks=0, collisions=0)
    width = len(str(path))
    assert len(row.row(width)) == len(Evaluation.header(width))


def test_the_race_progress_bar_ends_on_the_final_state() -> None:
    # The bar redraws at most ten times a second: a fast race can end between two redraws,
    # and the bar used to stay at the last one (46-61 % in the runs).
    import io

    from h2h_racing.envs.parallel import RacingEnv
    from h2h_racing.match import ProgressBar
    from h2h_racing.policies import make_driver

    env = RacingEnv(track="oval", num_cars=1,
                    rules=dataclasses.replace(RaceRules.preset("head_to_head"), laps=1))
    env.reset(seed=0)
    driver = make_driver("racing_line")
    driver.reset(env.core)
    stream = io.StringIO()
    bar = ProgressBar(env, delay=0.0, stream=stream)
    bar.update()
    assert "race   0%" in stream.getvalue()
    while env.agents:  # no redraws while the race runs
        env.step({"car_0": driver.act(env.core, 0)[0]})
    bar.close()
    last = stream.getvalue().splitlines()[-1]
    assert last.startswith("race 100% |" + "#" * ProgressBar.WIDTH + "|"), last
