"""Evaluate a driver alone on a track: lap completion, lap times, off-tracks and collisions.

Each episode is one lap attempt under DeepRacer's training rules (an infraction ends the
attempt) from a different start point, spread evenly round the lap as DeepRacer's training
starts are; all episodes run at once as env copies of one batched core. The same start points
are used for every driver, so two drivers' figures compare like for like.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from h2h_racing.config import EnvConfig, RaceRules
from h2h_racing.core import RaceCore
from h2h_racing.track import Track
from h2h_racing.track_io import load_track


@dataclass(frozen=True)
class Evaluation:
    """Figures of one driver over ``episodes`` lap attempts."""

    driver: str
    track: str
    episodes: int
    lap_completion: float
    """Fraction of attempts that completed the lap."""
    mean_lap_time: float
    """Mean lap time of the completed attempts [s] (inf if none)."""
    best_lap_time: float
    """Best lap time [s] (inf if none)."""
    off_tracks: int
    """Attempts that ended off track."""
    collisions: int
    """Contacts (with obstacles, when there are any)."""

    def row(self) -> str:
        """One line of the evaluation table."""
        mean = f"{self.mean_lap_time:.2f}" if np.isfinite(self.mean_lap_time) else "-"
        best = f"{self.best_lap_time:.2f}" if np.isfinite(self.best_lap_time) else "-"
        return (f"{self.driver:<28} {100 * self.lap_completion:>6.1f} % {mean:>8} {best:>8} "
                f"{self.off_tracks:>5} {self.collisions:>5}")

    @staticmethod
    def header() -> str:
        """Header line of the evaluation table."""
        return (f"{'driver':<28} {'laps':>8} {'mean s':>8} {'best s':>8} {'off':>5} "
                f"{'coll':>5}")


def evaluate(driver: Any, track: str | Track, episodes: int = 20, seed: int = 0,
             **config: Any) -> Evaluation:
    """Run ``episodes`` one-lap attempts of ``driver`` alone on ``track``.

    Args:
        driver: A driver name or ``policy.pt`` path (``make_driver``), or a driver object.
        track: Catalogue name, track file, ``random:<seed>``, or a ``Track``.
        episodes: Lap attempts, started at ``k * L / episodes`` for k = 0 .. episodes - 1.
        seed: Seed of the core (obstacle randomisation).
        **config: Further ``EnvConfig`` fields (e.g. ``num_obstacles``).
    """
    from h2h_racing.policies import make_driver

    if isinstance(driver, str):
        driver = make_driver(driver, seed=seed)
    rules = RaceRules.preset("time_trial", "training")
    loaded = track if isinstance(track, Track) else load_track(track)
    env_config = EnvConfig(track=loaded.name if isinstance(track, Track) else track, num_cars=1,
                           race_type="time_trial", rules=rules, **config)
    core = RaceCore(env_config, loaded, num_envs=episodes)
    core.reset(seed=seed, start=np.arange(episodes) * (loaded.length / episodes))
    driver.reset(core)
    while not core.done.all():
        core.step(*env_config.commands(np.asarray(driver.act(core, 0))[:, None, :]))
    laps = [t for env in range(episodes) for t in core.lap_times[env][0][:1]]
    return Evaluation(
        driver=getattr(driver, "name", type(driver).__name__), track=loaded.name,
        episodes=episodes, lap_completion=float(core.finished[:, 0].mean()),
        mean_lap_time=float(np.mean(laps)) if laps else float("inf"),
        best_lap_time=float(np.min(laps)) if laps else float("inf"),
        off_tracks=int(core.off_tracks[:, 0].sum()), collisions=int(core.collisions[:, 0].sum()))


@dataclass(frozen=True)
class HeadToHead:
    """Outcome of ``races`` 2-car races between two drivers, half in each seat order."""

    drivers: tuple[str, str]
    track: str
    races: int
    wins: tuple[int, int]
    """Races won by each driver (first across the line after the lap target)."""
    overtakes: tuple[int, int]
    """On-track passes made by each driver, over all races."""
    crashes: tuple[int, int]
    """Contacts each driver was judged to have caused (it was behind)."""
    finished: tuple[int, int]
    """Races each driver finished."""

    def summary(self) -> str:
        """A short text report."""
        a, b = self.drivers
        return (f"{self.track}, {self.races} races ({self.races // 2} in each seat order): "
                f"{a} won {self.wins[0]}, {b} won {self.wins[1]}; overtakes {self.overtakes[0]} / "
                f"{self.overtakes[1]}; crashes caused {self.crashes[0]} / {self.crashes[1]}; "
                f"finished {self.finished[0]} / {self.finished[1]}")


def head_to_head(driver_a: Any, driver_b: Any, track: str, races: int = 20, laps: int = 3,
                 seed: int = 0) -> HeadToHead:
    """Race two drivers against each other ``races`` times, all at once as env copies.

    Race pair k (copies 2k and 2k + 1) starts at a random point of the lap drawn from
    ``seed``, with driver A on grid slot 0 in one copy and slot 1 in the other (every start in
    both seat orders), ``head_to_head`` race rules (time penalties, not retirement) and
    ``laps`` laps counted from that start.
    """
    from h2h_racing.policies import make_driver

    drivers = [make_driver(d, seed=seed + car) if isinstance(d, str) else d
               for car, d in enumerate((driver_a, driver_b))]
    rules = RaceRules(laps=laps, time_limit=60.0 * laps)
    env_config = EnvConfig(track=track, num_cars=2, race_type="head_to_head", rules=rules)
    loaded = load_track(track)
    if races < 2 or races % 2:
        raise ValueError(f"races must be an even number >= 2 (both seat orders), got {races}")
    core = RaceCore(env_config, loaded, num_envs=races)
    slots = np.stack([np.arange(races) % 2, 1 - np.arange(races) % 2], axis=1)
    starts = np.repeat(np.random.default_rng(seed).uniform(0.0, loaded.length, races // 2), 2)
    core.reset(seed=seed, slots=slots, start=starts)
    for driver in drivers:
        driver.reset(core)
    while not core.done.all():
        core.step(*env_config.commands(np.stack([d.act(core, car)
                                                 for car, d in enumerate(drivers)], axis=1)))
    winner = (core.rank == 1) & core.finished
    names = tuple(getattr(d, "name", type(d).__name__) for d in drivers)
    return HeadToHead(
        drivers=(names[0], names[1]), track=loaded.name, races=races,
        wins=(int(winner[:, 0].sum()), int(winner[:, 1].sum())),
        overtakes=(int(core.overtakes[:, 0].sum()), int(core.overtakes[:, 1].sum())),
        crashes=(int(core.crashes[:, 0].sum()), int(core.crashes[:, 1].sum())),
        finished=(int(core.finished[:, 0].sum()), int(core.finished[:, 1].sum())))
