"""Evaluation of a driver over lap attempts from evenly spread start points."""

from __future__ import annotations

import numpy as np

from h2h_racing.training.evaluate import Evaluation, evaluate


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
        from h2h_racing.training.evaluate import head_to_head

        result = head_to_head("racing_line", "pure_pursuit", "oval", races=4, laps=1)
        # ~6 s against ~8.7 s a lap (policies/README): a sure win from either slot.
        assert result.wins == (4, 0) and result.finished == (4, 4)
        assert "racing_line won 4" in result.summary()

    def test_races_must_pair_the_seat_orders(self) -> None:
        import pytest

        from h2h_racing.training.evaluate import head_to_head

        with pytest.raises(ValueError, match="even"):
            head_to_head("racing_line", "pure_pursuit", "oval", races=3)


class TestGridProtocols:
    """``head_to_head(start=..., gap=...)``: results by grid slot, the from-behind protocol."""

    def test_grid_slots_by_protocol(self) -> None:
        import pytest

        from h2h_racing.training.evaluate import grid_slots

        # Columns: A's slot, B's slot; slot 1 is the one behind.
        assert grid_slots(4, "both").tolist() == [[0, 1], [1, 0], [0, 1], [1, 0]]
        assert grid_slots(3, "behind").tolist() == [[1, 0]] * 3
        assert grid_slots(2, "front").tolist() == [[0, 1]] * 2
        with pytest.raises(ValueError, match="start must be one of both, behind, front"):
            grid_slots(2, "side")
        with pytest.raises(ValueError, match="at least 1"):
            grid_slots(0, "behind")

    def test_the_faster_car_wins_from_behind_by_passing(self) -> None:
        from h2h_racing.training.evaluate import head_to_head

        # ~6 s against ~8.7 s a lap of the oval (policies/README): from 0.75 m behind the
        # racing line must pass pure pursuit once in each race, and wins them all.
        result = head_to_head("racing_line", "pure_pursuit", "oval", races=2, laps=1,
                              start="behind")
        assert (result.races_behind, result.wins_behind) == (2, 2)
        assert (result.races_front, result.wins_front) == (0, 0)
        assert result.overtakes[0] >= 2 and result.overtakes[1] == 0
        assert "won 2/2 from behind and 0/0 from the front" in result.summary()

    def test_the_slower_car_loses_from_the_front(self) -> None:
        from h2h_racing.training.evaluate import head_to_head

        result = head_to_head("pure_pursuit", "racing_line", "oval", races=2, laps=1,
                              start="front")
        assert (result.races_front, result.wins_front, result.wins) == (2, 0, (0, 2))
        assert result.overtakes[1] >= 2

    def test_both_splits_the_wins_by_slot(self) -> None:
        from h2h_racing.training.evaluate import head_to_head

        result = head_to_head("racing_line", "pure_pursuit", "oval", races=4, laps=1)
        assert (result.races_behind, result.races_front) == (2, 2)
        assert result.wins_behind + result.wins_front == result.wins[0] == 4

    def test_gap_sets_how_far_behind_the_driver_starts(self) -> None:
        from h2h_racing.policies import make_driver
        from h2h_racing.training.evaluate import head_to_head

        class Spy:
            """The racing line, noting the cars' race distances at the start."""

            name = "spy"

            def __init__(self) -> None:
                self.inner = make_driver("racing_line")
                self.start = np.zeros(0)

            def reset(self, core) -> None:
                self.start = core.distance.copy()
                self.inner.reset(core)

            def act(self, core, car):
                return self.inner.act(core, car)

        spy = Spy()
        head_to_head(spy, "pure_pursuit", "oval", races=2, laps=1, start="behind", gap=2.5)
        # Slot 1 starts 2.5 m of track behind slot 0: A's distance minus B's is -2.5.
        assert np.allclose(spy.start[:, 0] - spy.start[:, 1], -2.5)

    def test_gap_must_fit_the_track(self) -> None:
        import pytest

        from h2h_racing.training.evaluate import head_to_head

        for gap in (0.0, -1.0, 1e6, float("nan")):
            with pytest.raises(ValueError, match="gap must be a distance"):
                head_to_head("racing_line", "pure_pursuit", "oval", races=2, gap=gap)

    def test_combine_sums_tracks(self) -> None:
        from h2h_racing.training.evaluate import HeadToHead, combine

        one = HeadToHead(drivers=("a", "b"), track="oval", races=4, wins=(3, 1),
                         overtakes=(2, 1), crashes=(1, 0), finished=(4, 4), races_behind=2,
                         wins_behind=1, races_front=2, wins_front=2, defences=(0, 1))
        two = HeadToHead(drivers=("a", "b"), track="speedway", races=2, wins=(0, 2),
                         overtakes=(0, 3), crashes=(2, 2), finished=(1, 2), races_behind=1,
                         wins_behind=0, races_front=1, wins_front=0, defences=(1, 1))
        total = combine([one, two])
        assert total.track == "all" and total.races == 6 and total.wins == (3, 3)
        assert (total.races_behind, total.wins_behind, total.races_front,
                total.wins_front) == (3, 1, 3, 2)
        assert total.overtakes == (2, 4) and total.crashes == (3, 2)
        assert total.defences == (1, 2) and total.finished == (5, 6)
        assert total.per_race(total.crashes) == 0.5
        # Time-trial laps unmeasured: NaN, and no margin.
        assert np.isnan(total.time_trial_laps).all() and np.isnan(total.pace_margin)


class TestPaceMargin:
    """Each driver's time-trial lap and the margin between two, by hand."""

    def test_margin_by_hand(self) -> None:
        from h2h_racing.training.evaluate import HeadToHead, combine, pace_margin

        # 6 s against 8 s: (8 - 6) / 8 = 25 % faster; 8 s against 6 s: (6 - 8) / 6 = -33.3 %.
        assert pace_margin(6.0, 8.0) == 25.0
        assert round(pace_margin(8.0, 6.0), 4) == -33.3333
        assert np.isnan(pace_margin(float("inf"), 8.0)) and np.isnan(pace_margin(6.0, np.nan))
        common = dict(drivers=("a", "b"), races=2, wins=(1, 1), overtakes=(0, 0),
                      crashes=(0, 0), finished=(2, 2))
        one = HeadToHead(track="oval", time_trial_laps=(6.0, 8.0), **common)
        two = HeadToHead(track="kidney", time_trial_laps=(9.0, 8.0), **common)
        # Over both tracks: 15 s against 16 s, (16 - 15) / 16 = 6.25 %.
        total = combine([one, two])
        assert total.time_trial_laps == (15.0, 16.0) and total.pace_margin == 6.25

    def test_time_trial_lap_is_the_mean_of_four_attempts(self) -> None:
        from h2h_racing.training.evaluate import time_trial_lap

        lap = time_trial_lap("racing_line", "oval")
        assert lap == evaluate("racing_line", "oval", episodes=4).mean_lap_time
        # The racing line laps the oval in about 6.1 s from a standing start (policies/README);
        # its profile's flying lap, 5.15 s, bounds it from below.
        assert 5.15 < lap < 6.6
        # More grip, a faster lap.
        assert time_trial_lap("racing_line:grip_factor=0.7", "oval") < lap


class TestStartPoints:
    """RaceCore.reset(start=...) moves the race's start and finish line."""

    def test_race_laps_count_from_the_start_point(self) -> None:
        from h2h_racing.config.env import EnvConfig, RaceRules
        from h2h_racing.sim.core import RaceCore
        from h2h_racing.track.io import load_track

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
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "2", "--laps", "1"]) == 0
        lines = capsys.readouterr().out.splitlines()
        rows = [line for line in lines if line.split()[:2] == ["oval", "pure_pursuit"]]
        total = [line for line in lines if line.split()[:2] == ["all", "pure_pursuit"]]
        assert len(rows) == 1 and len(total) == 1
        # The racing line laps the oval in ~6 s against pure pursuit's ~8.7 s (policies/README):
        # it wins both races, one from each grid slot, and the total repeats the single track.
        assert rows[0].split()[2:11] == ["2", "/", "2", "1", "/", "1", "1", "/", "1"]
        assert "(100 % won)" in total[0]

    def test_from_behind_rows(self, capsys) -> None:
        from h2h_racing.cli.command import main

        # --start behind takes an odd race count: there are no seat-order pairs to keep.
        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "1", "--laps", "1", "--start", "behind",
                     "--gap", "2"]) == 0
        out = capsys.readouterr().out
        row = next(line for line in out.splitlines() if line.startswith("oval"))
        # Won 1 of 1, 1 of 1 from behind, none from the front, and it had to pass to win.
        assert row.split()[2:9] == ["1", "/", "1", "1", "/", "1", "-"]
        assert float(row.split()[13]) >= 1.0  # passes per race, after lap s and margin %
        assert "the policy starts behind, 2 m grid gap" in out

    def test_bad_gap_is_refused(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "2", "--gap", "-1"]) == 2
        assert "gap must be a distance in (0, " in capsys.readouterr().err

    def test_odd_race_count_is_refused(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against", "pure_pursuit",
                     "--track", "oval", "--races", "3"]) == 2
        assert "--races must be an even number" in capsys.readouterr().err

    def test_pace_margin_beside_the_results(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against",
                     "pure_pursuit,racing_line:grip_factor=0.7", "--track", "oval", "--races",
                     "2", "--laps", "1"]) == 0
        lines = capsys.readouterr().out.splitlines()
        header = next(line for line in lines if line.startswith("track"))
        assert header.split()[5:10] == ["from", "front", "lap", "s", "margin"]
        rows = {line.split()[1]: line.split() for line in lines if line.startswith("oval")}
        slow = rows["pure_pursuit"]
        # track, opponent, won, from behind, from front (3 tokens each), then lap s (A / B).
        mine, theirs, margin = float(slow[11]), float(slow[13]), float(slow[14])
        # Racing line ~6.1 s against pure pursuit's ~8.7 s a lap of the oval (policies/README):
        # about 30 % faster, and the margin is the printed laps' (to the rounding of 0.01 s).
        assert 5.15 < mine < 6.6 and 8.0 < theirs < 9.5
        assert abs(margin - 100 * (theirs - mine) / theirs) < 0.2 and margin > 20
        # The same driver at 0.7 of the grip is faster: a negative margin, and the name of the
        # driver with its setting in the row.
        paced = rows["racing_line:grip_factor=0.7"]
        assert float(paced[13]) < float(paced[11]) and float(paced[14]) < 0
        total = next(line for line in lines if line.split()[:2] == ["all", "pure_pursuit"])
        assert total.split()[11:15] == slow[11:15]  # one track: the total repeats it

    def test_bad_settings_are_refused_in_one_line(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--against",
                     "racing_line:grp=0.7", "--track", "oval", "--races", "2"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: racing_line: unknown setting 'grp'; its settings are "
                              "grip_factor, margin,") and err.count("\n") == 1
        assert main(["evaluate", "--policy", "league_racer:grip_factor=0.7", "--against",
                     "racing_line", "--track", "oval", "--races", "2"]) == 2
        assert "league_racer: a trained policy takes no settings" in capsys.readouterr().err
