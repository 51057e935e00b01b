"""Small helpers that turn bad input into a clear ``ValueError``.

Every message names the offending parameter, shows the value received and
says what was expected, so a user never has to read a numpy traceback.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


def _fmt(value: Any) -> str:
    """``repr(value)``, shortened: a 400-digit integer from a file is shown by its size."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value).bit_length() > 256:
        return f"an integer of about {int(abs(value).bit_length() * 0.30103)} digits"
    text = repr(value)
    return text if len(text) <= 200 else text[:197] + "..."


def require_finite(name: str, value: Any, unit: str = "") -> float:
    """Return ``value`` as a float, or raise if it is not a finite number.

    Strings are refused although ``float("10")`` works: a number that arrives as text (a
    config value read without parsing) is a mistake to report, not to guess at."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name} = {_fmt(value)}: expected a finite number{_unit(unit)}, not a string")
    if isinstance(value, (bool, np.bool_)):
        # float(True) is 1.0: a flag passed where a quantity belongs would run as 1 V, 1 m, ...
        raise ValueError(f"{name} = {_fmt(value)}: expected a finite number{_unit(unit)}, not a boolean")
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        # (OverflowError: an integer past float's range, e.g. 10**400 from a JSON file)
        raise ValueError(f"{name} = {_fmt(value)}: expected a finite number{_unit(unit)}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} = {_fmt(value)}: expected a finite number{_unit(unit)}")
    return number


_KINDS = {"b": "booleans", "U": "strings", "S": "bytes", "c": "complex numbers", "O": "objects"}


def require_float_array(name: str, value: Any, unit: str = "") -> np.ndarray:
    """``value`` (a number or an array of numbers) as a float array, or ``ValueError`` naming
    ``name``: ``np.asarray(x, dtype=float)`` took ``"0.5"`` and ``True`` as numbers (a flag
    ran as duty 1), dropped an imaginary part with a warning only, and raised an unnamed
    ``OverflowError`` for ``10**400``. Finiteness is the caller's check (it names the index)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} = {_fmt(value)}: expected numbers{_unit(unit)}") from None
    if array.dtype.kind not in "iuf":
        what = _KINDS.get(array.dtype.kind, str(array.dtype))
        if array.dtype.kind == "O":
            what += " (an integer beyond float's range, or numbers mixed with other things)"
        raise ValueError(f"{name} = {_fmt(value)}: expected numbers{_unit(unit)}, not {what}")
    return array.astype(float, copy=False)


def require_options(options: Any) -> dict[str, Any]:
    """``reset(options=...)``: a dict (a copy is returned) or ``None`` (an empty dict)."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"reset options = {_fmt(options)}: expected a dict (or None)")
    return dict(options)


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
    why: str = "",
) -> float:
    """Return ``value`` if it lies in the interval, else raise naming the interval.

    ``why``: the physical reason for the bounds, appended to the message.
    """
    left = "(" if lower_open else "["
    right = ")" if upper_open else "]"
    expected = f"expected a value in {left}{lower:g}, {upper:g}{right}{_unit(unit)}{_why(why)}"
    try:
        number = require_finite(name, value, unit)
    except ValueError:
        text = (
            ", not a string"
            if isinstance(value, (str, bytes))
            else ", not a boolean"
            if isinstance(value, (bool, np.bool_))
            else ", a single number, not an array or sequence"
            if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim > 0)
            else ""
        )
        raise ValueError(f"{name} = {_fmt(value)}: {expected}{text}") from None
    below = number <= lower if lower_open else number < lower
    above = number >= upper if upper_open else number > upper
    if below or above:
        raise ValueError(f"{name} = {_fmt(value)}: {expected}")
    return number


def require_int_range(name: str, value: Any, lower: int, upper: int) -> int:
    """``value`` as an ``int`` in [lower, upper]: a Python or numpy integer (``operator.index``
    takes them and nothing else: a 0-d array ``2.9`` was truncated to 2 and ``True`` read as 1)."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iu":
        value = value.item()  # a 0-d integer array, as numpy hands out
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} = {_fmt(value)}: expected an integer in [{lower}, {upper}]")
    try:
        number = operator.index(value)
    except TypeError:
        raise ValueError(f"{name} = {_fmt(value)}: expected an integer in [{lower}, {upper}]") from None
    if number < lower or number > upper:
        raise ValueError(f"{name} = {_fmt(value)}: expected an integer in [{lower}, {upper}]")
    return number


def require_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{name} = {_fmt(value)}: expected one of {', '.join(map(repr, choices))}")
    return value


def _numeric_array(name: str, value: Any, expected: str) -> np.ndarray:
    """``value`` as an int or float array (any shape), else a ``ValueError``: strings,
    booleans, complex or object values are refused, never cast."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name} = {value!r}: a string; {expected}")
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r}: {expected}") from None
    if a.dtype.kind not in "fiu":
        raise ValueError(f"{name} of dtype {a.dtype}: {expected}")
    return a


def require_action(action: Any, n: int) -> np.ndarray:
    """An env action as a float64 array of shape ``(n,)``, or a ``ValueError`` naming the expected shape.

    Accepted: a numeric array or sequence of shape ``(n,)`` (any float or int dtype: what
    Gymnasium's and SB3's checkers send is float32 or float64), and for ``n == 1`` a plain
    number. Refused: other shapes (``(2,)`` to a single env, ``(1, 1)``, ``(0,)``), strings,
    booleans, complex or object values, and NaN/inf.
    """
    # Fast path for what every well-behaved client sends (this runs on every env step).
    if type(action) is np.ndarray and action.shape == (n,) and action.dtype.kind == "f":
        a = action.astype(np.float64)
        if n == 1:
            if math.isfinite(a[0]):
                return a
        elif np.isfinite(a).all():
            return a
    expected = (
        f"expected a float array of shape ({n},) (dtype float32 or float64) with finite values (clipped to [-1, 1])"
    )
    a = _numeric_array("action", action, expected)
    if a.shape == () and n == 1:
        a = a.reshape(1)
    if a.shape != (n,):
        raise ValueError(f"action has shape {a.shape}: {expected}")
    a = a.astype(np.float64)
    if not np.isfinite(a).all():
        raise ValueError(f"action = {action!r}: {expected}")
    return a


def require_scalar_action(action: Any) -> float:
    """:func:`require_action` for one actuator, as a Python float (the single envs' step).

    Same acceptance and errors; the fast path skips the array conversion, which costs a
    tenth of an env step.
    """
    if type(action) is np.ndarray and action.shape == (1,) and action.dtype.kind == "f":
        a = float(action[0])
        if math.isfinite(a):
            return a
    return float(require_action(action, 1)[0])


def require_actions(actions: Any, num_envs: int, width: int = 1, ignored: np.ndarray | None = None) -> np.ndarray:
    """A vector env's actions as a float64 array of shape ``(num_envs, width)``, or a
    ``ValueError`` naming the expected shape: the batch of :func:`require_action`'s actions.
    For one actuator per env ``(num_envs,)`` is accepted too. Refused: other shapes (a
    transposed ``(1, num_envs)`` included), strings, booleans, complex or object values,
    NaN/inf, except in the rows ``ignored`` marks (sub-envs this step resets and whose
    actions it ignores, as Gymnasium's vector envs do), which come back as 0."""
    m, n = num_envs, width
    if type(actions) is np.ndarray and actions.shape == (m, n) and actions.dtype.kind == "f":
        a = actions.astype(np.float64)
        if np.isfinite(a).all():
            return a
    shapes = f"({m}, {n})" + (f" or ({m},)" if n == 1 else "")
    expected = f"expected a float array of shape {shapes} with finite values (clipped to [-1, 1])"
    a = _numeric_array("actions", actions, expected)
    if n == 1 and a.shape == (m,):
        a = a.reshape(m, 1)
    if a.shape != (m, n):
        raise ValueError(f"actions have shape {a.shape}: {expected}")
    a = a.astype(np.float64)
    if ignored is not None and ignored.any():
        a[ignored] = 0.0
    if not np.isfinite(a).all():
        i, j = (int(k[0]) for k in np.nonzero(~np.isfinite(a)))
        where = f"{i}" if n == 1 else f"{i}, {j}"
        raise ValueError(f"actions[{where}] = {float(a[i, j])!r}: {expected}")
    return a


def _unit(unit: str) -> str:
    return f" ({unit})" if unit else ""


def _why(why: str) -> str:
    return f": {why}" if why else ""


@dataclass(frozen=True)
class Bound:
    """The physical range of one or more numeric fields of a parameter dataclass: one row of
    its ``_BOUNDS`` table, checked by :func:`check_bounds` (the message gives ``why``)."""

    fields: tuple[str, ...]
    lower: float
    upper: float
    unit: str = ""
    why: str = ""
    lower_open: bool = False
    upper_open: bool = False


def check_bounds(obj: Any, bounds: Sequence[Bound]) -> None:
    """:func:`require_range` on every field of every row of ``bounds``, named ``Class.field``."""
    owner = type(obj).__name__
    for b in bounds:
        for name in b.fields:
            require_range(
                f"{owner}.{name}",
                getattr(obj, name),
                b.lower,
                b.upper,
                b.unit,
                lower_open=b.lower_open,
                upper_open=b.upper_open,
                why=b.why,
            )
