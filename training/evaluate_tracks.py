"""Evaluate drivers on many tracks at once, as the copies of one batched core.

A *run* is one driver on one track: ``evaluate``'s one-lap attempts or ``evaluate_races``'
races. ``lap_runs`` and ``race_runs`` race several runs in one ``RaceCore`` over their
tracks, each run a track of its own (a track given for two runs is stored once), so every
step of the simulation is one batched step of all of them, where ``evaluate`` over 40 routes
built and stepped 40 cores one after another.

Each run's figures are the ones ``evaluate`` or ``evaluate_races`` gives it alone, to the bit:
its copies are laid out in the pymunk Space as its own core would lay them out, over the other
runs' copies, which they never touch (``RaceCore(overlay=True)``); its track's generator is
seeded with the run's seed; its driver is its own (built as those functions build it) and
drives only its copies (a ``CoreView``, the batch its network would see alone); and its
figures are read the step its last copy is done. One thing a core of several runs cannot
give: pymunk sorts the contacts of a Space of fewer than ``HASH_MIN_BODIES`` bodies with a
bounding-box tree, whose order depends on every body in it, and of more with a spatial hash.
So runs whose cars can touch something (boxes, bots) are batched only when each run alone
would have used the hash too (``batchable``); the others race one core each, as before.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from h2h_racing.config.env import EnvConfig
from h2h_racing.sim.core import RaceCore
from h2h_racing.sim.physics import HASH_MIN_BODIES
from h2h_racing.sim.tracks import MAX_OVERLAID_TRACKS
from h2h_racing.track.shape import Track
from h2h_racing.training.evaluate import (Evaluation, RaceEvaluation, lap_config, lap_figures,
                                          lap_starts, race_config, race_figures)

MAX_COPIES = 4096
"""Env copies of one core at most: runs beyond it go to the next core (memory, and a core of
many thousand copies steps no faster per copy)."""


@dataclass(frozen=True)
class Run:
    """One driver on one track."""

    driver: Any
    """A driver spec (``make_driver``, built with the run's seed) or a fresh driver object."""
    track: Track
    seed: int = 0
    """Seed of the run's track generator and of a driver built from a spec."""


def batchable(config: EnvConfig, copies: int) -> bool:
    """Whether a run of ``copies`` copies under ``config`` races in a core of several runs as
    in its own core: its cars touch nothing (one car, no box, no bot), or its own core would
    sort contacts with pymunk's spatial hash too (see the module docstring)."""
    bodies = config.num_cars + config.obstacle_count + config.bot_count
    return bodies == 1 or copies * bodies >= HASH_MIN_BODIES


def batches(runs: Sequence[Run], copies: int) -> list[list[int]]:
    """The runs (their indices, in order) of each core: at most ``MAX_OVERLAID_TRACKS`` runs
    and ``MAX_COPIES`` copies each (at least one run)."""
    size = max(1, min(MAX_OVERLAID_TRACKS, MAX_COPIES // copies))
    return [list(range(a, min(a + size, len(runs)))) for a in range(0, len(runs), size)]


def lap_runs(runs: Sequence[Run], episodes: int,
             done: Callable[[int, Evaluation], None] | None = None) -> list[Evaluation]:
    """``evaluate(run.driver, run.track, episodes, run.seed)`` of every run, in batched cores.

    Args:
        runs: The runs.
        episodes: One-lap attempts of each run (``evaluate``'s starts).
        done: Called with a run's index and figures as soon as its attempts are done.
    """
    def make(batch: list[Run]) -> tuple[EnvConfig, RaceCore]:
        config = lap_config(batch[0].track.name)
        core = RaceCore(config, [run.track for run in batch], num_envs=episodes * len(batch),
                        overlay=True)
        core.seed_tracks([run.seed for run in batch])
        core.reset(start=np.concatenate([lap_starts(run.track, episodes) for run in batch]))
        return config, core

    return _race_all(runs, episodes, make, lap_figures, done)


def race_runs(runs: Sequence[Run], race_type: str, races: int, laps: int,
              done: Callable[[int, RaceEvaluation], None] | None = None
              ) -> list[RaceEvaluation]:
    """``evaluate_races(run.driver, run.track, race_type, races, laps, run.seed)`` of every
    run, in batched cores where that gives the same figures (``batchable``), else one core a
    run.

    Raises:
        ValueError: As ``evaluate_races`` for a bad race type or count; a track the race
            type's boxes or bots do not fit on fails its batch (``race_runs`` of its runs one
            by one tells which).
    """
    from h2h_racing.training.evaluate import RACE_TYPE_CHOICES

    if race_type not in RACE_TYPE_CHOICES:
        raise ValueError(f"race_type must be one of {', '.join(RACE_TYPE_CHOICES)}, got "
                         f"{race_type!r} (time trials: lap_runs)")
    if not (isinstance(races, int) and races >= 1 and isinstance(laps, int) and laps >= 1):
        raise ValueError(f"races and laps must be whole numbers >= 1, got {races!r} and "
                         f"{laps!r}")
    one_each = not batchable(race_config("", race_type, laps), races)

    def make(batch: list[Run]) -> tuple[EnvConfig, RaceCore]:
        config = race_config(batch[0].track.name, race_type, laps)
        core = RaceCore(config, [run.track for run in batch], num_envs=races * len(batch),
                        overlay=True)
        core.seed_tracks([run.seed for run in batch])
        core.reset()
        return config, core

    return _race_all(runs, races, make, race_figures, done, one_each)


def _race_all(runs: Sequence[Run], copies: int,
              make: Callable[[list[Run]], tuple[EnvConfig, RaceCore]],
              figures: Callable[[Any, Any], Any], done: Callable[[int, Any], None] | None,
              one_each: bool = False) -> list[Any]:
    """Race ``runs`` batch by batch (``make`` builds and resets a batch's core, run k on its
    track k); ``figures(driver, view)`` of each run as its last copy is done."""
    results: list[Any] = [None] * len(runs)
    groups = [[k] for k in range(len(runs))] if one_each else batches(runs, copies)
    for group in groups:
        config, core = make([runs[k] for k in group])
        parts = [(rows, view, _driver(runs[k]))
                 for k, (rows, view) in zip(group, core.track_views())]
        for _, view, driver in parts:
            driver.reset(view)
        actors = _actors(core, [runs[k] for k in group], parts, copies)
        actions = np.zeros((core.num_envs, 2))
        pending = list(range(len(parts)))
        while pending:
            racing = set(pending)
            for members, act in actors:
                if members & racing:
                    act(actions)
            core.step(*config.commands(actions[:, None, :]))
            running = []
            for i in pending:
                rows, view, driver = parts[i]
                if view.done.all():
                    # Read now: a done copy is stepped on with the others, as it waits.
                    results[group[i]] = figures(driver, view)
                    if done is not None:
                        done(group[i], results[group[i]])
                else:
                    running.append(i)
            pending = running
    return results


def _actors(core: RaceCore, runs: Sequence[Run], parts: list[tuple[Any, Any, Any]],
            copies: int) -> list[tuple[set[int], Callable[[np.ndarray], None]]]:
    """Who acts each step: the runs of one driver spec together where a batched driver
    gives each copy its own driver's bits (``training.evaluate_batched``), else each run's
    driver on its view; each with the runs (indices into ``parts``) it acts for.

    A batched driver acts for its runs' copies as long as one of them races (the copies of
    a done run are stepped on with the others; their figures were read as it ended)."""
    from h2h_racing.training.evaluate_batched import batched_driver

    by_spec: dict[Any, list[int]] = {}
    for i, run in enumerate(runs):
        by_spec.setdefault(run.driver if isinstance(run.driver, str) else id(run.driver),
                           []).append(i)
    every = np.arange(core.num_envs)
    actors: list[tuple[set[int], Callable[[np.ndarray], None]]] = []
    for members in by_spec.values():
        rows = [every[parts[i][0]] for i in members]
        batched = None
        if all(len(r) == copies for r in rows):
            batched = batched_driver([parts[i][2] for i in members], core, copies)
        if batched is not None:
            union = np.concatenate(rows)

            def act(actions: np.ndarray, batched: Any = batched, union: Any = union) -> None:
                actions[union] = batched.act(core, union, 0)

            actors.append((set(members), act))
            continue
        for i in members:
            def act_one(actions: np.ndarray, part: tuple[Any, Any, Any] = parts[i]) -> None:
                rows, view, driver = part
                actions[rows] = driver.act(view, 0)

            actors.append(({i}, act_one))
    return actors


def _driver(run: Run) -> Any:
    """The run's driver: built from its spec with its seed, as ``evaluate`` builds it."""
    if isinstance(run.driver, str):
        from h2h_racing.policies import make_driver

        return make_driver(run.driver, seed=run.seed)
    return copy.deepcopy(run.driver)
