"""Validation helpers shared by the config dataclasses: each failure names the field, the value and what is allowed."""

from __future__ import annotations

import math
from typing import Any


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
