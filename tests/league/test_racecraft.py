"""league.racecraft: pairs of legs scored so the grid does not decide, records by grid slot."""

from __future__ import annotations

import io
import math
from pathlib import Path

import pytest

from h2h_racing.league.pfsp import Payoff
from h2h_racing.league.racecraft import (grid_slots, leg_key, pair_result,
                                         paired_races, racecraft_records)
from h2h_racing.league.store import CarResult, LeagueStore, MatchRecord, Player

LEAGUE_DIR = Path(__file__).resolve().parents[2] / "league"
CONTEXT = "league:smoke:eval"


def leg(a: str, b: str, slots: str, race: int, places: tuple[int, int],
        times: tuple[float, float] = (60.0, 61.0), stored_slots: bool = True,
        finished: tuple[bool, bool] = (True, True), overtakes: tuple[int, int] = (0, 0),
        crashes: tuple[int, int] = (0, 0), prefix: str = f"{CONTEXT}:round=0") -> MatchRecord:
    """One race of ``a`` (seat 0) against ``b`` (seat 1) as the league keys it; ``slots``:
    seat 0's then seat 1's grid slot."""
    cars = tuple(CarResult(seat=seat, player=player, position=places[seat],
                           finished=finished[seat], laps=1,
                           total_time=times[seat] if finished[seat] else math.inf,
                           overtakes=overtakes[seat], crashes=crashes[seat],
                           grid_slot=int(slots[seat]) if stored_slots else None)
                 for seat, player in enumerate((a, b)))
    return MatchRecord(key=f"{prefix}:oval:{a},{b}:slots={slots}:race={race}", track="oval",
                       race_type="head_to_head", laps=1, seed=race, cars=cars,
                       context=CONTEXT)


class TestKeysAndSlots:
    def test_leg_key_drops_the_seat_order(self) -> None:
        assert leg_key("t:oval:a,b:slots=10:race=3") == "t:oval:a,b:race=3"
        assert leg_key("t:oval:a,b:slots=01:race=3") == "t:oval:a,b:race=3"
        assert leg_key("t:oval:a,b:n=3") is None

    def test_grid_slots_stored_or_read_from_the_key(self) -> None:
        assert grid_slots(leg("a", "b", "10", 0, (1, 2))) == {"a": 1, "b": 0}
        # A file from before grid_slot was stored: seat i took the key's slot digit i.
        assert grid_slots(leg("a", "b", "10", 0, (1, 2), stored_slots=False)) == \
            {"a": 1, "b": 0}
        old = leg("a", "b", "10", 0, (1, 2), stored_slots=False)
        no_key = MatchRecord(key="t:oval:a,b:n=0", track="oval", race_type="head_to_head",
                             laps=1, seed=0, cars=old.cars)
        assert grid_slots(no_key) is None


class TestPairResult:
    def test_winning_both_legs_wins_the_pair(self) -> None:
        # a passed from behind (leg 1) and held from the front (leg 2).
        assert pair_result(leg("a", "b", "10", 0, (1, 2)), leg("a", "b", "01", 0, (1, 2))) \
            == {"a": 1.0, "b": 2.0}
        assert pair_result(leg("a", "b", "10", 0, (2, 1)), leg("a", "b", "01", 0, (2, 1))) \
            == {"a": 2.0, "b": 1.0}

    def test_a_split_goes_to_the_lower_aggregate_time(self) -> None:
        # Each wins the leg it starts in front. a: 60.0 + 61.0 = 121.0 s; b: 60.5 + 60.8 =
        # 121.3 s: a followed b more closely than b followed a, and wins the pair.
        front_a = leg("a", "b", "01", 0, (1, 2), times=(60.0, 60.5))
        front_b = leg("a", "b", "10", 0, (2, 1), times=(61.0, 60.8))
        assert pair_result(front_a, front_b) == {"a": 1.0, "b": 2.0}
        # a 1.2 s behind b instead: a 60.0 + 62.0 = 122.0 s, b 121.3 s -> b.
        slow_follow = leg("a", "b", "10", 0, (2, 1), times=(62.0, 60.8))
        assert pair_result(front_a, slow_follow) == {"a": 2.0, "b": 1.0}

    def test_a_close_or_unfinished_split_is_a_tie(self) -> None:
        front_a = leg("a", "b", "01", 0, (1, 2), times=(60.0, 60.5))
        # a: 60.0 + 61.05 = 121.05 s, b: 60.5 + 60.5 = 121.0 s: 0.05 s apart, a tie.
        close = leg("a", "b", "10", 0, (2, 1), times=(61.05, 60.5))
        assert pair_result(front_a, close) == {"a": 1.0, "b": 1.0}
        dnf = leg("a", "b", "10", 0, (2, 1), finished=(False, True))
        assert pair_result(front_a, dnf) == {"a": 1.0, "b": 1.0}

    def test_legs_must_be_the_same_two_players(self) -> None:
        with pytest.raises(ValueError, match="not two 2-car races between the same two"):
            pair_result(leg("a", "b", "10", 0, (1, 2)), leg("a", "c", "01", 0, (1, 2)))


class TestPairedRaces:
    def test_pairs_in_key_order_and_lone_legs_left_out(self) -> None:
        matches = [
            leg("a", "b", "01", 10, (1, 2)), leg("a", "b", "10", 10, (1, 2)),  # a both
            leg("a", "b", "01", 2, (2, 1)), leg("a", "b", "10", 2, (2, 1)),  # b both
            leg("a", "b", "01", 5, (1, 2)),  # its other leg failed: left out
            # Both legs from the same slot: not a pair of seat orders.
            leg("a", "c", "01", 0, (1, 2)), leg("a", "c", "01", 0, (1, 2))]
        paired = paired_races(matches)
        # race=2 sorts before race=10 (numbers, not text).
        assert paired.races == [{"a": 2.0, "b": 1.0}, {"a": 1.0, "b": 2.0}]
        assert paired.unpaired == 3

    def test_payoff_separates_players_that_each_win_from_the_front(self) -> None:
        # Three start points; each player wins every leg it starts in front, but a always
        # trails b by 0.2 s when behind and b trails a by 0.6 s.
        matches = []
        for race in range(3):
            matches.append(leg("a", "b", "01", race, (1, 2), times=(60.0, 60.6)))
            matches.append(leg("a", "b", "10", race, (2, 1), times=(60.2, 60.0)))
        per_leg = Payoff.from_races([m.places for m in matches], decay=1.0)
        paired = Payoff.from_races(paired_races(matches).races, decay=1.0)
        # Per leg: 3 wins of 6, the grid's 1/2. Paired: a 120.2 s against b 120.6 s each time.
        assert per_leg.win_rate("a", "b") == 0.5
        assert paired.win_rate("a", "b") == 1.0 and paired.games("a", "b") == 3


class TestRecords:
    def test_record_by_grid_slot(self) -> None:
        matches = [
            leg("a", "b", "10", 0, (1, 2), overtakes=(1, 0)),  # a passed from behind
            leg("a", "b", "01", 0, (1, 2)),  # a held from the front
            leg("a", "c", "10", 0, (2, 1), crashes=(1, 0)),  # a stuck behind, hit c
            leg("c", "a", "10", 0, (1, 2), overtakes=(1, 1)),  # a (front) passed, re-passed
        ]
        records = racecraft_records(matches, "a")
        total = records["all"]
        assert (total.races, total.races_behind, total.wins_behind, total.races_front,
                total.wins_front, total.overtakes, total.crashes) == (4, 2, 1, 2, 1, 2, 1)
        assert records["b"].wins_front == 1 and records["c"].races == 2
        assert set(racecraft_records(matches, "a", opponents=["c"])) == {"c", "all"}
        assert records["all"].line() == ("a vs all: 4 races, from behind won 1/2, from the "
                                         "front won 1/2, 0.50 passes and 0.25 crashes caused "
                                         "per race")

    def test_old_league_file_without_stored_slots(self, tmp_path: Path) -> None:
        store = LeagueStore(tmp_path / "old.sqlite", name="old")
        try:
            for name in ("a", "b"):
                store.add_player(Player(name=name, kind="scripted", checkpoint=name))
            for match in (leg("a", "b", "01", 0, (1, 2), stored_slots=False),
                          leg("a", "b", "10", 0, (1, 2), stored_slots=False)):
                store.record_match(match)
            matches = store.matches(context=CONTEXT)
        finally:
            store.close()
        assert [car.grid_slot for m in matches for car in m.cars] == [None] * 4
        assert paired_races(matches).races == [{"a": 1.0, "b": 2.0}]
        assert racecraft_records(matches, "a")["all"].wins_behind == 1


def test_league_payoff_and_round_report_use_the_pairs(tmp_path: Path) -> None:
    from h2h_racing.league.config import LeagueConfig
    from h2h_racing.league.selfplay import League

    out = io.StringIO()
    league = League(LeagueConfig.from_toml(LEAGUE_DIR / "smoke.toml"), tmp_path, out=out)
    try:
        # main holds racing_line off from the front and is held off from behind, 0.3 s
        # closer each time: the grid splits the legs, the aggregate gives main the pair.
        league.store.record_match(leg("main", "racing_line", "01", 0, (1, 2),
                                      times=(60.0, 60.5)))
        league.store.record_match(leg("main", "racing_line", "10", 0, (2, 1),
                                      times=(60.2, 60.0), overtakes=(0, 0)))
        assert league._payoff().win_rate("main", "racing_line") == 1.0
        league._show_racecraft(0)
    finally:
        league.close()
    assert ("main vs the anchors: 2 races, from behind won 0/1, from the front won 1/1, "
            "0.00 passes and 0.00 crashes caused per race") in out.getvalue()
