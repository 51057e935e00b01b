"""Small helpers that turn bad input into a clear ``ValueError``.

Every message names the offending parameter, shows the value received and
says what was expected, so a user never has to read a numpy traceback.
"""

from __future__ import annotations

import math
from typing import Any


def _fmt(value: Any) -> str:
    return repr(value)


def require_finite(name: str, value: Any, unit: str = "") -> float:
    """Return ``value`` as a float, or raise if it is not a finite number."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {_fmt(value)}: expected a finite number{_unit(unit)}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} = {_fmt(value)}: expected a finite number{_unit(unit)}")
    return number


def require_positive(name: str, value: Any, unit: str = "") -> float:
    number = require_finite(name, value, unit)
    if number <= 0.0:
        raise ValueError(f"{name} = {_fmt(value)}: expected a value > 0{_unit(unit)}")
    return number


def require_non_negative(name: str, value: Any, unit: str = "") -> float:
    number = require_finite(name, value, unit)
    if number < 0.0:
        raise ValueError(f"{name} = {_fmt(value)}: expected a value >= 0{_unit(unit)}")
    return number


def require_range(
    name: str,
    value: Any,
    lower: float,
    upper: float,
    unit: str = "",
    *,
    lower_open: bool = False,
    upper_open: bool = False,
) -> float:
    """Return ``value`` if it lies in the interval, else raise naming the interval."""
    number = require_finite(name, value, unit)
    below = number <= lower if lower_open else number < lower
    above = number >= upper if upper_open else number > upper
    if below or above:
        left = "(" if lower_open else "["
        right = ")" if upper_open else "]"
        raise ValueError(
            f"{name} = {_fmt(value)}: expected a value in {left}{lower:g}, {upper:g}{right}{_unit(unit)}"
        )
    return number


def require_int_range(name: str, value: Any, lower: int, upper: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int,)) and not (
        hasattr(value, "__index__")
    ):
        raise ValueError(f"{name} = {_fmt(value)}: expected an integer in [{lower}, {upper}]")
    number = int(value)
    if number < lower or number > upper:
        raise ValueError(f"{name} = {_fmt(value)}: expected an integer in [{lower}, {upper}]")
    return number


def require_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{name} = {_fmt(value)}: expected one of {', '.join(map(repr, choices))}")
    return value


def _unit(unit: str) -> str:
    return f" ({unit})" if unit else ""
