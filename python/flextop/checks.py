"""Checks of the numbers a caller gives by name (settings, builder arguments): each refusal
a :class:`~flextop.errors.FlextopError` that names the argument, the range it must lie in
and the value given."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import FlextopError, SettingsError


def real(value: Any) -> float | None:
    """``value`` as a finite float if it is a real number (not a bool, a string or a
    sequence), else ``None``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        return None
    try:
        v = float(value)
    except OverflowError:  # an int beyond any float
        return None
    return v if math.isfinite(v) else None


def bounds(low: float, high: float, brackets: str) -> str:
    """The interval ``low``–``high`` in words a reader checks at a glance: ``in (0, 1]``,
    or ``> 0`` where it is open above."""
    if high == math.inf:
        return f"{'≥' if brackets[0] == '[' else '>'} {low:g}"
    if low == -math.inf:
        return f"{'≤' if brackets[1] == ']' else '<'} {high:g}"
    return f"in {brackets[0]}{low:g}, {high:g}{brackets[1]}"


def number(name: str, value: Any, low: float = -math.inf, high: float = math.inf, brackets: str = "()", *,
           error: type[FlextopError] = SettingsError) -> float:
    """``value`` as a float: a finite real number within ``low``–``high`` (``brackets``
    ``"()"``, ``"[]"``, ``"[)"`` or ``"(]"``), or ``error`` naming ``name``."""
    v = real(value)
    if v is None:
        raise error(f"{name} must be a finite number, got {value!r}")
    above = low <= v if brackets[0] == "[" else low < v
    below = v <= high if brackets[1] == "]" else v < high
    if not (above and below):
        raise error(f"{name} must be {bounds(low, high, brackets)}, got {value!r}")
    return v


def whole(name: str, value: Any, low: int = 1, *, error: type[FlextopError] = SettingsError) -> int:
    """``value`` as an int: a whole number (not a bool) ≥ ``low``, or ``error`` naming
    ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < low:
        raise error(f"{name} must be a whole number ≥ {low}, got {value!r}")
    return int(value)
