"""The environment variables that choose how the engine runs, read and checked in one place.

- PLANTLOD_THREADS (`constants.THREADS_ENV`): the lanes engine's threads, a whole number
  >= 1 (default: every core numba sees).
- PLANTLOD_KERNEL (`constants.KERNEL_ENV`): "compiled" or "interpreted" forces the
  single-run kernel's engine (default: chosen by the run's size; the same bits either way).
- numba's NUMBA_NUM_THREADS (a whole number, 1 to MAX_NUMBA_THREADS) and NUMBA_DISABLE_JIT
  (a whole number):
  numba reads them when it is imported, deep inside a command, and answered 0 with a
  ValueError ("internal error") and "abc" with a multi-line warning holding a traceback
  (a helper's environment fuzzing, session 35). NUMBA_DISABLE_JIT other than 0 leaves the
  lanes engine's vector type (`vec4`) without an implementation: `run_lanes` refuses it.

`check_environment` reads them all before a command starts (`cli.main`), so that every
command refuses a bad value alike, with one line and exit 2, whether or not it would
have reached the engine.
"""

from __future__ import annotations

import os

from plantlod.lsys.errors import InputError

from .constants import (KERNEL_ENV, MAX_NUMBA_THREADS, NUMBA_NO_JIT_ENV, NUMBA_THREADS_ENV,
                        THREADS_ENV)


def _whole(name: str, low: int | None = None, high: int | None = None) -> int | None:
    """The variable ``name`` as a whole number (None where it is unset), refused where it is
    set to anything else, below ``low`` or above ``high``."""
    raw = os.environ.get(name)
    if raw is None:
        return None
    text = raw.strip()
    try:
        value = int(text)
    except ValueError:
        raise InputError(f"{name}={raw!r} is not a whole number") from None
    if low is not None and value < low:
        raise InputError(f"{name}={raw!r}: expected a whole number >= {low}")
    if high is not None and value > high:
        raise InputError(f"{name}={raw!r}: expected a whole number <= {high:,}")
    return value


def env_threads() -> int | None:
    """$PLANTLOD_THREADS as a thread count >= 1, None where it is unset or empty."""
    if not os.environ.get(THREADS_ENV, "").strip():
        return None
    return _whole(THREADS_ENV, 1)


def forced_kernel() -> str | None:
    """$PLANTLOD_KERNEL: "compiled", "interpreted", or None where it is unset or empty."""
    forced = os.environ.get(KERNEL_ENV, "").strip().lower()
    if not forced:
        return None
    if forced not in ("compiled", "interpreted"):
        raise InputError(f"{KERNEL_ENV}={forced!r}: expected compiled or interpreted")
    return forced


def jit_disabled() -> bool:
    """True where $NUMBA_DISABLE_JIT is set to a whole number other than 0."""
    return bool(_whole(NUMBA_NO_JIT_ENV))


def check_environment() -> None:
    """Every variable above, refused (InputError) where it is set to a value the engine or
    numba cannot take."""
    env_threads()
    forced_kernel()
    _whole(NUMBA_THREADS_ENV, 1, MAX_NUMBA_THREADS)
    jit_disabled()


def check_jit_enabled() -> None:
    """The lanes engine needs numba's compiler: refused under NUMBA_DISABLE_JIT."""
    if jit_disabled():
        raise InputError(f"{NUMBA_NO_JIT_ENV}={os.environ[NUMBA_NO_JIT_ENV]!r}: the lanes engine "
                         "(simplify, scene, a list of winds) needs numba's compiler, whose vector "
                         "type has no pure-Python form; unset it")
