"""The drivers inside a ``RacingVecEnv``: its opponents and its expert, one per track.

A driver (``h2h_racing.policies``: ``reset(core)``, ``act(core, car)``) drives one car of every
copy of a core of one track: it reads ``core.track`` and keeps what it computed for it (a
racing line, a planner's lanes and plans). A ``RacingVecEnv`` over K tracks gives each track a
driver of its own, which drives that track's copies through their one-track view
(``RaceCore.track_views()``): as K envs of one track each would, in one batched step. With
one track the driver drives the core itself.

``PoolOpponent`` shares the copies among several drivers (``TrainConfig.opponent`` with
several names; the league's opponents).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt


class PoolOpponent:
    """Drives the opponent car of each env copy with that copy's driver.

    Args:
        specs: Driver of each env copy (``make_driver`` argument), length E.
        seed: Seeds the ``random`` driver, if it plays.
    """

    def __init__(self, specs: tuple[str, ...], seed: int = 0) -> None:
        from h2h_racing.policies import make_driver

        self.specs = tuple(specs)
        self.seed = seed
        self.names = sorted(set(specs))
        self.drivers = [make_driver(name, rng=np.random.default_rng(seed)) if name == "random"
                        else make_driver(name) for name in self.names]
        index = {name: i for i, name in enumerate(self.names)}
        self.assignment = np.array([index[s] for s in specs])

    def for_copies(self, rows: slice | npt.NDArray[np.int64], seed: int) -> PoolOpponent:
        """The pool of the copies ``rows`` alone (their drivers built anew, seeded ``seed``)."""
        picked = np.arange(len(self.specs))[rows]
        return PoolOpponent(tuple(self.specs[e] for e in picked.tolist()), seed=seed)

    def reset(self, core: Any) -> None:
        """Reset every driver (each drives all copies; rows are picked in ``act``)."""
        if len(self.assignment) != core.num_envs:
            raise ValueError(f"{len(self.assignment)} opponent assignments for "
                             f"{core.num_envs} env copies")
        for driver in self.drivers:
            driver.reset(core)

    def act(self, core: Any, car: int) -> np.ndarray:
        """Actions of car ``car`` in every copy, each from its copy's driver, (E, 2)."""
        actions = np.empty((core.num_envs, 2), dtype=np.float32)
        for k, driver in enumerate(self.drivers):
            rows = self.assignment == k
            actions[rows] = np.asarray(driver.act(core, car))[rows]
        return actions


def build_driver(driver: str | Any, seed: int) -> Any:
    """``driver`` itself, or the driver a name (a spec) makes, seeded with ``seed``."""
    if isinstance(driver, str):
        from h2h_racing.policies import make_driver

        return make_driver(driver, seed=seed)
    return driver


class TrackDrivers:
    """One driver per track of ``core``, each driving its track's copies.

    Args:
        driver: A driver name (built once per track, with that track's seed) or object (the
            object itself drives a core of one track; a core of several gets a copy per
            track, and a ``PoolOpponent`` the pool of each track's copies).
        core: The core.
        seeds: One seed per track of the core.
    """

    def __init__(self, driver: str | Any, core: Any, seeds: Sequence[int]) -> None:
        self.driver = build_driver(driver, seeds[0])
        """The driver as given (built, for a name): with one track, the one driving it."""
        self._parts: list[tuple[Any, Any, Any]] = []
        for rows, view in core.track_views():
            if core.num_tracks == 1:
                mine = self.driver
            elif isinstance(driver, str):
                mine = build_driver(driver, seeds[view.track_number])
            elif isinstance(driver, PoolOpponent):
                mine = driver.for_copies(rows, seeds[view.track_number])
            else:
                mine = copy.deepcopy(driver)
            self._parts.append((rows, view, mine))

    def bind(self, core: Any) -> None:
        """Drive ``core`` (a new core of as many tracks, the same blocks of copies) with the
        same drivers, each on its track's copies there; call ``reset`` next."""
        views = core.track_views()
        if len(views) != len(self._parts):
            raise ValueError(f"these drivers drive {len(self._parts)} tracks, the core races "
                             f"{len(views)}")
        self._parts = [(rows, view, part[2]) for (rows, view), part in zip(views, self._parts)]

    @property
    def drivers(self) -> list[Any]:
        """The driver of each track that some copy races, in track order."""
        return [part[2] for part in self._parts]

    def reset(self) -> None:
        """Let every driver prepare for its track (``reset(view)``)."""
        for _, view, driver in self._parts:
            driver.reset(view)

    def act(self, car: int) -> npt.NDArray[np.float32]:
        """Actions of car ``car`` in every copy, each from its track's driver, (E, 2)."""
        if len(self._parts) == 1:
            _, view, driver = self._parts[0]
            return np.asarray(driver.act(view, car))
        parts = [(rows, np.asarray(driver.act(view, car))) for rows, view, driver in self._parts]
        out = np.empty((sum(len(a) for _, a in parts), 2), dtype=parts[0][1].dtype)
        for rows, actions in parts:
            out[rows] = actions
        return out
