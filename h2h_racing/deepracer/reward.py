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

A call can be given a time limit (``time_limit``, seconds; off by default): a function still
running when it passes, an endless loop say, is stopped with a ``RewardFunctionError`` naming
the file, the car and the step, instead of hanging the run. The limit is a ``SIGALRM`` interval
timer set and cleared around every call (about 15 microseconds a call, so it is off unless asked
for); it needs the main thread of a Unix process, and Ctrl-C still interrupts the function.

Real reward functions keep module-level state (previous steps, speeds), so each car gets its
own module instance: the file is executed once per car under a unique module name.
"""

from __future__ import annotations

import importlib.util
import itertools
import math
import numbers
import reprlib
import signal
import sys
import threading
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


class _TimeLimit(BaseException):
    """Raised inside a reward function by the ``SIGALRM`` handler when its time is up (a
    ``BaseException``, so that the function's own ``except Exception`` does not swallow it)."""


def _time_up(signum: int, frame: Any) -> None:
    raise _TimeLimit


def check_time_limit(time_limit: Any) -> float | None:
    """Return ``time_limit`` as a float, or raise ``ValueError`` unless it is None or a number
    in (0, 3600] seconds, and the caller is the main thread of a process that has ``SIGALRM``."""
    if time_limit is None:
        return None
    if (isinstance(time_limit, bool) or not isinstance(time_limit, (int, float))
            or not 0 < time_limit <= 3600):
        raise ValueError(f"reward_time_limit must be None (no limit) or a number of seconds in "
                         f"(0, 3600], got {time_limit!r}")
    if not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        raise ValueError("reward_time_limit needs the main thread of a Unix process (it uses a "
                         "SIGALRM timer); leave it None here")
    return float(time_limit)


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
        time_limit: Longest a call may run [s], None for no limit (see the module docstring).

    Raises:
        FileNotFoundError: The file does not exist.
        TypeError: It defines no ``reward_function``; ``source`` is neither path nor
            callable.
        RewardFunctionError: Importing the file raised.
    """

    def __init__(self, source: str | Path | Callable[[dict[str, Any]], Any], num_cars: int,
                 agents: list[str] | None = None, time_limit: float | None = None) -> None:
        self.time_limit = check_time_limit(time_limit)
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
            if self.time_limit is None:
                value = self.functions[car](copy_params(params))
            else:
                value = self._call_limited(car, copy_params(params))
        except KeyboardInterrupt:
            raise
        except _TimeLimit:
            raise self._error(car, params, f"ran past its time limit of {self.time_limit:g} s "
                                           f"(reward_time_limit)") from None
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

    def _call_limited(self, car: int, params: dict[str, Any]) -> Any:
        """Call car ``car``'s function with a ``SIGALRM`` timer of ``time_limit`` armed."""
        previous = signal.signal(signal.SIGALRM, _time_up)
        try:
            signal.setitimer(signal.ITIMER_REAL, self.time_limit)
            try:
                return self.functions[car](params)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
        finally:
            signal.signal(signal.SIGALRM, previous)

    def _error(self, car: int, params: dict[str, Any], what: str) -> RewardFunctionError:
        return RewardFunctionError(
            f"reward function {self.source} {what} for {self.agents[car]} at step "
            f"{params.get('steps')}; fix the function so that it returns a finite number. "
            f"params: {_summary(params)}")
