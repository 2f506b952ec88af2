"""Evaluation of a driver over lap attempts from evenly spread start points."""

from __future__ import annotations

import numpy as np

from h2h_racing.league.evaluate import Evaluation, evaluate


class TestEvaluate:
    """Scripted drivers give the figures their lap-time table predicts."""

    def test_racing_line_beats_pure_pursuit_from_every_start(self) -> None:
        fast = evaluate("racing_line", "oval", episodes=4)
        slow = evaluate("pure_pursuit", "oval", episodes=4)
        assert fast.episodes == 4 and fast.lap_completion == 1.0
        assert slow.lap_completion == 1.0
        # Racing line ~6 s vs pure pursuit ~8.7 s per lap of the 20 m oval (policies/README).
        assert fast.mean_lap_time < 0.85 * slow.mean_lap_time
        assert fast.best_lap_time <= fast.mean_lap_time

    def test_a_driver_that_leaves_the_track_completes_nothing(self) -> None:
        class FullLeft:
            name = "full_left"

            def reset(self, core: object) -> None:
                pass

            def act(self, core: object, car: int) -> np.ndarray:
                return np.tile(np.array([[1.0, 1.0]], np.float32), (core.num_envs, 1))

        result = evaluate(FullLeft(), "oval", episodes=3)
        assert result.lap_completion == 0.0 and result.off_tracks == 3
        assert result.mean_lap_time == float("inf")
        assert "full_left" in result.row() and "0.0 %" in result.row()
        assert Evaluation.header().split()[0] == "driver"


class TestHeadToHead:
    """Two-car races in both seat orders from random starts."""

    def test_racing_line_beats_pure_pursuit(self) -> None:
        from h2h_racing.league.evaluate import head_to_head

        result = head_to_head("racing_line", "pure_pursuit", "oval", races=4, laps=1)
        # ~6 s against ~8.7 s a lap (policies/README): a sure win from either slot.
        assert result.wins == (4, 0) and result.finished == (4, 4)
        assert "racing_line won 4" in result.summary()

    def test_races_must_pair_the_seat_orders(self) -> None:
        import pytest

        from h2h_racing.league.evaluate import head_to_head

        with pytest.raises(ValueError, match="even"):
            head_to_head("racing_line", "pure_pursuit", "oval", races=3)


class TestStartPoints:
    """RaceCore.reset(start=...) moves the race's start and finish line."""

    def test_race_laps_count_from_the_start_point(self) -> None:
        from h2h_racing.config import EnvConfig, RaceRules
        from h2h_racing.core import RaceCore
        from h2h_racing.track_io import load_track

        track = load_track("oval")
        core = RaceCore(EnvConfig(track="oval", num_cars=1, rules=RaceRules(laps=1)), track)
        core.reset(seed=0, start=np.array([5.0]))
        # The car sits 5 m round the lap; its lap ends when it is back there, after L metres.
        assert core.distance[0, 0] == 5.0 and core.lap_origin[0, 0] == 5.0
        start_xy = track.point_at(np.array([5.0]))[0]
        assert np.allclose(core.position[0, 0], start_xy)


class TestEvaluateCli:
    """``h2h-racing evaluate --against``: head-to-head rows per track and opponent."""

    def test_rows_and_totals(self, capsys) -> None:
        from h2h_racing.cli import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "2", "--laps", "1"]) == 0
        lines = capsys.readouterr().out.splitlines()
        rows = [line for line in lines if line.split()[:2] == ["oval", "pure_pursuit"]]
        total = [line for line in lines if line.split()[:2] == ["all", "pure_pursuit"]]
        assert len(rows) == 1 and len(total) == 1
        # The racing line laps the oval in ~6 s against pure pursuit's ~8.7 s (policies/README):
        # it wins both races, one from each grid slot, and the total repeats the single track.
        assert rows[0].split()[2:5] == ["2", "/", "2"]
        assert "(100 % won)" in total[0]

    def test_odd_race_count_is_refused(self, capsys) -> None:
        from h2h_racing.cli import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "3"]) == 2
        assert "--races must be an even number" in capsys.readouterr().err
