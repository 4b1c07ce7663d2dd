"""Winds: world-frame wind vectors over time (m/s, z up).

A wind is any object with ``sample(times) -> (K, 3)``: ``times`` is a (K,)
float64 array of seconds, the result the wind vector V(t) at each of them. The
simulation samples it at t_{k-1} = (k - 1) dt for step k.

- `ConstantWind(vector)`: the same vector at every time.
- `KeyframeWind(times, vectors)`: piecewise linear between keyframes, held
  constant before the first and after the last; `KeyframeWind.from_csv` reads
  rows ``t,vx,vy,vz``.
- `wind_from_speed(speed, direction_deg)`: a horizontal constant wind blowing
  toward the azimuth ``direction_deg``, measured in the ground plane from +x
  toward +y (0 = +x, 90 = +y).
- `GustyWind(base, seed, strength)`: any wind scaled by a seeded, repeatable gust
  factor (see its docstring).
"""

from __future__ import annotations

import math
from typing import Protocol, TextIO

import numpy as np

from .constants import (GUST_COMPONENTS, GUST_MAX_FREQUENCY, GUST_MIN_FREQUENCY, MAX_WIND_SPEED,
                        SPEED_ROUNDING)
from plantlod.lsys.checks import real, real_array, shown_value, whole
from plantlod.lsys.errors import InputError, RunFailure


class Wind(Protocol):
    """What the simulation needs from a wind."""

    def sample(self, times: np.ndarray) -> np.ndarray:
        """Wind vectors (K, 3) float64, m/s, world frame, at ``times`` (K,) s."""
        ...


def wind_samples(wind: Wind, times: np.ndarray) -> np.ndarray:
    """(K, 3) m/s: ``wind.sample(times)`` for K = len(times), checked, for a wind object of
    the caller's too: one whose sample() fails, or gives no real numbers, another shape, or
    values that are not finite is a RunFailure; one faster than MAX_WIND_SPEED an InputError,
    as every wind is (`check_speed`)."""
    try:
        out = real_array(wind.sample(times))     # (strings were read as numbers)
    except (TypeError, ValueError) as exc:
        raise RunFailure(f"the wind gave no array of numbers ({exc})") from None
    except Exception as exc:                        # the caller's own object failed
        raise RunFailure(f"the wind's sample() failed: {type(exc).__name__}: {exc}") from None
    if out.shape != (len(times), 3):
        raise RunFailure(f"the wind gave an array of shape {out.shape}, expected ({len(times)}, 3)")
    if not np.all(np.isfinite(out)):
        raise RunFailure("the wind gave values that are not finite numbers")
    if len(out):
        check_speed(float(np.linalg.norm(out, axis=1).max()), "a wind object's sample")
    return out


def _times(times) -> np.ndarray:
    return np.asarray(times, dtype=np.float64).reshape(-1)


class ConstantWind:
    """The same wind vector (3,) m/s at every time."""

    def __init__(self, vector):
        try:
            v = np.asarray(vector, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):          # ConstantWind("abc")
            v = np.zeros(0)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise InputError(f"a wind vector must be three finite numbers, got {vector!r}")
        check_speed(float(np.linalg.norm(v)), "a wind")
        self.vector = v

    def sample(self, times) -> np.ndarray:
        t = _times(times)
        return np.broadcast_to(self.vector, (len(t), 3)).copy()

    def __repr__(self) -> str:
        return "ConstantWind(({:g}, {:g}, {:g}))".format(*self.vector)


def check_speed(speed: float, what: str, *where) -> None:
    """InputError where ``what`` blows faster than MAX_WIND_SPEED m/s (every wind of a run:
    a vector, a keyframe, a gust's peak); ``where``: its file, line and column, if any."""
    if speed > MAX_WIND_SPEED * (1.0 + SPEED_ROUNDING):   # (|(v cos a, v sin a)| may round up)
        raise InputError(f"{what} of {speed:.12g} m/s; expected at most {MAX_WIND_SPEED:g} m/s",
                         *where)


def wind_from_speed(speed: float, direction_deg: float) -> ConstantWind:
    """A horizontal wind of ``speed`` m/s blowing toward azimuth ``direction_deg``.

    The azimuth is measured in the ground plane from +x toward +y, in degrees:
    0 blows toward +x, 90 toward +y. Multiples of 90 degrees give exact axis
    vectors (no 6e-17 crumbs from cos 90°), so a wind along an axis keeps a
    tree that is symmetric about that axis exactly symmetric.
    """
    speed = float(speed)
    direction_deg = float(direction_deg)
    if not (math.isfinite(speed) and 0 <= speed <= MAX_WIND_SPEED):
        raise InputError(f"wind speed must be a finite number in [0, {MAX_WIND_SPEED:g}] m/s, "
                         f"got {speed:g}")
    if not math.isfinite(direction_deg):
        raise InputError(f"wind direction must be a finite number of degrees, got {direction_deg:g}")
    turned = direction_deg % 360.0
    exact = {0.0: (1.0, 0.0), 90.0: (0.0, 1.0), 180.0: (-1.0, 0.0), 270.0: (0.0, -1.0)}
    if turned in exact:
        cx, cy = exact[turned]
    else:
        a = math.radians(turned)
        cx, cy = math.cos(a), math.sin(a)
    return ConstantWind((speed * cx, speed * cy, 0.0))


class KeyframeWind:
    """Wind from keyframes, linearly interpolated, held beyond the first and last.

    times   : (K,) float64 s, strictly increasing, K >= 1
    vectors : (K, 3) float64 m/s
    """

    def __init__(self, times, vectors):
        try:
            t = np.asarray(times, dtype=np.float64).reshape(-1)
            v = np.asarray(vectors, dtype=np.float64)
        except (TypeError, ValueError):    # KeyframeWind("a", "b"), ragged rows: numpy's own error
            raise InputError("keyframe wind needs numbers: K times and one (vx, vy, vz) per "
                             f"time, got {shown_value(times)} and {shown_value(vectors)}") from None
        if v.shape != (len(t), 3):
            raise InputError(f"keyframe wind needs one (vx, vy, vz) per time, got shape {v.shape}")
        if len(t) == 0:
            raise InputError("keyframe wind needs at least one keyframe")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise InputError("keyframe times and wind vectors must be finite")
        if np.any(np.diff(t) <= 0):
            raise InputError("keyframe times must be strictly increasing")
        check_speed(float(np.linalg.norm(v, axis=1).max()), "a keyframe wind")
        self.times = t
        self.vectors = v

    def sample(self, times) -> np.ndarray:
        t = _times(times)
        out = np.empty((len(t), 3))
        for axis in range(3):
            out[:, axis] = np.interp(t, self.times, self.vectors[:, axis])
        return out

    @classmethod
    def from_csv(cls, stream: TextIO, source: str | None = None) -> "KeyframeWind":
        """Read keyframes ``t,vx,vy,vz`` (s, m/s), one per line.

        The first non-blank line may be a header (a line of which no field is a
        number, e.g. ``t,vx,vy,vz``). Blank lines and lines starting with ``#``
        are skipped. Times must be finite and strictly increasing. Errors are
        `InputError` at the line and column of the offending field.
        """
        times: list[float] = []
        vectors: list[tuple[float, float, float]] = []
        first_content = True
        last_line = 0
        for line_no, raw in enumerate(stream, start=1):
            last_line = line_no
            line = raw.rstrip("\r\n")
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            fields = line.split(",")
            starts = _field_starts(fields)
            if first_content:
                first_content = False
                if all(_parse_float(f) is None for f in fields):
                    continue   # header line (no field a number: a row whose time alone is
                    # not, as after a second byte-order mark, was dropped as one)
            if len(fields) != 4:
                raise InputError(f"expected 4 numbers t,vx,vy,vz, got {len(fields)} field(s)",
                                 source, line_no, 1)
            values = []
            for name, text, col in zip(("t", "vx", "vy", "vz"), fields, starts):
                value = _parse_float(text)
                if value is None or not math.isfinite(value):
                    raise InputError(f"expected a finite number for {name}, got {text.strip()!r}",
                                     source, line_no, col)
                values.append(value)
            check_speed(math.hypot(*values[1:]), "a wind", source, line_no, starts[1])
            if times and values[0] <= times[-1]:
                raise InputError(f"times must be strictly increasing: {values[0]:g} after {times[-1]:g}",
                                 source, line_no, starts[0])
            times.append(values[0])
            vectors.append((values[1], values[2], values[3]))
        if not times:
            raise InputError("expected at least one keyframe row t,vx,vy,vz", source,
                             max(last_line, 1), 1)
        return cls(times, vectors)

    def __repr__(self) -> str:
        return f"KeyframeWind({len(self.times)} keyframes)"


def _field_starts(fields: list[str]) -> list[int]:
    """1-based column of each comma-separated field's first non-blank character."""
    cols, pos = [], 1
    for f in fields:
        cols.append(pos + (len(f) - len(f.lstrip())))
        pos += len(f) + 1
    return cols


def _parse_float(text: str) -> float | None:
    text = text.strip()
    if not text or "_" in text or not text.isascii():     # (float() reads "١" and "１" as 1)
        return None
    try:
        return float(text)
    except ValueError:
        return None


def gust_peak_factor(strength: float, components: int = GUST_COMPONENTS) -> float:
    """An upper bound of `GustyWind`'s factor max(0, 1 + strength g(t)) at any time: g is
    sqrt(2 / M) times a sum of M sines, so |g| <= sqrt(2 M) and the factor is at most
    1 + strength sqrt(2 M) (the gusts a scene's levels must be fitted for, checked before
    any run)."""
    return 1.0 + float(strength) * math.sqrt(2.0 * components)


class GustyWind:
    """A base wind scaled by a seeded gust factor: V(t) = base(t) * max(0, 1 + strength * g(t)).

    g(t) = sqrt(2 / M) * sum_{m=1..M} sin(2 pi f_m t + p_m) is a sum of M
    sinusoids whose frequencies f_m are log-uniform in [f_min, f_max] Hz and
    whose phases p_m are uniform in [0, 2 pi), both drawn from numpy's PCG64
    generator ``np.random.default_rng(seed)`` (the raw doubles of
    ``Generator.random``, which are the same on every machine). The amplitude
    makes g's mean square 1 over a long run, so ``strength`` is the RMS
    relative fluctuation of the wind speed (e.g. 0.3 for +-30 %); the factor
    is clipped at 0 so that a gust never reverses the wind. The direction is
    the base wind's. The same (base, seed, strength, ...) always gives the same
    wind; a different seed gives different gusts.
    """

    def __init__(self, base: Wind, seed: int = 0, strength: float = 0.3,
                 components: int = GUST_COMPONENTS,
                 min_frequency: float = GUST_MIN_FREQUENCY,
                 max_frequency: float = GUST_MAX_FREQUENCY):
        if not callable(getattr(base, "sample", None)):
            raise InputError(f"a gust's base must be a wind object (one with .sample(times)), "
                             f"got {type(base).__name__}")
        # (bool is an int: seed=True was taken as 1; a str or None gave numpy's or float's error)
        seed = whole("gust seed", seed)
        strength = real("gust strength", strength, low=0)
        components = whole("gust components", components, low=1)
        min_frequency = real("gust min_frequency", min_frequency)
        max_frequency = real("gust max_frequency", max_frequency)
        if not (0 < min_frequency <= max_frequency and math.isfinite(max_frequency)):
            raise InputError("gust frequencies must satisfy 0 < min_frequency <= max_frequency")
        if isinstance(base, (ConstantWind, KeyframeWind)):   # (any other wind is its own)
            steady = base.vector[None] if isinstance(base, ConstantWind) else base.vectors
            peak = float(np.linalg.norm(steady, axis=1).max())
            check_speed(peak * gust_peak_factor(strength, components),
                        f"gusts of strength {strength:g} reach a wind")
        self.base = base
        self.seed = int(seed)
        self.strength = strength
        u = np.random.default_rng(self.seed).random(2 * components)
        log_lo, log_hi = math.log(min_frequency), math.log(max_frequency)
        self.frequencies = np.exp(log_lo + u[:components] * (log_hi - log_lo))   # (M,) Hz
        self.phases = 2.0 * math.pi * u[components:]                             # (M,) rad
        self.amplitude = math.sqrt(2.0 / components)

    def factor(self, times) -> np.ndarray:
        """The gust factor max(0, 1 + strength g(t)), (K,) float64."""
        t = _times(times)
        g = np.sin(2.0 * math.pi * np.outer(t, self.frequencies) + self.phases).sum(axis=1)
        return np.maximum(0.0, 1.0 + self.strength * self.amplitude * g)

    def sample(self, times) -> np.ndarray:
        t = _times(times)
        return self.base.sample(t) * self.factor(t)[:, None]

    def __repr__(self) -> str:
        return f"GustyWind({self.base!r}, seed={self.seed}, strength={self.strength:g})"
