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


def finite(value: int | float) -> bool:
    """Whether a number is finite and a float can hold it (an int past a double's range
    overflows math.isfinite)."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def shown_value(value: Any) -> str:
    """``value`` for a message: its repr, an integer past a few dozen digits by its power of
    ten (Python refuses to print one of more than 4,300 digits, and it would fill the line)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**30:
        return f"an integer of about 10^{int(abs(value).bit_length() * math.log10(2))}"
    text = repr(value)
    return text if len(text) <= 80 else text[:79] + "…"


def real(name: str, value: Any, *, low: float | None = None, low_open: bool = False,
         high: float | None = None) -> float:
    """``value`` as a finite float in [low, high] (``low_open``: above low)."""
    if isinstance(value, bool) or not isinstance(value, _REAL):
        raise InputError(f"{name} must be a number (an int or a float), got {shown_value(value)}")
    x = float(value) if finite(value) else math.inf
    if not math.isfinite(x) or (low is not None and (x <= low if low_open else x < low)) \
            or (high is not None and x > high):
        if low is None and high is None:         # (any finite number: "in [-inf, inf]" misled)
            raise InputError(f"{name} must be a finite number, got {shown_value(value)}")
        bounds = f"{'(' if low_open else '['}{'-inf' if low is None else f'{low:g}'}, " \
                 f"{'inf)' if high is None else f'{high:g}]'}"
        raise InputError(f"{name} must be a finite number in {bounds}, got {shown_value(value)}")
    return x


def real_array(value: Any) -> np.ndarray:
    """``value`` (an array, or nested lists) as a float64 array where it holds real numbers
    (integers or floats); TypeError naming what it holds otherwise, where numpy would read
    strings as numbers, True as 1, timedelta64 as an integer, or drop a complex part with a
    warning. A ragged list is numpy's ValueError."""
    raw = np.asarray(value)
    if raw.dtype.kind not in "iuf":
        raise TypeError("complex numbers" if raw.dtype.kind == "c" else f"an array of {raw.dtype}")
    return np.asarray(raw, dtype=np.float64)


def flag(name: str, value: Any) -> bool:
    """``value`` where it is True or False (numpy's bool too); any other value, which Python
    would read as true or false ("yes", None, 0), is an `InputError` naming ``name``."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def whole(name: str, value: Any, *, low: int = 0, high: int | None = None) -> int:
    """``value`` as an int in [low, high]."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or value < low or (high is not None and value > high):
        raise InputError(f"{name} must be a whole number in [{low}, "
                         f"{'inf)' if high is None else f'{high:,}]'}, got {shown_value(value)}")
    return int(value)


def steps_past_limit(steps: int) -> str | None:
    """The message for a derivation length past MAX_DERIVATION_STEPS (None within it): the
    parser says it at the file's value, `derive` for -n and the API's steps. A huge one is
    shown by its power of ten (an integer of 4,300 digits would fill the line)."""
    from .constants import MAX_DERIVATION_STEPS

    if steps <= MAX_DERIVATION_STEPS:
        return None
    shown = f"{steps:,}" if steps < 10**15 else f"about 10^{len(str(int(steps))) - 1}"
    return (f"derivation length {shown} is more than the limit of {MAX_DERIVATION_STEPS:,} "
            "steps; expected a smaller derivation_length or -n")


def digits_past_limit(literal: str) -> int | None:
    """The significant digits of a decimal integer ``literal`` (sign and leading zeros
    aside) where Python would refuse to convert them (`sys.get_int_max_str_digits`, 4300
    by default: int() raises ValueError), else None."""
    digits = len(literal.lstrip("+-").lstrip("0"))
    limit = sys.get_int_max_str_digits()
    return digits if limit and digits > limit else None


def did_you_mean(word: str, choices) -> str:
    """" (did you mean 'X'?)" for the choice closest to a misspelled ``word`` (difflib's
    ratio >= 0.6), "" where none is close: for the messages that refuse a name."""
    import difflib

    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""
