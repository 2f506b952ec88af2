"""Validation helpers shared by the config dataclasses: each failure names the field, the value and what is allowed."""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def _check(condition: bool, owner: str, name: str, value: Any, allowed: str) -> None:
    """Raise a ValueError naming the field, the value and what is allowed."""
    if not condition:
        raise ValueError(f"{owner}.{name} must be {allowed}, got {value!r}")


def _is_int(value: Any) -> bool:
    """Whether ``value`` is an int (a bool is not a count, though Python calls it an int)."""
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    """Whether ``value`` is an int or a float (not a bool, a string or None)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite_positive(owner: str, name: str, value: float) -> None:
    _check(
        _is_number(value) and math.isfinite(value) and value > 0,
        owner,
        name,
        value,
        "a finite number > 0",
    )


def check_seed(seed: Any) -> None:
    """Raise ``ValueError`` unless ``seed`` is None or an int >= 0 (a bool, a negative int or a
    list is not a seed, though numpy takes lists).

    >>> check_seed(-1)
    Traceback (most recent call last):
    ...
    ValueError: reset(seed=...) must be None or an int >= 0, got -1
    """
    if seed is not None and not (isinstance(seed, (int, np.integer))
                                 and not isinstance(seed, (bool, np.bool_)) and seed >= 0):
        shown = repr(seed) if len(repr(seed)) <= 60 else f"a {type(seed).__name__}"
        raise ValueError(f"reset(seed=...) must be None or an int >= 0, got {shown}")
