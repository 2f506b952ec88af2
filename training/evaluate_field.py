"""Field races: one driver against several opponents at once, its grid slot rotated.

``evaluate --field A,B,C`` races the policy with every opponent on the grid together (a
3-car race for two opponents, 4-car for three), all races at once as env copies of one
batched core, as ``head_to_head`` does for two cars. Every start point is raced in every
cyclic rotation of the grid (the tournament's field races do the same), so the policy starts
from each slot equally often and the figures can be split by slot: its mean finishing place,
wins, passes and crashes caused per race from the front slot, from the last one, and between.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.track.io import load_track
from h2h_racing.training.evaluate import race_batch


@dataclass(frozen=True)
class FieldResult:
    """Outcome of ``races`` races of a driver (car 0) with its opponents, by its grid slot.

    The ``*_by_slot`` tuples hold, for each grid slot k (0 is the front, slot k starts
    ``k * gap`` metres of track behind it), the driver's totals over the races it started
    from slot k.
    """

    drivers: tuple[str, ...]
    """The driver, then its opponents."""
    track: str
    races: int
    races_by_slot: tuple[int, ...]
    """Races the driver started from each slot."""
    places_by_slot: tuple[int, ...]
    """Sum of its finishing places (1 = won) from each slot."""
    wins_by_slot: tuple[int, ...]
    """Races it won from each slot (first across the line after the lap target)."""
    overtakes_by_slot: tuple[int, ...]
    """On-track passes it made, from each slot."""
    crashes_by_slot: tuple[int, ...]
    """Contacts it was judged to have caused (it was behind), from each slot."""
    finished_by_slot: tuple[int, ...]
    """Races it finished, from each slot."""
    off_tracks_by_slot: tuple[int, ...]
    """Times it left the track, from each slot."""
    wins: tuple[int, ...]
    """Races won by each driver (the driver, then its opponents), over all slots."""
    gap: float = 0.75
    """Distance between consecutive grid slots [m of track]."""
    rolling: float = 0.0
    """Start speed of every car [m/s]: 0 for a standing start."""

    def slot_figures(self, slot: int | None = None) -> dict[str, float]:
        """The driver's figures from ``slot`` (None: all slots): races, mean place, wins,
        passes, crashes caused and off-tracks per race, finishes."""
        pick = slice(None) if slot is None else slice(slot, slot + 1)

        def total(values: tuple[int, ...]) -> int:
            return int(sum(values[pick]))

        races = total(self.races_by_slot)
        per = 1.0 / races if races else float("nan")
        return {"races": races, "mean_place": total(self.places_by_slot) * per,
                "wins": total(self.wins_by_slot),
                "passes_per_race": total(self.overtakes_by_slot) * per,
                "crashes_per_race": total(self.crashes_by_slot) * per,
                "off_tracks_per_race": total(self.off_tracks_by_slot) * per,
                "finished": total(self.finished_by_slot)}


def field_rotations(races: int, cars: int) -> np.ndarray:
    """Grid slot of each car in each race, shape (races, cars): race r puts car i in slot
    ``(i + r) % cars``, so consecutive ``cars`` races share a start point in every rotation.

    Raises:
        ValueError: Unless ``races`` is a positive multiple of ``cars``.
    """
    if races < cars or races % cars:
        raise ValueError(f"races must be a multiple of the field's {cars} cars (every start "
                         f"point in every rotation of the grid), got {races}")
    shift = np.arange(races)[:, None]
    return (np.arange(cars)[None, :] + shift) % cars


def field_race(driver: Any, opponents: Sequence[Any], track: str, races: int = 20,
               laps: int = 3, seed: int = 0, gap: float | None = None, rolling: float = 0.0,
               progress: Callable[[float, int], None] | None = None) -> FieldResult:
    """Race ``driver`` with all of ``opponents`` on the grid at once, ``races`` times.

    Start points are drawn from ``seed``, one per ``len(opponents) + 1`` races, each raced in
    every cyclic rotation of the grid (``field_rotations``); ``head_to_head`` race rules
    (time penalties, not retirement) and ``laps`` laps counted from the front slot.

    Args:
        driver: A driver name or ``policy.pt`` path (``make_driver``), or a driver object.
        opponents: At least two opponents (names or driver objects).
        gap: Distance between consecutive slots [m of track]; None keeps the grid's 0.75 m.
            The grid may reach at most a quarter of the lap.
        rolling: Start speed of every car [m/s]: 0 a standing start (see
            ``RaceCore.reset(rolling=...)``).
        progress: As ``head_to_head``'s.
    """
    from h2h_racing.policies import make_driver

    cars = len(opponents) + 1
    if cars < 3:
        raise ValueError(f"a field needs at least two opponents, got {len(opponents)}; for "
                         "two-car races use head_to_head (evaluate --against)")
    slots = field_rotations(races, cars)
    loaded = load_track(track)
    spacing = EnvConfig.grid_spacing if gap is None else gap
    reach = loaded.length / 4
    if not (isinstance(spacing, (int, float)) and 0.0 < spacing * (cars - 1) <= reach):
        raise ValueError(f"gap must be a distance in (0, {reach / (cars - 1):.1f}] m (the "
                         f"{cars}-car grid within a quarter of {loaded.name}'s lap), got "
                         f"{gap!r}")
    drivers = [make_driver(d, seed=seed + car) if isinstance(d, str) else d
               for car, d in enumerate((driver, *opponents))]
    rng = np.random.default_rng(seed)
    starts = np.repeat(rng.uniform(0.0, loaded.length, races // cars), cars)
    core = race_batch(track, loaded, drivers, laps, spacing, slots, starts, seed, rolling, progress)
    winner = (core.rank == 1) & core.finished
    slot = slots[:, 0]

    def by_slot(values: np.ndarray) -> tuple[int, ...]:
        return tuple(int(v) for v in np.bincount(slot, weights=values, minlength=cars))

    return FieldResult(
        drivers=tuple(getattr(d, "name", type(d).__name__) for d in drivers),
        track=loaded.name, races=races, races_by_slot=by_slot(np.ones(races)),
        places_by_slot=by_slot(core.rank[:, 0]), wins_by_slot=by_slot(winner[:, 0]),
        overtakes_by_slot=by_slot(core.overtakes[:, 0]),
        crashes_by_slot=by_slot(core.crashes[:, 0]),
        finished_by_slot=by_slot(core.finished[:, 0]),
        off_tracks_by_slot=by_slot(core.off_tracks[:, 0]),
        wins=tuple(int(w) for w in winner.sum(axis=0)), gap=float(spacing),
        rolling=float(rolling))


def combine_fields(results: list[FieldResult], track: str = "all") -> FieldResult:
    """Sum the races of ``results`` (the same field; e.g. one per track) into one record."""
    if not results:
        raise ValueError("combine_fields needs at least one FieldResult")

    def total(name: str) -> tuple[int, ...]:
        return tuple(int(v) for v in np.sum([getattr(r, name) for r in results], axis=0))

    gaps = {r.gap for r in results}
    speeds = {r.rolling for r in results}
    return FieldResult(
        drivers=results[0].drivers, track=track, races=sum(r.races for r in results),
        races_by_slot=total("races_by_slot"), places_by_slot=total("places_by_slot"),
        wins_by_slot=total("wins_by_slot"), overtakes_by_slot=total("overtakes_by_slot"),
        crashes_by_slot=total("crashes_by_slot"), finished_by_slot=total("finished_by_slot"),
        off_tracks_by_slot=total("off_tracks_by_slot"),
        wins=total("wins"), gap=gaps.pop() if len(gaps) == 1 else float("nan"),
        rolling=speeds.pop() if len(speeds) == 1 else float("nan"))


def field_header() -> str:
    """Header of ``field_rows``' table."""
    return (f"{'track':<16} {'slot':>5} {'races':>6} {'mean place':>10} {'won':>5} "
            f"{'passes/race':>12} {'crashes/race':>12} {'off/race':>9} {'finished':>9}")


def field_rows(result: FieldResult, slots: bool = False) -> list[str]:
    """The driver's row over all slots, preceded (``slots``) by one row per grid slot
    (``1`` is the front slot)."""
    picks: list[int | None] = [*range(len(result.races_by_slot))] if slots else []
    rows = []
    for slot in [*picks, None]:
        f = result.slot_figures(slot)
        if not f["races"]:
            continue
        rows.append(f"{result.track:<16} {'all' if slot is None else slot + 1:>5} "
                    f"{f['races']:>6} {f['mean_place']:>10.2f} {f['wins']:>5} "
                    f"{f['passes_per_race']:>12.2f} {f['crashes_per_race']:>12.2f} "
                    f"{f['off_tracks_per_race']:>9.2f} {f['finished']:>9}")
    return rows
