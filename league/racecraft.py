"""Racecraft: league results the grid does not decide, and records split by grid slot.

In a 2-car race the car on the front slot wins unless the other passes it, so a race's result
mostly says who started in front. The league races every pairing in both seat orders on the
same start point (``tournament.PAIR_ORDERS``: the two *legs* of a race, each player once from
behind). Its payoff table, its restore record and its ratings score the **pair of legs** as one
result, like a two-legged tie:

- a player that won both legs (passed from behind and held, or re-passed, from the front) wins
  the pair; one that lost both loses it;
- when each won one leg, and all four cars finished, the **aggregate time** decides: the
  player whose two finish times (penalties served included) add up to less, by more than
  ``AGGREGATE_TIE`` seconds, wins the pair. The grid gap costs both players the same, so what
  decides is how closely each followed the other when behind and how far it pulled away when
  in front (GT Sophy's "time gained on the car ahead"). A split with a car that did not finish
  is a tie, as is an aggregate within ``AGGREGATE_TIE``.

Why not score each leg: averaging the two legs gives 1/2 + (w_A - w_B) / 2 with w the
from-behind win rates, so it already cancels the grid, but when neither can pass (the common
case) every cell is 1/2 and the table carries no signal. The aggregate keeps the pass-decided
results and breaks the rest by pace in traffic, which the grid does not decide either.

Stored league files need no new fields: the legs of a pair are the matches whose keys differ
only in their ``slots=`` part. A leg whose partner is missing (a failed race, a run killed
between them, a multi-car race) is left out of the pair results and counted in
``PairedRaces.unpaired``. A car's grid slot is ``CarResult.grid_slot``, or, in files written
before that was stored, read from the key's ``slots=`` digits.

``racecraft_records`` reports a player's record by grid slot: wins from behind and from the
front, passes and crashes caused per race. Stored matches do not hold defences;
``evaluate --against`` reports those (``h2h_racing.training.evaluate.HeadToHead``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from h2h_racing.league.store import MatchRecord

AGGREGATE_TIE = 0.1
"""Aggregate times of a split pair of legs closer than this are a tie [s]."""
_SLOTS = re.compile(r":slots=(\d+)")


def leg_key(key: str) -> str | None:
    """The key shared by both legs of a pair: ``key`` without its ``:slots=..`` part; None
    for a key without one (not a leg)."""
    if _SLOTS.search(key) is None:
        return None
    return _SLOTS.sub("", key, count=1)


def grid_slots(match: MatchRecord) -> dict[str, int] | None:
    """Player -> grid slot (0 = front) of a match: the stored slots, else the key's ``slots=``
    digits (seat i took slot digit i); None when neither says."""
    if all(car.grid_slot is not None for car in match.cars):
        return {car.player: int(car.grid_slot) for car in match.cars}  # type: ignore[arg-type]
    found = _SLOTS.search(match.key)
    if found is None or len(found.group(1)) != len(match.cars):
        return None
    digits = found.group(1)
    return {car.player: int(digits[car.seat]) for car in match.cars
            if 0 <= car.seat < len(digits)} or None


def _natural(key: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key with digit runs compared as numbers (``race=2`` before ``race=10``)."""
    return tuple((0, int(part)) if part.isdigit() else (1, part)
                 for part in re.split(r"(\d+)", key) if part)


def pair_result(first: MatchRecord, second: MatchRecord) -> dict[str, float]:
    """Places ``{player: 1 or 2}`` (1 and 1 for a tie) of the pair of legs ``first`` and
    ``second`` (the same two players, each once on each grid slot; see the module docstring).

    Raises:
        ValueError: The legs are not two 2-car races between the same two players.
    """
    players = sorted(car.player for car in first.cars)
    if len(players) != 2 or sorted(car.player for car in second.cars) != players:
        raise ValueError(f"legs {first.key!r} and {second.key!r} are not two 2-car races "
                         f"between the same two players")
    a, b = players
    legs = [{car.player: car for car in leg.cars} for leg in (first, second)]
    won = sum(leg[a].position < leg[b].position for leg in legs)
    lost = sum(leg[a].position > leg[b].position for leg in legs)
    if won > lost:
        return {a: 1.0, b: 2.0}
    if lost > won:
        return {a: 2.0, b: 1.0}
    times = [leg[p].total_time for leg in legs for p in (a, b)]
    if not all(leg[p].finished for leg in legs for p in (a, b)) or \
            not all(math.isfinite(t) for t in times):
        return {a: 1.0, b: 1.0}
    margin = (legs[0][a].total_time + legs[1][a].total_time
              - legs[0][b].total_time - legs[1][b].total_time)
    if abs(margin) < AGGREGATE_TIE:
        return {a: 1.0, b: 1.0}
    return {a: 1.0, b: 2.0} if margin < 0 else {a: 2.0, b: 1.0}


@dataclass(frozen=True)
class PairedRaces:
    """Pair results of a list of matches (``paired_races``)."""

    races: list[dict[str, float]]
    """One ``{player: place}`` per pair of legs, in key order (ratings and payoff input)."""
    unpaired: int
    """Matches left out: a leg without its partner, or not a 2-car leg."""


def paired_races(matches: Iterable[MatchRecord]) -> PairedRaces:
    """Group ``matches`` into pairs of legs and score each pair (``pair_result``).

    Pairs come in the natural order of their keys (digit runs as numbers: ``round=9`` before
    ``round=10``), so the same matches give the same list whatever order they were stored in.
    """
    groups: dict[str, list[MatchRecord]] = {}
    unpaired = 0
    for match in matches:
        key = leg_key(match.key)
        if key is None or len(match.cars) != 2:
            unpaired += 1
            continue
        groups.setdefault(key, []).append(match)
    races = []
    for key in sorted(groups, key=_natural):
        legs = groups[key]
        slots = [grid_slots(leg) for leg in legs]
        swapped = (len(legs) == 2 and slots[0] is not None and slots[1] is not None
                   and slots[0].keys() == slots[1].keys()
                   and all(slots[0][p] != slots[1][p] for p in slots[0]))
        if not swapped:
            unpaired += len(legs)
            continue
        races.append(pair_result(legs[0], legs[1]))
    return PairedRaces(races=races, unpaired=unpaired)


@dataclass(frozen=True)
class Racecraft:
    """A player's record against one opponent (or all of them) by grid slot."""

    player: str
    opponent: str
    races: int
    """2-car races whose grid slots are known."""
    races_behind: int = 0
    wins_behind: int = 0
    """Races won from the slot behind: the player passed and stayed ahead."""
    races_front: int = 0
    wins_front: int = 0
    """Races won from the front slot: the player held the lead or re-took it."""
    overtakes: int = 0
    """The player's passes over those races."""
    crashes: int = 0
    """Contacts the player caused over those races."""
    clean_wins_behind: int = 0
    """Races won from the slot behind without causing a crash (the league main's record,
    ``League.record``)."""

    def line(self) -> str:
        """One text line: wins by slot, passes and crashes caused per race."""
        def ratio(won: int, of: int) -> str:
            return f"{won}/{of}" if of else "-"

        per = max(self.races, 1)
        return (f"{self.player} vs {self.opponent}: {self.races} races, from behind won "
                f"{ratio(self.wins_behind, self.races_behind)}, from the front won "
                f"{ratio(self.wins_front, self.races_front)}, {self.overtakes / per:.2f} "
                f"passes and {self.crashes / per:.2f} crashes caused per race")


def racecraft_records(matches: Iterable[MatchRecord], player: str,
                      opponents: Sequence[str] | None = None) -> dict[str, Racecraft]:
    """``player``'s record by grid slot in its 2-car ``matches``: one ``Racecraft`` per
    opponent (only ``opponents`` when given) and one over them all under the key ``"all"``.
    Matches whose grid slots are unknown are left out."""
    counts: dict[str, list[int]] = {}
    for match in matches:
        slots = grid_slots(match)
        cars = {car.player: car for car in match.cars}
        if slots is None or len(cars) != 2 or player not in cars:
            continue
        opponent = next(p for p in cars if p != player)
        if opponents is not None and opponent not in opponents:
            continue
        mine, theirs = cars[player], cars[opponent]
        won = int(mine.position < theirs.position)
        behind = slots[player] > slots[opponent]
        row = [1, int(behind), won * behind, int(not behind), won * (not behind),
               mine.overtakes, mine.crashes, won * behind * int(mine.crashes == 0)]
        for name in (opponent, "all"):
            counts[name] = [x + y for x, y in zip(counts.get(name, [0] * len(row)), row)]
    return {name: Racecraft(player, name, *row) for name, row in counts.items()}
