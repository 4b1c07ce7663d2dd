"""The small-angle model's range: the first sample of a run where a branch tilts beyond
LARGE_ANGLE_RAD (hypot of its bend and rotation), found on the output arrays after the
kernels ran (the kernels are not touched), so that a run far outside the model says so."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .constants import LARGE_ANGLE_RAD, SIM_CHUNK_VALUES


@dataclass(frozen=True)
class LargeAngle:
    """Where a run first passed the limit: time (s), branch address, its tilt (rad)."""

    time: float
    address: str
    tilt: float

    def message(self, what: str = "") -> str:
        where = f"{what}: " if what else ""
        return (f"{where}branch {self.address} tilts {_above(self.tilt, LARGE_ANGLE_RAD)} rad "
                f"at t = {self.time:g} s, "
                f"beyond {LARGE_ANGLE_RAD:g} rad: the small-angle model (docs/model.md) is far "
                "outside its range there; check the units (metres), the wind and the strengths")


class LargeAngleWatch:
    """Sees a run's angles chunk by chunk and keeps the first sample beyond the limit.

    The common case costs two maxima per chunk: the tilt is computed only for a chunk
    whose largest |angle| could pass the limit."""

    def __init__(self, addresses, limit: float = LARGE_ANGLE_RAD):
        self.addresses, self.limit = list(addresses), float(limit)
        self.first: LargeAngle | None = None

    def see(self, times: np.ndarray, bend: np.ndarray, rot: np.ndarray) -> None:
        """times (m,) s; bend, rot (m, B) rad."""
        if self.first is not None or np.size(bend) == 0:
            return
        bend, rot = np.asarray(bend), np.asarray(rot)
        top = max(float(np.max(np.abs(bend))), float(np.max(np.abs(rot))))
        if not top * math.sqrt(2.0) > self.limit:
            return
        rows = max(1, SIM_CHUNK_VALUES // max(1, bend.shape[1]))    # bounded extra memory
        for r0 in range(0, len(bend), rows):
            tilt = np.hypot(bend[r0:r0 + rows], rot[r0:r0 + rows])
            over = np.argwhere(tilt > self.limit)
            if len(over):
                row, column = over[0]
                self.first = LargeAngle(float(np.asarray(times)[r0 + row]),
                                        self.addresses[column], float(tilt[row, column]))
                return


def first_large_angle(times: np.ndarray, bend: np.ndarray, rot: np.ndarray,
                      addresses) -> LargeAngle | None:
    """The first sample beyond LARGE_ANGLE_RAD of one run (T,), (T, B), (T, B); None if none."""
    watch = LargeAngleWatch(addresses)
    watch.see(times, bend, rot)
    return watch.first


def _above(value: float, limit: float) -> str:
    """``value`` to 3 significant digits, or as many more as show it above ``limit`` ("tilts
    1 rad … beyond 1 rad" read as no excess: a helper's reading, session 42)."""
    for digits in range(3, 18):
        text = f"{value:.{digits}g}"
        if float(text) > limit:
            return text
    return repr(value)
