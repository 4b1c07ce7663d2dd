"""Checks of argument values shared by every layer (the API's `plantlod.arguments`,
`simplify.pipeline.Options`): each gives the value in its type or raises `InputError`
naming the argument."""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np

from .errors import InputError

_REAL = (int, float, np.integer, np.floating)


def real(name: str, value: Any, *, low: float | None = None, low_open: bool = False,
         high: float | None = None) -> float:
    """``value`` as a finite float in [low, high] (``low_open``: above low)."""
    if isinstance(value, bool) or not isinstance(value, _REAL):
        raise InputError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except OverflowError:                     # an int past a double's range
        x = math.inf
    if not math.isfinite(x) or (low is not None and (x <= low if low_open else x < low)) \
            or (high is not None and x > high):
        bounds = f"{'(' if low_open else '['}{'-inf' if low is None else f'{low:g}'}, " \
                 f"{'inf' if high is None else f'{high:g}'}]"
        raise InputError(f"{name} must be a finite number in {bounds}, got {value!r}")
    return x


def whole(name: str, value: Any, *, low: int = 0, high: int | None = None) -> int:
    """``value`` as an int in [low, high]."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or value < low or (high is not None and value > high):
        raise InputError(f"{name} must be a whole number in [{low}, "
                         f"{'inf' if high is None else f'{high:,}'}], got {value!r}")
    return int(value)


def digits_past_limit(literal: str) -> int | None:
    """The significant digits of a decimal integer ``literal`` (sign and leading zeros
    aside) where Python would refuse to convert them (`sys.get_int_max_str_digits`, 4300
    by default: int() raises ValueError), else None."""
    digits = len(literal.lstrip("+-").lstrip("0"))
    limit = sys.get_int_max_str_digits()
    return digits if limit and digits > limit else None
