"""Per-car ``infos`` of the PettingZoo env: flat, fixed keys of numbers.

Trainers build tensor specs from the infos that ``reset()`` returns (TorchRL's
``PettingZooWrapper`` does), so every car's info has the same keys at reset and at every step,
and every value is a finite Python ``float``, ``int`` or ``bool``. A lap time that does not
exist yet is ``NO_LAP_TIME`` (-1.0), never ``inf``. The structures that do not fit that mould
(every lap time, the reward terms as a dict, DeepRacer's params) come with
``info_level="full"`` (see ``RacingEnv``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit

from h2h_racing import rewards
from h2h_racing.race import TIME_EPS

NO_LAP_TIME = -1.0
"""``last_lap_time`` / ``best_lap_time`` of a car without a (valid) timed lap yet [s]."""

INFO_LEVELS: tuple[str, ...] = ("flat", "full")

FLOAT_KEYS: tuple[str, ...] = ("progress", "distance", "last_lap_time", "best_lap_time",
                               "gap_to_leader", "time")
INT_KEYS: tuple[str, ...] = ("lap", "rank", "overtakes", "overtaken", "defences", "resets",
                             "penalties")
BOOL_KEYS: tuple[str, ...] = ("frozen", "finished", "off_track", "crashed", "collided",
                              "penalised", "parked")
REWARD_KEYS: tuple[str, ...] = tuple(f"reward_{term}" for term in rewards.TERMS)
INFO_KEYS: tuple[str, ...] = FLOAT_KEYS + INT_KEYS + BOOL_KEYS + REWARD_KEYS
"""Every key of a car's default info, in order."""


class InfoBuilder:
    """Builds the per-car info dicts of env copy 0 of a ``RaceCore``.

    Args:
        num_cars: Cars of the race.
        lap_length: Length of the lap [m] (progress is a percentage of it).
        level: ``"flat"`` (the fixed keys of ``INFO_KEYS``) or ``"full"`` (those plus
            ``lap_times`` and ``reward_terms``).
    """

    def __init__(self, num_cars: int, lap_length: float, level: str = "flat") -> None:
        if level not in INFO_LEVELS:
            raise ValueError(f"info_level must be one of {INFO_LEVELS}, got {level!r}")
        self.level = level
        self.percent_per_metre = 100.0 / lap_length
        self._floats = np.empty((num_cars, len(FLOAT_KEYS)))
        self._ints = np.empty((num_cars, len(INT_KEYS)), dtype=np.int64)
        self._flags = np.empty((num_cars, 6), dtype=bool)
        self._no_flags = np.zeros((4, 1, num_cars), dtype=bool)
        self._no_terms = [[0.0] * len(rewards.TERMS)] * num_cars

    def build(self, core: Any, index: dict[str, int], agents: list[str], events: Any,
              terms: npt.NDArray[np.float64] | None) -> dict[str, dict[str, Any]]:
        """Return ``{agent: info}`` for ``agents`` after a step (events, terms) or a reset."""
        floats, ints, flags = self._floats, self._ints, self._flags
        if events is None:
            step_flags = self._no_flags
        else:
            step_flags = (events.off_track, events.crashed, events.collided, events.penalised)
        _info_kernel(core.distance, core.start_distance, self.percent_per_metre,
                     core.last_lap_time, core.best_lap_time, core.time, core.laps, core.rank,
                     core.overtakes, core.overtaken, core.defences, core.resets,
                     core.penalties, core.frozen_until, core.finished, step_flags[0],
                     step_flags[1], step_flags[2], step_flags[3], floats, ints, flags)
        float_rows, int_rows, flag_rows = floats.tolist(), ints.tolist(), flags.tolist()
        done = core.done[0].tolist()
        term_rows = terms[:, 0, :].T.tolist() if terms is not None else self._no_terms
        keys = INFO_KEYS
        infos = {}
        for a in agents:
            i = index[a]
            flag_rows[i].append(done[i])
            # One zip over the concatenated rows: far cheaper than a key at a time.
            infos[a] = dict(zip(keys, float_rows[i] + int_rows[i] + flag_rows[i]
                                + term_rows[i]))
        if self.level == "full":
            lap_times = core.lap_times[0]
            names = rewards.TERMS
            for a in agents:
                i = index[a]
                infos[a]["lap_times"] = list(lap_times[i])
                infos[a]["reward_terms"] = dict(zip(names, term_rows[i]))
        return infos


@njit(cache=True)
def _info_kernel(distance, start_distance, percent_per_metre, last_lap, best_lap, time, laps,
                 rank, overtakes, overtaken, defences, resets, penalties, frozen_until, finished,
                 off_track, crashed, collided, penalised, floats, ints,
                 flags):  # pragma: no cover
    # Gathers the info fields of env copy 0 into three small tables, so that the per-car
    # dicts are built from three tolist() calls instead of one per field.
    leader = distance[0, 0]
    for i in range(distance.shape[1]):
        leader = max(leader, distance[0, i])
    for i in range(distance.shape[1]):
        floats[i, 0] = (distance[0, i] - start_distance[0, i]) * percent_per_metre
        floats[i, 1] = distance[0, i]
        last = last_lap[0, i]
        best = best_lap[0, i]
        floats[i, 2] = last if math.isfinite(last) else NO_LAP_TIME
        floats[i, 3] = best if math.isfinite(best) else NO_LAP_TIME
        floats[i, 4] = leader - distance[0, i]
        floats[i, 5] = time[0]
        ints[i, 0] = laps[0, i]
        ints[i, 1] = rank[0, i]
        ints[i, 2] = overtakes[0, i]
        ints[i, 3] = overtaken[0, i]
        ints[i, 4] = defences[0, i]
        ints[i, 5] = resets[0, i]
        ints[i, 6] = penalties[0, i]
        flags[i, 0] = frozen_until[0, i] > time[0] + TIME_EPS
        flags[i, 1] = finished[0, i]
        flags[i, 2] = off_track[0, i]
        flags[i, 3] = crashed[0, i]
        flags[i, 4] = collided[0, i]
        flags[i, 5] = penalised[0, i]
