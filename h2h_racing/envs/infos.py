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

from h2h_racing.sim import rewards
from h2h_racing.sim.race import TIME_EPS

NO_LAP_TIME = -1.0
"""``last_lap_time`` / ``best_lap_time`` of a car without a (valid) timed lap yet [s]."""

INFO_LEVELS: tuple[str, ...] = ("flat", "full")

FLOAT_KEYS: tuple[str, ...] = ("progress", "distance", "last_lap_time", "best_lap_time",
                               "gap_to_leader", "time")
REWARD_KEYS: tuple[str, ...] = tuple(f"reward_{term}" for term in rewards.TERMS)
INT_KEYS: tuple[str, ...] = ("lap", "rank", "overtakes", "overtaken", "defences", "resets",
                             "penalties")
BOOL_KEYS: tuple[str, ...] = ("frozen", "finished", "off_track", "crashed", "collided",
                              "penalised", "parked")
INFO_KEYS: tuple[str, ...] = FLOAT_KEYS + REWARD_KEYS + INT_KEYS + BOOL_KEYS
"""Every key of a car's default info, in order."""
_INT_START = 8 * (len(FLOAT_KEYS) + len(REWARD_KEYS))
_FLAG_START = _INT_START + 8 * len(INT_KEYS)
_TABLE_DTYPE = np.dtype({
    "names": list(INFO_KEYS),
    "formats": (["f8"] * (len(FLOAT_KEYS) + len(REWARD_KEYS)) + ["i8"] * len(INT_KEYS)
                + ["?"] * len(BOOL_KEYS)),
    "offsets": list(range(0, _FLAG_START, 8)) + [_FLAG_START + k for k in range(len(BOOL_KEYS))],
    # Whole 8-byte words, so that every float and int of every record stays aligned.
    "itemsize": _FLAG_START + 8 * -(-len(BOOL_KEYS) // 8)})
"""One car's info record: the fields of ``INFO_KEYS`` in order."""


class InfoBuilder:
    """Computes the rewards and builds the per-car info dicts of env copy 0 of a ``RaceCore``.

    The built-in reward terms and the info fields are gathered by one compiled call into
    three small tables (floats with the terms, ints, flags), and each car's dict is built from
    their rows: the per-step cost of the PettingZoo layer is mostly Python, so fewer calls
    and no per-key work is what makes it cheap.

    Args:
        num_cars: Cars of the race.
        lap_length: Length of the lap [m] (progress is a percentage of it).
        weights: Reward term weights in ``rewards.TERMS`` order (``rewards.weights_of``).
        level: ``"flat"`` (the fixed keys of ``INFO_KEYS``) or ``"full"`` (those plus
            ``lap_times`` and ``reward_terms``).
    """

    def __init__(self, num_cars: int, lap_length: float, weights: npt.NDArray[np.float64],
                 level: str = "flat") -> None:
        if level not in INFO_LEVELS:
            raise ValueError(f"info_level must be one of {INFO_LEVELS}, got {level!r}")
        self.level = level
        self.percent_per_metre = 100.0 / lap_length
        self.weights = weights
        n = num_cars
        # One record per car with every info field, so that a single tolist() gives each
        # car's values as Python floats, ints and bools in INFO_KEYS order; the kernel fills
        # it through three 2-D views (floats with the terms, ints, flags).
        self._table = np.zeros(n, dtype=_TABLE_DTYPE)
        self._blank = dict.fromkeys(INFO_KEYS)
        self._cut_tables()
        self._terms = np.empty((len(rewards.TERMS), 1, n))
        self._reward = np.empty((1, n))
        # Stand-ins for a step's events at reset: nothing happened and nobody raced, so every
        # reward term is 0.
        self._no_flags = np.zeros((1, n), dtype=bool)
        self._no_progress = np.zeros((1, n))
        self._no_counts = np.zeros((1, n), dtype=np.int64)

    def _cut_tables(self) -> None:
        raw = self._table.view(np.uint8).reshape(len(self._table), _TABLE_DTYPE.itemsize)
        self._floats = raw[:, :_INT_START].view(np.float64)
        self._ints = raw[:, _INT_START:_FLAG_START].view(np.int64)
        self._flags = raw[:, _FLAG_START:_FLAG_START + len(BOOL_KEYS)].view(np.bool_)

    def __getstate__(self) -> dict[str, Any]:
        # The views would travel as copies of their own: they are cut again on arrival.
        state = self.__dict__.copy()
        for key in ("_floats", "_ints", "_flags"):
            del state[key]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._cut_tables()

    def reset(self, core: Any, index: dict[str, int],
              agents: list[str]) -> dict[str, dict[str, Any]]:
        """Return ``{agent: info}`` after a reset (every reward term 0)."""
        no, zero, counts = self._no_flags, self._no_progress, self._no_counts
        self._fill(core, no, zero, no, no, no, counts, counts, no, no)
        return self._dicts(core, index, agents)

    def step(self, core: Any, index: dict[str, int], agents: list[str], events: Any,
             racing: npt.NDArray[np.bool_]) -> tuple[list[float], dict[str, dict[str, Any]]]:
        """Return the built-in reward of every car (a list over all cars) and the infos of
        ``agents`` after a step with ``events``; ``racing``: who raced during the step."""
        ev = events
        self._fill(core, racing, ev.progress, ev.off_track, ev.crashed, ev.collided,
                   ev.overtakes, ev.overtaken, ev.lap_completed, ev.penalised)
        return self._reward[0].tolist(), self._dicts(core, index, agents)

    def _fill(self, core: Any, racing: Any, progress: Any, off_track: Any, crashed: Any,
              collided: Any, overtakes: Any, overtaken: Any, lap_completed: Any,
              penalised: Any) -> None:
        _info_kernel(self.weights, racing, progress, off_track, crashed, collided, overtakes,
                     overtaken, lap_completed, penalised, core._car_floats, core._car_counts,
                     core._car_flags, self.percent_per_metre, core.time, self._terms,
                     self._reward, self._floats, self._ints, self._flags)

    def _dicts(self, core: Any, index: dict[str, int],
               agents: list[str]) -> dict[str, dict[str, Any]]:
        rows = self._table.tolist()
        keys, blank = INFO_KEYS, self._blank
        infos = {}
        for a in agents:
            # One zip over the car's record into a copy of a dict that has every key already
            # (no resizing as it fills): far cheaper than a key at a time.
            info = infos[a] = blank.copy()
            info.update(zip(keys, rows[index[a]]))
        if self.level == "full":
            lap_times = core.lap_times[0]
            first = len(FLOAT_KEYS)
            for a in agents:
                i = index[a]
                infos[a]["lap_times"] = list(lap_times[i])
                infos[a]["reward_terms"] = dict(zip(rewards.TERMS,
                                                    rows[i][first:first + len(REWARD_KEYS)]))
        return infos


@njit(cache=True)
def _info_kernel(weights, racing, progress, off_track, crashed, collided, step_overtakes,
                 step_overtaken, lap_completed, penalised, car_floats, car_counts, car_flags,
                 percent_per_metre, time, terms, reward, floats, ints,
                 flags):  # pragma: no cover
    # The reward terms (the same kernel as rewards.reward_terms) and the info fields of env
    # copy 0, in one compiled call; the car fields come as the core's blocks (race.CAR_*).
    speed, distance, start_distance = car_floats[3], car_floats[6], car_floats[7]
    last_lap, best_lap, frozen_until = car_floats[9], car_floats[10], car_floats[11]
    laps, resets, penalties = car_counts[0], car_counts[3], car_counts[4]
    overtakes, overtaken = car_counts[5], car_counts[6]
    defences, rank = car_counts[7], car_counts[8]
    done, finished = car_flags[0], car_flags[1]
    rewards._reward_kernel(weights, progress, speed, racing, off_track, crashed, collided,
                           step_overtakes, step_overtaken, lap_completed, terms, reward)
    leader = distance[0, 0]
    for i in range(distance.shape[1]):
        leader = max(leader, distance[0, i])
    first_term = 6
    for i in range(distance.shape[1]):
        floats[i, 0] = (distance[0, i] - start_distance[0, i]) * percent_per_metre
        floats[i, 1] = distance[0, i]
        last = last_lap[0, i]
        best = best_lap[0, i]
        floats[i, 2] = last if math.isfinite(last) else NO_LAP_TIME
        floats[i, 3] = best if math.isfinite(best) else NO_LAP_TIME
        floats[i, 4] = leader - distance[0, i]
        floats[i, 5] = time[0]
        for k in range(terms.shape[0]):
            floats[i, first_term + k] = terms[k, 0, i]
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
        flags[i, 6] = done[0, i]
