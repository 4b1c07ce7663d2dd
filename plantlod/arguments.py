"""The public API's argument checks (plantlod/api.py): every argument that is not what a
function takes is an `InputError` naming the argument, as a command's bad option is, never
a TypeError or a numpy error from deep inside (docs/api.md)."""

from __future__ import annotations

import io
import os
from typing import Any

import numpy as np

from plantlod.lsys.checks import flag, real, real_array, whole  # noqa: F401  (the API's argument checks)
from plantlod.lsys.errors import InputError


def label(name: str, value: Any) -> str | None:
    """``value`` where it is None or a string (a name messages give a text or a stream)."""
    if value is not None and not isinstance(value, str):
        raise InputError(f"{name} must be a string, got {type(value).__name__}")
    return value


def binary_stream(value: Any) -> bool:
    """Whether a stream (an object with read or write) reads or writes bytes, not text."""
    return isinstance(value, (io.RawIOBase, io.BufferedIOBase)) or "b" in getattr(value, "mode", "")


def output_target(value: Any, name: str = "the target",
                  kind: "tuple[str, tuple[str, ...]] | None" = None) -> None:
    """None, a writable text stream, or the path of a file whose folder exists; ``kind``
    (what is written, the extensions that hold it): a path named for another kind of file
    is refused, as the commands' -o is (`formats.kinds.output_kind_problem`)."""
    if value is None:
        return
    if hasattr(value, "write"):
        if getattr(value, "closed", False):
            raise InputError(f"{name} is a closed stream; expected an open one or a path")
        if binary_stream(value):
            raise InputError(f"{name} is a binary stream; expected a text stream or a path")
        if getattr(value, "writable", lambda: True)() is False:
            raise InputError(f"{name} is not open for writing")
        return
    path = path_of(value, name, output=True)
    if kind is not None:
        from plantlod.formats.kinds import output_kind_problem

        problem = output_kind_problem(path, *kind)
        if problem is not None:
            raise InputError(problem, path)


def path_of(value: Any, name: str = "the path", *, output: bool = False) -> str:
    """``value`` (a str or os.PathLike naming a file) as a str; ``output``: its folder must
    exist (as a command's -o FILE)."""
    if not isinstance(value, (str, os.PathLike)):
        raise InputError(f"{name} must be a path (str or os.PathLike), got {type(value).__name__}")
    path = os.fspath(value)
    if not isinstance(path, str) or not path or "\0" in path:
        raise InputError(f"{name} must name a file, got {value!r}")
    if output and ("\n" in path or "\r" in path):
        # (a name from readline(): 'a.npz\n' was written as JSON to a file no read_* call
        # opens by the same string, which it reads as text)
        raise InputError(f"{name} must name a file, got {value!r}, which holds a line break "
                         f"(strip it)")
    if output and not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        raise InputError("output directory does not exist", path)
    return path


def angle_ndim(values: Any) -> int:
    """The number of dimensions of an `Angles` array (``bend`` or ``rotation``); a ragged
    one (rows of different lengths) is refused as the other malformed arrays are (numpy's
    "inhomogeneous shape" ValueError reached the caller)."""
    try:
        return int(np.ndim(values))
    except (TypeError, ValueError):
        raise InputError("the angles' time, bend and rotation must be arrays of real numbers "
                         "(rows of one length)") from None


def one_run(angles: Any, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[str]]:
    """(time (T,), bend (T, B), rotation (T, B), addresses [B]) of an `Angles` of one run,
    checked: T >= 1 finite times rising, finite angles of the addresses' count."""
    from plantlod.api import Angles

    if not isinstance(angles, Angles):
        raise InputError(f"{what} takes an Angles (plantlod.simulate or read_angles), got "
                         f"{type(angles).__name__}")
    if angle_ndim(angles.bend) == 3:
        raise InputError(f"{what} takes one run: select it first (angles[w])")
    addresses = angles.addresses
    if not isinstance(addresses, (tuple, list)) or not all(isinstance(a, str) for a in addresses):
        raise InputError("the angles' addresses must be a sequence of address strings")
    if any(np.iscomplexobj(a) for a in (angles.time, angles.bend, angles.rotation)):
        # (float64 conversion keeps the real part and warns; a tree's arrays are refused so)
        raise InputError("the angles' time, bend and rotation must be arrays of real numbers, "
                         "got complex numbers")
    try:
        # (strings were read as numbers, True as 1 rad)
        time, bend, rot = (real_array(a) for a in (angles.time, angles.bend, angles.rotation))
    except (TypeError, ValueError, OverflowError):
        raise InputError("the angles' time, bend and rotation must be arrays of real numbers") from None
    shape = (time.shape[0] if time.ndim == 1 else -1, len(addresses))
    if time.ndim != 1 or time.shape[0] < 1 or bend.shape != shape or rot.shape != shape:
        raise InputError(f"the angles must hold time (T,) with T >= 1 and bend and rotation "
                         f"(T, B) for B = {len(addresses)} addresses; got time "
                         f"{tuple(time.shape)}, bend {tuple(bend.shape)}, rotation {tuple(rot.shape)}")
    if not (np.isfinite(time).all() and np.isfinite(bend).all() and np.isfinite(rot).all()):
        raise InputError("the angles hold values that are not finite numbers")
    if np.any(np.diff(time) <= 0):
        raise InputError("the angles' times must rise from row to row")
    return time, bend, rot, list(addresses)
