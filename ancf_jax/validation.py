"""Input checks that run on the host, before anything is traced or compiled."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import ModelError


def coincide_tolerance(size: float) -> float:
    """Distance [m] at or below which two points of a model of ``size`` [m] (its largest
    coordinate) count as coinciding at the initial state: a spring's ends that must
    start apart, a fixed joint's body that must start at its point (the model builder
    and the scenario checker apply this one rule)."""
    return 1e-9 * float(size) + 1e-12


def _as_float(name: str, value: Any) -> float:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be a real number, got {value!r}") from None
    if arr.shape != ():
        raise ModelError(f"{name} must be a scalar, got shape {arr.shape}")
    return float(arr)


def check_positive(name: str, value: Any, unit: str = "") -> float:
    """Return ``value`` as a float if it is finite and > 0, else raise ModelError."""
    x = _as_float(name, value)
    if not math.isfinite(x) or x <= 0.0:
        u = f" {unit}" if unit else ""
        raise ModelError(f"{name} must be a finite number > 0{u}, got {value!r}")
    return x


def check_nonnegative(name: str, value: Any, unit: str = "") -> float:
    """Return ``value`` as a float if it is finite and >= 0, else raise ModelError."""
    x = _as_float(name, value)
    if not math.isfinite(x) or x < 0.0:
        u = f" {unit}" if unit else ""
        raise ModelError(f"{name} must be a finite number >= 0{u}, got {value!r}")
    return x


def check_finite(name: str, value: Any) -> np.ndarray:
    """Return ``value`` as a float array if every entry is finite."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be numeric, got {value!r}") from None
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{name} must be finite, got {value!r}")
    return arr


def check_vector(name: str, value: Any, size: int) -> np.ndarray:
    """Return ``value`` as a finite float vector of the given size."""
    arr = check_finite(name, value)
    if arr.shape != (size,):
        raise ModelError(f"{name} must be a vector of {size} numbers, got {value!r}")
    return arr


def check_count(name: str, value: Any, minimum: int = 1, maximum: int | None = None) -> int:
    """Return ``value`` as an int if it is an integer in [minimum, maximum]."""
    accepted = f"an integer >= {minimum}" if maximum is None else f"an integer in {minimum}..{maximum}"
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise ModelError(f"{name} must be {accepted}, got {value!r}")
    if value < minimum or (maximum is not None and value > maximum):
        raise ModelError(f"{name} must be {accepted}, got {value!r}")
    return int(value)


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """Return ``value`` if it is one of ``choices``."""
    if value not in choices:
        raise ModelError(f"{name} must be one of {', '.join(map(repr, choices))}, got {value!r}")
    return value
