"""The h2h-racing command line, run in-process through ``h2h_racing.cli.command.main``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from h2h_racing.cli.command import main
from h2h_racing.track.io import list_tracks, load_track


class TestTracksCommands:
    """``h2h-racing tracks list | show | import``."""

    def test_list_names_every_catalogue_track(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["tracks", "list"]) == 0
        out = capsys.readouterr().out
        for name in list_tracks():
            assert name in out

    def test_tracks_prints_the_reference_lap(self, capsys: pytest.CaptureFixture[str]) -> None:
        from h2h_racing.policies.lap_times import track_laps

        assert main(["tracks"]) == 0  # 'tracks' alone lists, as 'tracks list' does
        out = capsys.readouterr().out
        assert out.splitlines()[0].split()[:9] == ["track", "lap", "m", "width", "m",
                                                   "reference", "s", "racing_line", "s"]
        rows = {line.split()[0]: line.split() for line in out.splitlines()[1:]}
        for name in list_tracks():
            laps = track_laps(load_track(name))
            reference, profile = float(rows[name][3]), float(rows[name][4])
            assert (reference, profile) == (round(laps.reference, 2), round(laps.racing_line, 2))
            # Full grip on the same path is faster than racing_line's own profile.
            assert reference < profile
        assert "an estimate: a point mass on the racing line's path" in out

    def test_tracks_of_a_folder_and_a_file(self, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
        from h2h_racing.track.io import save_track

        folder = tmp_path / "mine"
        folder.mkdir()
        save_track(load_track("technical"), folder / "tech.json")
        (folder / "notes.txt").write_text("not a track")
        assert main(["tracks", "list", "--track", f"oval,{folder}"]) == 0
        rows = [line.split() for line in capsys.readouterr().out.splitlines()[1:3]]
        assert [row[0] for row in rows] == ["oval", "technical"]
        assert rows[1][1:3] == ["20.00", "0.76-0.76"]
        empty = tmp_path / "empty"
        empty.mkdir()
        assert main(["tracks", "--track", str(empty)]) == 2
        assert "holds no .json, .npy or .csv track file" in capsys.readouterr().err

    def test_show_writes_a_png_of_the_track(self, tmp_path: Path) -> None:
        out = tmp_path / "oval.png"
        assert main(["tracks", "show", "oval", "--out", str(out), "--width", "300"]) == 0
        image = cv2.imread(str(out))
        assert image is not None and image.shape[1] == 300
        # The preview is not blank: it has the floor, the grey surface and white borders.
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 3

    def test_import_csv_round_trips_through_the_json_format(self, tmp_path: Path) -> None:
        # A circle of radius 3 m sampled every 10 degrees, 0.4 m wide on each side.
        angle = np.radians(np.arange(0, 360, 10))
        rows = np.stack([3 * np.cos(angle), 3 * np.sin(angle), np.full(36, 0.4),
                         np.full(36, 0.4)], axis=1)
        csv = tmp_path / "ring.csv"
        np.savetxt(csv, rows, delimiter=",", header="x_m,y_m,w_tr_right_m,w_tr_left_m")
        out = tmp_path / "ring.json"
        assert main(["tracks", "import", str(csv), "--name", "ring", "--out", str(out)]) == 0
        data = json.loads(out.read_text())
        assert data["name"] == "ring" and len(data["x"]) == 36
        track = load_track(out)
        # Perimeter of the 36-gon inscribed in a 3 m circle: 36 * 2 * 3 * sin(5 deg) = 18.83 m.
        assert track.length == pytest.approx(36 * 6 * np.sin(np.radians(5)), rel=1e-6)

    def test_bad_file_is_a_clear_error_not_a_traceback(
            self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        bad = tmp_path / "bad.csv"
        bad.write_text("1,2,0.5,0.5\n3,4,0.5,0.5\n")
        assert main(["tracks", "import", str(bad)]) == 2
        err = capsys.readouterr().err
        assert "bad.csv" in err


class TestRaceCommand:
    """``h2h-racing race`` prints a results table."""

    def test_race_prints_both_drivers_and_a_winner(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--track", "oval", "--laps", "1"]) == 0
        out = capsys.readouterr().out
        assert "racing_line" in out and "pure_pursuit" in out
        lines = [line for line in out.splitlines() if line.strip().startswith(("1 ", "2 "))]
        assert len(lines) == 2

    def test_head_to_bot_lists_only_the_cars(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--track", "oval", "--laps", "1", "--race-type", "head_to_bot",
                     "--bots", "2", "--bot-speed", "0.5"]) == 0
        out = capsys.readouterr().out
        rows = [line for line in out.splitlines() if line[:3].strip().isdigit()]
        assert len(rows) == 2 and "car_0" in out and "car_1" in out and "bot" not in rows[0]
        assert "2 bot cars at 0.5 m/s" in out

    def test_bad_bot_count_is_reported(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--track", "oval", "--race-type", "head_to_bot", "--bots",
                     "40"]) == 2
        assert "num_bots" in capsys.readouterr().err

    def test_unknown_driver_is_reported(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--track", "oval", "--drivers", "racing_line,nobody"]) == 2
        assert "nobody" in capsys.readouterr().err

    def test_drivers_take_settings(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--track", "oval", "--laps", "1", "--drivers",
                     "racing_line:grip_factor=0.7,pure_pursuit:cruise_speed=2"]) == 0
        out = capsys.readouterr().out
        # Each car is shown by its driver's spec: which pace raced.
        assert "car_0 (racing_line:grip_factor=0.7)" in out
        assert "car_1 (pure_pursuit:cruise_speed=2)" in out
        assert main(["race", "--track", "oval", "--drivers",
                     "racing_line:grip_factor=1.5,pure_pursuit"]) == 2
        err = capsys.readouterr().err
        assert err == ("h2h-racing: error: racing_line: grip_factor must be a number in (0, 1], "
                       "got '1.5'\n")

    def test_video_is_written(self, tmp_path: Path) -> None:
        video = tmp_path / "race.mp4"
        assert main(["race", "--track", "oval", "--laps", "1", "--video", str(video)]) == 0
        capture = cv2.VideoCapture(str(video))
        frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        capture.release()
        # One frame per step plus the start frame; a 1-lap race on the 20 m oval takes > 5 s.
        assert frames > 5 * 15

    def test_simtrace_and_deepracer_reward(self, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
        # A reward function that pays 1 per step: each car's total is its number of rated
        # steps, and every simtrace row after the prepare row carries reward 1.
        reward = tmp_path / "reward.py"
        reward.write_text("def reward_function(params):\n    return 1\n")
        out = tmp_path / "logs"
        assert main(["race", "--track", "oval", "--laps", "1", "--simtrace", str(out),
                     "--reward-function", str(reward), "--no-progress"]) == 0
        text = capsys.readouterr().out
        assert "total DeepRacer reward" in text and f"simtrace -> {out / 'car_0'}" in text
        for car in ("car_0", "car_1"):
            (trace,) = (out / car).glob("evaluation-*/evaluation-simtrace/0-iteration.csv")
            lines = trace.read_text().splitlines()
            assert lines[0].startswith("episode,steps,X,Y,yaw,steer,throttle,action,reward")
            rewards = [float(line.split(",")[8]) for line in lines[2:]]
            assert rewards == [1.0] * len(rewards)
            # "car_0 (racing_line) 123.00": the total equals the number of step rows.
            line = next(t for t in text.splitlines() if t.startswith("total DeepRacer"))
            total = float(re.search(rf"{car} \(\w+\) ([0-9.]+)", line).group(1))
            assert total == len(rewards)

    def test_simtrace_needs_a_single_track(self, tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["race", "--track", "all", "--simtrace", str(tmp_path)]) == 2
        assert "--simtrace records one race" in capsys.readouterr().err


class TestCameraCommand:
    """``h2h-racing camera`` saves what a car's camera sees."""

    def test_camera_png_is_written_and_scaled(self, tmp_path: Path) -> None:
        out = tmp_path / "cam.png"
        assert main(["camera", "--track", "oval", "--steps", "5", "--scale", "2",
                     "--out", str(out)]) == 0
        image = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
        # The default camera is 160 x 120; scale 2 gives 320 x 240.
        assert image.shape == (240, 320)
        # Sky above the horizon is lighter than the track surface below it.
        assert image[:20].mean() > image[-20:].mean()

    def test_car_index_out_of_range(self, capsys: pytest.CaptureFixture[str]) -> None:
        assert main(["camera", "--track", "oval", "--car", "5"]) == 2
        assert "--car" in capsys.readouterr().err
