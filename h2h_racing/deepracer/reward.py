"""Load and call DeepRacer reward functions, once per car, with DeepRacer's checks.

A reward file is a Python module defining ``reward_function(params)``. DeepRacer calls it as
``float(reward_function(copy.deepcopy(params)))`` (simapp ``agent_ctrl/rollout_agent_ctrl.py``)
and stops the job with ``RewardFunctionError`` when the result is not a finite number; its
validator also requires ``-1e5 <= reward <= 1e5`` (``reward_func_validator``), which we
report as a warning. We are stricter than ``float()`` in one way: the result must be a real
number (``int``, ``float`` or a numpy number), so that a string such as ``"1.0"`` or a bool
(``return params["all_wheels_on_track"]`` is a mistake) is an error and not a silent cast.

Anything the user's code raises, ``sys.exit()`` included, becomes a ``RewardFunctionError``
naming the file, the car and the step; only ``KeyboardInterrupt`` (Ctrl-C) passes through.

Real reward functions keep module-level state (previous steps, speeds), so each car gets its
own module instance: the file is executed once per car under a unique module name.
"""

from __future__ import annotations

import importlib.util
import itertools
import math
import numbers
import reprlib
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from h2h_racing.deepracer.params import copy_params

REWARD_LIMIT = 1e5
"""DeepRacer's validator accepts rewards in [-1e5, 1e5]; outside it we warn (once per car)."""

_module_ids = itertools.count()


class RewardFunctionError(RuntimeError):
    """A reward function raised, or returned something that is not a finite number."""


def _load_function(path: Path, car: int) -> Callable[[dict[str, Any]], Any]:
    """Execute ``path`` as a fresh module and return its ``reward_function``."""
    if not path.is_file():
        raise FileNotFoundError(f"reward function file {str(path)!r} does not exist; pass the "
                                f"path of a .py file that defines reward_function(params)")
    name = f"h2h_racing_reward_{path.stem}_{car}_{next(_module_ids)}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ValueError(f"cannot import {str(path)!r} as a Python module; expected a .py file "
                         f"that defines reward_function(params)")
    module = importlib.util.module_from_spec(spec)
    # Registered so that tracebacks, pickling of functions and dataclasses inside the file
    # work; the unique name keeps each car's module-level state separate.
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # sys.exit() in the file too: an error, not a silent exit
        del sys.modules[name]
        raise RewardFunctionError(f"importing reward function file {str(path)!r} (car {car}) "
                                  f"failed: {_describe(exc)}") from exc
    function = getattr(module, "reward_function", None)
    if not callable(function):
        raise TypeError(f"{str(path)!r} must define a function reward_function(params); "
                         f"got {type(function).__name__} for reward_function")
    return function


def _describe(exc: BaseException) -> str:
    """``SystemExit: 3``, or the bare type name when the exception has no message."""
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__


def _summary(params: dict[str, Any]) -> str:
    """Params without the long lists (waypoints), for error messages."""
    parts = []
    for key, value in params.items():
        if key == "waypoints":
            parts.append(f"'waypoints': <{len(value)} points>")
        else:
            parts.append(f"{key!r}: {value!r}")
    return "{" + ", ".join(parts) + "}"


class DeepRacerReward:
    """DeepRacer reward functions for N cars.

    Args:
        source: Path of a ``.py`` file defining ``reward_function(params)`` (loaded once per
            car, so module-level state is per car), or a callable ``f(params)`` shared by
            every car.
        num_cars: Number of cars N.
        agents: Names of the cars for messages; defaults to ``car_0`` ... ``car_{N-1}``.

    Raises:
        FileNotFoundError: The file does not exist.
        TypeError: It defines no ``reward_function``; ``source`` is neither path nor
            callable.
        RewardFunctionError: Importing the file raised.
    """

    def __init__(self, source: str | Path | Callable[[dict[str, Any]], Any], num_cars: int,
                 agents: list[str] | None = None) -> None:
        self.agents = agents or [f"car_{i}" for i in range(num_cars)]
        if callable(source):
            self.source = getattr(source, "__qualname__", repr(source))
            self.functions = [source] * num_cars
        elif isinstance(source, (str, Path)):
            path = Path(source).expanduser().resolve()
            self.source = str(path)
            self.functions = [_load_function(path, car) for car in range(num_cars)]
        else:
            raise TypeError(f"reward_function must be a path to a .py file or a callable, "
                             f"got {type(source).__name__}")
        self._warned = [False] * num_cars

    def __call__(self, car: int, params: dict[str, Any]) -> float:
        """Return car ``car``'s reward for ``params`` (the function gets a deep copy).

        Raises:
            RewardFunctionError: The function raised (``sys.exit()`` included), or returned
                a non-number (a str or bool too), NaN, inf or an int too large for a float;
                the message names the file, the car, the step and the params.
        """
        try:
            value = self.functions[car](copy_params(params))
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # sys.exit() too: an error, not a silent end of the run
            raise self._error(car, params, f"raised {_describe(exc)}") from exc
        if not isinstance(value, numbers.Real) or isinstance(value, bool):
            raise self._error(car, params, f"returned {reprlib.repr(value)} "
                                           f"({type(value).__name__}), expected a number")
        try:
            reward = float(value)
        except OverflowError:
            raise self._error(car, params, f"returned {reprlib.repr(value)}, an int too large "
                                           f"for a float, expected a finite number") from None
        if not math.isfinite(reward):
            raise self._error(car, params, f"returned {reward!r}, expected a finite number")
        if abs(reward) > REWARD_LIMIT and not self._warned[car]:
            self._warned[car] = True
            warnings.warn(f"reward function {self.source} returned {reward!r} for "
                          f"{self.agents[car]} at step {params.get('steps')}; DeepRacer only "
                          f"accepts rewards in [-{REWARD_LIMIT:g}, {REWARD_LIMIT:g}] (warned "
                          f"once per car)", RuntimeWarning, stacklevel=2)
        return reward

    def _error(self, car: int, params: dict[str, Any], what: str) -> RewardFunctionError:
        return RewardFunctionError(
            f"reward function {self.source} {what} for {self.agents[car]} at step "
            f"{params.get('steps')}; fix the function so that it returns a finite number. "
            f"params: {_summary(params)}")
