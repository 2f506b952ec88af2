"""Field races (``evaluate --field``): a driver with several opponents, by grid slot."""

from __future__ import annotations

import re

import numpy as np
import pytest

from h2h_racing.training.evaluate_field import (FieldResult, combine_fields, field_race,
                                                field_rotations, field_rows)


class Spy:
    """A scripted driver noting the cars' race distances and speeds at the start."""

    def __init__(self, inner: str) -> None:
        from h2h_racing.policies import make_driver

        self.inner = make_driver(inner)
        self.name = f"spy_{inner}"
        self.distance = self.speed = np.zeros(0)

    def reset(self, core) -> None:
        self.distance, self.speed = core.distance.copy(), core.speed.copy()
        self.inner.reset(core)

    def act(self, core, car):
        return self.inner.act(core, car)


class TestRotations:
    def test_every_start_in_every_rotation(self) -> None:
        # Race r puts car i in slot (i + r) % 3: the driver (car 0) starts from slot r % 3.
        assert field_rotations(6, 3).tolist() == [[0, 1, 2], [1, 2, 0], [2, 0, 1]] * 2
        assert field_rotations(4, 4)[:, 0].tolist() == [0, 1, 2, 3]

    @pytest.mark.parametrize("races", [0, 2, 4, 5])
    def test_races_must_fill_the_rotations(self, races: int) -> None:
        with pytest.raises(ValueError, match="races must be a multiple of the field's 3 cars"):
            field_rotations(races, 3)


class TestFieldRace:
    def test_grid_by_hand(self) -> None:
        spy = Spy("racing_line")
        result = field_race(spy, ["pure_pursuit", "pure_pursuit"], "oval", races=3, laps=1,
                            gap=1.5, rolling=1.0)
        # One start point for the three races; in race r the driver is in slot r, 1.5 r m
        # behind slot 0, and the car in slot k is always 1.5 k m behind it.
        slot0 = spy.distance.max(axis=1)
        assert np.allclose(spy.distance[:, 0] - slot0, [0.0, -1.5, -3.0])
        assert np.allclose(np.sort(spy.distance - slot0[:, None], axis=1), [[-3.0, -1.5, 0.0]])
        assert np.allclose(spy.speed, 1.0)
        assert result.races_by_slot == (1, 1, 1) and (result.gap, result.rolling) == (1.5, 1.0)

    def test_fast_driver_wins_from_the_front_slow_one_stays_last_from_the_back(self) -> None:
        # Racing line ~6 s a lap of the oval, pure pursuit ~8.7 s (policies/README): from the
        # front the racing line is never caught; pure pursuit, from the back behind two racing
        # lines, never passes.
        fast = field_race("racing_line", ["pure_pursuit", "pure_pursuit"], "oval", races=3,
                          laps=1)
        assert fast.wins_by_slot[0] == 1 and fast.places_by_slot[0] == 1
        assert fast.overtakes_by_slot[0] == 0
        slow = field_race("pure_pursuit", ["racing_line", "racing_line"], "oval", races=3,
                          laps=1)
        assert slow.places_by_slot[2] == 3 and slow.wins_by_slot[2] == 0
        # Every race has one winner; the driver finished every race.
        assert sum(slow.wins) == 3 and slow.finished_by_slot == (1, 1, 1)

    def test_a_field_needs_two_opponents(self) -> None:
        with pytest.raises(ValueError, match="at least two opponents"):
            field_race("racing_line", ["pure_pursuit"], "oval", races=2)

    @pytest.mark.parametrize("gap", [0.0, -1.0, 1e6, float("nan")])
    def test_gap_must_fit_the_track(self, gap: float) -> None:
        with pytest.raises(ValueError, match="gap must be a distance"):
            field_race("racing_line", ["pure_pursuit", "blocker"], "oval", races=3, gap=gap)


class TestCombine:
    def test_sums_by_slot(self) -> None:
        def one(track: str, races: tuple[int, ...], places: tuple[int, ...]) -> FieldResult:
            return FieldResult(drivers=("a", "b", "c"), track=track, races=sum(races),
                               races_by_slot=races, places_by_slot=places,
                               wins_by_slot=(1, 0, 0), overtakes_by_slot=(0, 1, 2),
                               crashes_by_slot=(0, 0, 1), finished_by_slot=races,
                               off_tracks_by_slot=(0, 1, 0), wins=(1, 1, 1))

        total = combine_fields([one("oval", (1, 1, 1), (1, 2, 3)),
                                one("speedway", (2, 2, 2), (3, 4, 6))])
        assert total.track == "all" and total.races == 9
        assert total.races_by_slot == (3, 3, 3) and total.places_by_slot == (4, 6, 9)
        # From the last slot: places 3 + 6 over 3 races, 2 + 2 passes, 1 + 1 crashes caused.
        last = total.slot_figures(2)
        assert last["mean_place"] == 3.0 and last["passes_per_race"] == 4 / 3
        assert last["crashes_per_race"] == 2 / 3
        assert total.slot_figures()["mean_place"] == 19 / 9 and total.wins == (2, 2, 2)
        rows = field_rows(total, slots=True)
        assert [row.split()[:4] for row in rows] == [
            ["all", "1", "3", "1.33"], ["all", "2", "3", "2.00"], ["all", "3", "3", "3.00"],
            ["all", "all", "9", "2.11"]]


class TestFieldCli:
    def test_rows_by_slot(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--field",
                     "pure_pursuit,pure_pursuit", "--track", "oval", "--races", "3",
                     "--laps", "1", "--no-progress"]) == 0
        out = capsys.readouterr().out
        assert "3 3-car races of 1 laps per track" in out
        totals = [line.split() for line in out.splitlines() if line.startswith("all ")]
        assert [row[1] for row in totals] == ["1", "2", "3", "all"]
        assert all(row[2] == "1" for row in totals[:3]) and totals[3][2] == "3"
        assert "races won: racing_line " in out
        # Each car's time-trial lap, and the policy's margin over each opponent: racing_line
        # ~6.1 s against pure pursuit's ~8.7 s a lap of the oval (policies/README).
        pace = re.fullmatch(r"lap s on oval: racing_line (\S+); pure_pursuit (\S+) \((\S+) %\)",
                            next(line for line in out.splitlines()
                                 if line.startswith("lap s on oval")))
        assert pace is not None
        mine, theirs, margin = map(float, pace.groups())
        assert 5.15 < mine < 6.6 and 8.0 < theirs < 9.5
        assert abs(margin - 100 * (theirs - mine) / theirs) < 0.2
        assert f"lap s on all tracks: racing_line {pace.group(1)};" in out

    def test_against_and_field_are_exclusive(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--field", "a,b", "--against",
                     "blocker"]) == 2
        assert "not both" in capsys.readouterr().err

    def test_start_does_not_apply(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--field", "blocker,blocker",
                     "--start", "behind"]) == 2
        assert "--field rotates the policy over every grid slot" in capsys.readouterr().err

    def test_races_must_fill_the_rotations(self, capsys) -> None:
        from h2h_racing.cli.command import main

        assert main(["evaluate", "--policy", "racing_line", "--field", "blocker,pure_pursuit",
                     "--track", "oval", "--races", "4", "--no-progress"]) == 2
        assert "races must be a multiple of the field's 3 cars" in capsys.readouterr().err
