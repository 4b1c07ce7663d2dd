"""How far a simplified tree's motion is from the original's (model.md section 6).

Signals are sampled at times ``t`` of shape (K,) (seconds, increasing). An
angle signal is (K,) or (K, G), one column per group, in radians; every
measure works down the time axis and returns one figure per column. Tips are
(K, G, 3) world positions in metres.

Undefined figures are NaN: the period of a signal with fewer than two upward
crossings of its mean, and a relative error whose reference is undefined or 0.
`Report.to_dict` turns them into ``None`` for JSON.

A NaN inside a signal propagates: its amplitude is NaN, and since no sample
compares with a NaN mean, it has no crossings and no period. `compare_groups`
refuses non-finite input outright (an `InputError`), so a report never mixes
real figures with ones computed from a diverged run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .constants import COUNTED_AMPLITUDE_FRACTION, MAJOR_AMPLITUDE_FRACTION, STILL_AMPLITUDE
from plantlod.lsys.errors import InputError

COMPONENTS = ("bend", "rotation")


# --- measures of one signal ---------------------------------------------------------

def amplitude(x: np.ndarray) -> np.ndarray | float:
    """Half the peak-to-peak range, (max - min) / 2, of x (K,) or (K, G): a float or (G,).

    Same unit as x. NaN for a column that holds a NaN.
    """
    x = _as_signal(x)
    a = (np.max(x, axis=0) - np.min(x, axis=0)) / 2.0
    return float(a) if np.ndim(a) == 0 else a


def upward_crossings(t: np.ndarray, x: np.ndarray) -> list[np.ndarray]:
    """Times (s) at which x (K,) or (K, G) crosses its mean upward: one (c_g,) array per column.

    A crossing lies between samples k-1 and k where x[k-1] < mean <= x[k]; its
    time is found by linear interpolation between t[k-1] and t[k]. The slow,
    explicit form of what `period` computes in one pass; for reports and tests.
    """
    t, x2 = _check_time(t, x)
    out = []
    for col in x2.T:
        m = np.mean(col)
        k = np.flatnonzero((col[:-1] < m) & (m <= col[1:])) + 1
        frac = (m - col[k - 1]) / (col[k] - col[k - 1])
        out.append(t[k - 1] + frac * (t[k] - t[k - 1]))
    return out


def period(t: np.ndarray, x: np.ndarray) -> np.ndarray | float:
    """Mean spacing (s) of the upward crossings of x's mean: a float for x (K,), (G,) for (K, G).

    Crossings as in `upward_crossings`. With c >= 2 crossings at times
    c_1 < … < c_n the mean spacing is (c_n - c_1) / (n - 1); fewer than two
    crossings (a constant signal, a NaN, a single swing) give NaN.
    """
    t, x2 = _check_time(t, x)
    m = np.mean(x2, axis=0)                              # (G,)
    lo, hi = x2[:-1], x2[1:]                             # (K-1, G)
    up = (lo < m) & (m <= hi)                            # crossing between k-1 and k
    count = up.sum(axis=0)                               # (G,)
    first = np.argmax(up, axis=0)                        # index k-1 of the first crossing
    last = up.shape[0] - 1 - np.argmax(up[::-1], axis=0)  # and of the last one
    cols = np.arange(x2.shape[1])

    def crossing_time(k0: np.ndarray) -> np.ndarray:
        x0, x1 = x2[k0, cols], x2[k0 + 1, cols]
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = (m - x0) / (x1 - x0)
        return t[k0] + frac * (t[k0 + 1] - t[k0])

    with np.errstate(invalid="ignore", divide="ignore"):
        p = (crossing_time(last) - crossing_time(first)) / (count - 1)
    p = np.where(count >= 2, p, np.nan)
    return float(p[0]) if np.ndim(x) == 1 else p


def window(t: np.ndarray, t0: float | None = None, t1: float | None = None) -> slice:
    """The samples of t (K,) with t0 <= t <= t1 (either bound None: open), as a slice.

    Use it on the time axis of every signal of one run: ``x[window(t, 2, 10)]``.
    Raises InputError when t0 > t1 or when fewer than two samples fall inside.
    """
    t = np.asarray(t, dtype=np.float64)
    if t0 is not None and t1 is not None and t0 > t1:
        raise InputError(f"window start {t0:g} s is after its end {t1:g} s; expected start <= end")
    start = 0 if t0 is None else int(np.searchsorted(t, t0, side="left"))
    stop = len(t) if t1 is None else int(np.searchsorted(t, t1, side="right"))
    if stop - start < 2:
        raise InputError(
            f"window [{_fmt_bound(t0)}, {_fmt_bound(t1)}] s holds {max(stop - start, 0)} sample(s) "
            f"of a run from {t[0]:g} to {t[-1]:g} s; expected at least 2")
    return slice(start, stop)


def relative_error(value: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """|value - reference| / reference, elementwise; NaN where the reference is 0 or NaN."""
    value = np.asarray(value, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.abs(value - reference) / reference
    return np.where(reference != 0, err, np.nan)


def _squared_distances(tips_orig: np.ndarray, tips_simp: np.ndarray) -> np.ndarray:
    """|tip_y - tip_x|² (K, G) from (K, G, 3) tips (m)."""
    d = np.asarray(tips_simp, dtype=np.float64) - np.asarray(tips_orig, dtype=np.float64)
    return np.einsum("kgi,kgi->kg", d, d)


def tip_error(tips_orig: np.ndarray, tips_simp: np.ndarray, rest_height: float) -> np.ndarray:
    """RMS over time of |tip_y - tip_x|, divided by rest_height: (G,) from (K, G, 3) tips (m)."""
    return np.sqrt(np.mean(_squared_distances(tips_orig, tips_simp), axis=0)) / rest_height


# --- the report -------------------------------------------------------------------

@dataclass
class ComponentFigures:
    """Figures of one component (combined bend or rotation angle) of one group.

    Amplitudes in radians, periods in seconds, errors relative (NaN: undefined).
    counted : whether the component enters the worst-group amplitude and
              period errors (its original amplitude is at least
              COUNTED_AMPLITUDE_FRACTION of the largest one in the run).
    """

    amplitude_original: float
    amplitude_simplified: float
    amplitude_error: float
    period_original: float
    period_simplified: float
    period_error: float
    counted: bool

    def to_dict(self) -> dict:
        return {
            "amplitude_original": json_float(self.amplitude_original),
            "amplitude_simplified": json_float(self.amplitude_simplified),
            "amplitude_error": json_float(self.amplitude_error),
            "period_original": json_float(self.period_original),
            "period_simplified": json_float(self.period_simplified),
            "period_error": json_float(self.period_error),
            "counted": self.counted,
        }


@dataclass
class GroupFigures:
    """Figures of one group: its simplified branch's address, both components, its tip error."""

    address: str
    bend: ComponentFigures
    rotation: ComponentFigures
    tip_error: float

    def component(self, name: str) -> ComponentFigures:
        return self.bend if name == "bend" else self.rotation

    def to_dict(self) -> dict:
        return {
            "address": self.address,
            "bend": self.bend.to_dict(),
            "rotation": self.rotation.to_dict(),
            "tip_error": json_float(self.tip_error),
        }


@dataclass(frozen=True)
class GroupTable:
    """Every group's figures as arrays, rows 0 bend and 1 rotation (what `GroupFigures`
    holds per group; a report builds those only when asked: at tens of thousands of groups
    the objects cost more than the measures).

    amplitude_original, amplitude_simplified, amplitude_error,
    period_original, period_simplified, period_error : (2, G) float64 (rad, s, relative)
    counted : (2, G) bool;  tip_error : (G,) relative;  addresses : (G,) str
    """

    addresses: list[str]
    amplitude_original: np.ndarray
    amplitude_simplified: np.ndarray
    amplitude_error: np.ndarray
    period_original: np.ndarray
    period_simplified: np.ndarray
    period_error: np.ndarray
    counted: np.ndarray
    tip_error: np.ndarray

    def motion(self, largest: float) -> np.ndarray:
        """(2, G) |A_y - A_x| / A_max, model.md 6's motion error of each component (``largest``
        = A_max, the report's `largest_amplitude`); NaN everywhere when A_max is 0."""
        if largest > 0:
            return np.abs(self.amplitude_simplified - self.amplitude_original) / largest
        return np.full_like(self.amplitude_original, np.nan)

    def major(self, largest: float) -> np.ndarray:
        """(2, G) bool: the components whose period error model.md 6's period error (major)
        reads: A_x at least MAJOR_AMPLITUDE_FRACTION of A_max, the error defined."""
        if largest > 0:
            return (self.amplitude_original >= MAJOR_AMPLITUDE_FRACTION * largest) \
                & np.isfinite(self.period_error)
        return np.zeros_like(self.amplitude_original, bool)

    def figures(self) -> list[GroupFigures]:
        """One `GroupFigures` per group, in order."""
        columns = [getattr(self, name).tolist() for name in (
            "amplitude_original", "amplitude_simplified", "amplitude_error", "period_original",
            "period_simplified", "period_error", "counted")]
        tips = self.tip_error.tolist()
        return [GroupFigures(address, *[ComponentFigures(*[col[c][j] for col in columns])
                                        for c in range(2)], tips[j])
                for j, address in enumerate(self.addresses)]


@dataclass
class Worst:
    """Where a worst-group figure was found: a group's address and, for angles, the component."""

    address: str
    component: str | None = None

    def to_dict(self) -> dict:
        out = {"address": self.address}
        if self.component is not None:
            out["component"] = self.component
        return out


@dataclass
class Report:
    """The comparison of one simplified run with the original (model.md section 6).

    amplitude_error   : largest amplitude error over counted components (NaN: none counts)
    period_error      : largest period error over counted components with a defined period
    tip_error         : largest tip error over all groups
    *_at              : the group (and component) where each maximum was found
    undefined_periods : counted components left out of the period maximum because
                        the original's or the simplified run's period is undefined
    largest_amplitude : the largest original combined-angle amplitude (rad), the
                        reference of the counting rule; 0 where it is at most
                        STILL_AMPLITUDE (roundoff: the original does not move)
    groups            : one entry per group, in simplified-branch order
    t0, t1            : the time window (s) the figures cover

    The visible-motion measures of model.md section 6 (what a viewer sees):
    motion_error       : largest |A_y - A_x| / A_max over counted components
                         (A_max = largest_amplitude); NaN when nothing counts
    period_error_major : largest period error over components with A_x >= 10 % of
                         A_max and a defined period; NaN when there is none
    tip_error_max_m    : largest |tip_y - tip_x| over time and groups, metres
    """

    amplitude_error: float
    period_error: float
    tip_error: float
    amplitude_error_at: Worst | None
    period_error_at: Worst | None
    tip_error_at: Worst | None
    undefined_periods: list[Worst]
    largest_amplitude: float
    rest_height: float
    t0: float
    t1: float
    table: GroupTable | None = field(default=None, compare=False, repr=False)
    motion_error: float = math.nan
    motion_error_at: Worst | None = None
    period_error_major: float = math.nan
    period_error_major_at: Worst | None = None
    tip_error_max_m: float = math.nan
    tip_error_max_m_at: Worst | None = None

    @property
    def groups(self) -> list[GroupFigures]:
        """One entry per group, in simplified-branch order (built from `table` once)."""
        if self.table is None:
            return []
        built = self.__dict__.get("_groups")
        if built is None:
            built = self.__dict__["_groups"] = self.table.figures()
        return built

    def to_dict(self) -> dict:
        """JSON-ready values: plain floats, None for NaN, addresses as strings."""
        at = lambda w: None if w is None else w.to_dict()   # noqa: E731
        return {
            "motion_error": json_float(self.motion_error),
            "motion_error_at": at(self.motion_error_at),
            "period_error_major": json_float(self.period_error_major),
            "period_error_major_at": at(self.period_error_major_at),
            "tip_error_max_m": json_float(self.tip_error_max_m),
            "tip_error_max_m_at": at(self.tip_error_max_m_at),
            "amplitude_error": json_float(self.amplitude_error),
            "period_error": json_float(self.period_error),
            "tip_error": json_float(self.tip_error),
            "amplitude_error_at": None if self.amplitude_error_at is None else self.amplitude_error_at.to_dict(),
            "period_error_at": None if self.period_error_at is None else self.period_error_at.to_dict(),
            "tip_error_at": None if self.tip_error_at is None else self.tip_error_at.to_dict(),
            "undefined_periods": [w.to_dict() for w in self.undefined_periods],
            "largest_amplitude": json_float(self.largest_amplitude),
            "counted_fraction": COUNTED_AMPLITUDE_FRACTION,
            "rest_height": json_float(self.rest_height),
            "window": [json_float(self.t0), json_float(self.t1)],
            "groups": [g.to_dict() for g in self.groups],
        }


def component_figures(t: np.ndarray, bend: np.ndarray, rot: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(amplitudes, periods), each (2, G) (row 0 bend, row 1 rotation; rad and s), of the
    angles bend, rot (K, G) sampled at t (K,): `amplitude` and `period` of each column."""
    return (np.stack([amplitude(bend), amplitude(rot)]),
            np.stack([period(t, bend), period(t, rot)]))


def compare_groups(t: np.ndarray,
                   orig_combined_b: np.ndarray, orig_combined_r: np.ndarray,
                   simp_b: np.ndarray, simp_r: np.ndarray,
                   tips_orig: np.ndarray, tips_simp: np.ndarray,
                   rest_height: float,
                   addresses: list[str],
                   original_figures: tuple[np.ndarray, np.ndarray] | None = None) -> Report:
    """Compare every group of the original with its simplified branch over one window.

    t                  : (K,) sample times, s (already cut to the window; see `window`)
    orig_combined_b, _r: (K, G) the original's combined angles Θb, Θr per group, rad
    simp_b, simp_r     : (K, G) bend and rotation angle of each group's simplified branch, rad
    tips_orig          : (K, G, 3) group tips of the original, m
    tips_simp          : (K, G, 3) tips of the simplified branches, m
    rest_height        : the original tree's rest height (largest tip z at rest), m
    addresses          : (G,) the simplified branches' addresses, for the report
    original_figures   : (amplitudes, periods), each (2, G), of the original's Θb and Θr as
                         `component_figures` gives them, when one original run is compared
                         with many simplified ones (computed here otherwise)

    Raises InputError on shapes that disagree, non-finite samples, or a rest
    height that is not positive.
    """
    t = np.asarray(t, dtype=np.float64)
    k = t.shape[0] if t.ndim == 1 else -1
    angles = [np.asarray(a, dtype=np.float64) for a in (orig_combined_b, orig_combined_r, simp_b, simp_r)]
    g = angles[0].shape[1] if angles[0].ndim == 2 else -1
    tips_orig = np.asarray(tips_orig, dtype=np.float64)
    tips_simp = np.asarray(tips_simp, dtype=np.float64)
    if k < 2 or g < 0 or any(a.shape != (k, g) for a in angles) \
            or tips_orig.shape != (k, g, 3) or tips_simp.shape != (k, g, 3) or len(addresses) != g:
        raise InputError(
            f"compare: expected t (K,) with K >= 2, four angle arrays (K, G), two tip arrays (K, G, 3) "
            f"and G addresses; got t {t.shape}, angles {[a.shape for a in angles]}, "
            f"tips {tips_orig.shape} and {tips_simp.shape}, {len(addresses)} addresses")
    for name, arr in (("time", t), ("original bend", angles[0]), ("original rotation", angles[1]),
                      ("simplified bend", angles[2]), ("simplified rotation", angles[3]),
                      ("original tips", tips_orig), ("simplified tips", tips_simp)):
        bad = ~np.isfinite(arr)
        if bad.any():
            where = np.argwhere(bad)[0]
            raise InputError(f"compare: {name} is not finite at sample {int(where[0])} "
                             f"(t = {t[int(where[0])]:g} s); expected finite values (did the run diverge?)")
    if not rest_height > 0:
        raise InputError(f"compare: the original tree's rest height is {rest_height:g} m; "
                         f"expected a tree whose highest tip is above z = 0")

    # (2, G) per component: row 0 bend, row 1 rotation
    amp_x, per_x = component_figures(t, angles[0], angles[1]) if original_figures is None \
        else original_figures
    amp_y, per_y = component_figures(t, angles[2], angles[3])
    amp_err = relative_error(amp_y, amp_x)
    per_err = relative_error(per_y, per_x)
    largest = float(amp_x.max()) if g else 0.0
    if largest <= STILL_AMPLITUDE:            # roundoff, not motion: nothing counts (model.md 6)
        largest = 0.0
    counted = (amp_x >= COUNTED_AMPLITUDE_FRACTION * largest) if largest > 0 else np.zeros_like(amp_x, bool)
    d2 = _squared_distances(tips_orig, tips_simp)                # (K, G) m²
    tips = np.sqrt(np.mean(d2, axis=0)) / rest_height            # tip_error, (G,)

    table = GroupTable(list(addresses), amp_x, amp_y, amp_err, per_x, per_y, per_err, counted,
                       tips)

    amp_worst, amp_at = _worst(np.where(counted, amp_err, np.nan), addresses)
    per_defined = counted & np.isfinite(per_err)
    per_worst, per_at = _worst(np.where(per_defined, per_err, np.nan), addresses)
    undefined = [Worst(addresses[j], COMPONENTS[c])
                 for j in range(g) for c in range(2) if counted[c, j] and not per_defined[c, j]]
    tip_worst, tip_at = _worst(tips[None, :], addresses, components=(None,))
    # visible motion (model.md 6): errors against the largest motion, periods of the major components
    motion_worst, motion_at = _worst(np.where(counted, table.motion(largest), np.nan), addresses)
    major_worst, major_at = _worst(np.where(table.major(largest), per_err, np.nan), addresses)
    tip_max = np.sqrt(d2.max(axis=0)) if k else np.zeros(g)            # largest |tip_y - tip_x| over time, (G,) m
    tip_max_worst, tip_max_at = _worst(tip_max[None, :], addresses, components=(None,))
    return Report(amp_worst, per_worst, tip_worst, amp_at, per_at, tip_at, undefined,
                  largest, float(rest_height), float(t[0]), float(t[-1]), table,
                  motion_worst, motion_at, major_worst, major_at, tip_max_worst, tip_max_at)


# --- helpers ----------------------------------------------------------------------

def _worst(values: np.ndarray, addresses: list[str],
           components: tuple[str | None, ...] = COMPONENTS) -> tuple[float, Worst | None]:
    """The largest non-NaN entry of values (C, G) and where it is; NaN and None if there is none.

    Ties go to the first group in order, then to the first component.
    """
    by_group = values.T.reshape(-1)                      # group-major: (G * C,)
    if by_group.size == 0 or np.all(np.isnan(by_group)):
        return math.nan, None
    pos = int(np.argmax(np.where(np.isnan(by_group), -np.inf, by_group)))
    j, c = divmod(pos, values.shape[0])
    return float(by_group[pos]), Worst(addresses[j], components[c])


def _as_signal(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim not in (1, 2) or x.shape[0] < 1:
        raise InputError(f"expected a signal of shape (K,) or (K, G) with K >= 1, got {x.shape}")
    return x


def _check_time(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """t as (K,) float64 and x as (K, G) float64, with K >= 2."""
    t = np.asarray(t, dtype=np.float64)
    x = _as_signal(x)
    if t.ndim != 1 or t.shape[0] != x.shape[0] or t.shape[0] < 2:
        raise InputError(f"expected times (K,) matching a signal (K,) or (K, G) with K >= 2; "
                         f"got t {t.shape} and x {x.shape}")
    return t, x.reshape(x.shape[0], -1)


def json_float(v: float) -> float | None:
    """``v`` as compare's JSON holds a figure: a float, or None where it is undefined (NaN;
    plain JSON has no NaN)."""
    return None if v is None or not math.isfinite(v) else float(v)


def _fmt_bound(v: float | None) -> str:
    return "-" if v is None else f"{v:g}"
