"""The PettingZoo env's actions: checking one step's actions and turning them into commands.

Continuous actions ``[steer, speed]`` in [-1, 1] are clipped and mapped to radians and m/s in
one compiled pass; discrete actions are indices into ``EnvConfig.discrete_actions``. Bad actions
get a clear error naming the agent and what is allowed. ``RacingEnv`` (``h2h_racing.envs.parallel``)
mixes ``EnvActions`` in.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
import numpy.typing as npt
from numba import njit


class EnvActions:
    """Action validation and scaling of ``RacingEnv`` (a mixin)."""

    def _parse_actions(self, actions: Any, agents: list[str],
                       ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        if not isinstance(actions, dict):
            raise ValueError(f"actions must be a dict keyed by agent, got "
                             f"{type(actions).__name__}; live agents: {agents}")
        if actions.keys() != self._live:
            missing = [a for a in agents if a not in actions]
            unknown = [a for a in actions if a not in self._index]
            if missing or unknown:
                raise ValueError(f"actions must have one entry per racing agent {agents} "
                                 f"(entries for cars whose race is over are ignored); missing "
                                 f"{missing}, unknown agents {unknown} (the agents are "
                                 f"{self.possible_agents})")
            # Actions for cars whose race is over are not read.
            actions = {a: actions[a] for a in agents}
        n = self._num_cars
        every = len(agents) == n
        if self._continuous:
            for a in agents:
                if not _real_numbers(actions[a]):
                    value = actions[a]
                    kind = (f"{type(value).__name__} of dtype {value.dtype}"
                            if hasattr(value, "dtype") else repr(value)[:80])
                    raise ValueError(f"action of {a} must be 2 numbers [steer, speed] (real: ints or "
                                     f"floats), got {kind}")
            try:
                values = np.array([actions[a] for a in agents], dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"actions must be arrays of 2 numbers [steer, speed]; got "
                                 f"{ {a: actions[a] for a in agents} }") from exc
            if values.shape != (len(agents), 2):
                bad = {a: np.shape(actions[a]) for a in agents if np.shape(actions[a]) != (2,)}
                raise ValueError(f"each action must have shape (2,) = [steer, speed]; "
                                 f"got shapes {bad}")
            # One fresh (2, 1, N) block per step: rows steer and speed, each (1, N) as the
            # core takes them (it keeps them as its last commands, so never reused).
            commands = np.empty((2, 1, len(agents)))
            if not _scale_actions(values, self._affine, commands):
                bad = {a: actions[a] for a, row in zip(agents, values)
                       if not np.isfinite(row).all()}
                raise ValueError(f"actions must be finite; got NaN or inf for {bad}")
            if every:
                return commands[0], commands[1]
            steer_values, speed_values = commands[0, 0], commands[1, 0]
        else:
            count = len(self.config.discrete_actions)
            chosen = []
            for a in agents:
                value = actions[a]
                if isinstance(value, np.ndarray) and value.ndim == 0:
                    value = value.item()
                integral = (isinstance(value, (numbers.Integral, np.integer))
                            or (isinstance(value, (float, np.floating)) and float(value).is_integer()))
                if isinstance(value, (bool, np.bool_)) or not integral or not 0 <= value < count:
                    raise ValueError(f"action of {a} must be an integer index in "
                                     f"[0, {count - 1}], got {value!r}")
                chosen.append(int(value))
            self._chosen = chosen
            steer_values = self._discrete_steer[chosen]
            speed_values = self._discrete_speed[chosen]
        if every:
            return steer_values.reshape(1, n), speed_values.reshape(1, n)
        # Finished cars keep a zero command (the core ignores them anyway).
        idx = [self._index[a] for a in agents]
        steer = np.zeros((1, n))
        speed = np.zeros((1, n))
        steer[0, idx] = steer_values
        speed[0, idx] = speed_values
        return steer, speed


_REAL_KINDS = frozenset("iuf")
_REAL_TYPES = (int, float, np.integer, np.floating)


def _real_numbers(value: Any) -> bool:
    """Whether ``value`` holds real numbers only: an int or float array (not masked), or a
    list or tuple of ints and floats. Strings, bools, complex numbers, dates and masked arrays
    are not actions, though numpy converts most of them to floats without a word."""
    if isinstance(value, np.ndarray):
        return value.dtype.kind in _REAL_KINDS and not isinstance(value, np.ma.MaskedArray)
    if isinstance(value, (list, tuple)):
        return all(isinstance(v, _REAL_TYPES) and not isinstance(v, (bool, np.bool_)) for v in value)
    try:  # a torch tensor, another array type, or a number (refused for its shape later)
        return np.asarray(value).dtype.kind in _REAL_KINDS and not isinstance(value, (bool, np.bool_))
    except (TypeError, ValueError):
        return False


@njit(cache=True)
def _scale_actions(values, affine, commands):  # pragma: no cover
    # Clip [steer, speed] to [-1, 1] and map to radians and m/s into commands[0] and
    # commands[1]; False if any is NaN or inf.
    steer_mid, steer_half, speed_mid, speed_half = affine[0], affine[1], affine[2], affine[3]
    for i in range(values.shape[0]):
        a = values[i, 0]
        b = values[i, 1]
        if not (math.isfinite(a) and math.isfinite(b)):
            return False
        steer = min(max(a, -1.0), 1.0) * steer_half
        if steer_mid != 0.0:
            steer += steer_mid
        commands[0, 0, i] = steer
        commands[1, 0, i] = speed_mid + min(max(b, -1.0), 1.0) * speed_half
    return True
