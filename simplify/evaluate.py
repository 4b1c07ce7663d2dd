"""Measure a simplified tree against the original: simulate both, compare (model.md section 6).

`Runs` simulates the original once per wind and keeps what the comparison
needs (combined angles and group tips per group), so that calibration can
simulate many candidate simplified trees against the same original runs.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

from .constants import HIGH_SPEED_FRACTION
from .constants import MEASURE_WIND_DIRECTIONS
from .constants import REPORTS_KEPT, RUNS_BATCH_BYTES, RUNS_PIECE_BYTES
from plantlod.lsys.errors import InputError, RunFailure
from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import rest_height
from plantlod.sim.wind import wind_from_speed

from plantlod.compare.runs import tip_series
from .finite import NOT_FINITE_FIT, finite_parameters
from .targets import GroupMap
from plantlod.compare.groups import combined_angles
from plantlod.compare.measures import Report, compare_groups, component_figures, period



@dataclass(frozen=True)
class WindCase:
    """A horizontal wind: speed m/s toward azimuth direction deg (0 = +x), steady, or with
    gust_strength > 0 the seeded gusts of `plantlod.sim.wind.GustyWind` on it (a scene's
    wind: `scene.levels` measures its levels' tip errors in the gusts the trees see)."""

    speed: float
    direction: float
    gust_strength: float = 0.0
    gust_seed: int = 0

    def label(self) -> str:
        gusts = f" with gusts of {self.gust_strength:g}" if self.gust_strength > 0 else ""
        return f"the wind of {self.speed:g} m/s toward {self.direction:g}°{gusts}"

    def wind(self):
        """The `plantlod.sim.wind` object of this case."""
        from plantlod.sim.wind import GustyWind

        base = wind_from_speed(self.speed, self.direction)
        if self.gust_strength > 0:
            return GustyWind(base, seed=self.gust_seed, strength=self.gust_strength)
        return base




def wind_cases(low: float, high: float,
               directions: tuple[float, ...] = MEASURE_WIND_DIRECTIONS) -> list[WindCase]:
    """Steady winds: speeds low, sqrt(low high), 0.75 high, high (duplicates once), each direction."""
    if not (0 < low <= high and math.isfinite(high)):
        raise InputError(f"wind range {low:g} to {high:g} m/s: expected 0 < low <= high")
    values = []
    for v in (low, math.sqrt(low * high), max(low, HIGH_SPEED_FRACTION * high), high):
        v = float(f"{v:.6g}")
        if v not in values:
            values.append(v)
    return [WindCase(s, d) for s in values for d in directions]


@dataclass
class OriginalRun:
    """One wind's run of the original, reduced to what comparison needs.

    The group tips are kept as their rest positions and float32 displacements from them
    (a few mm to m, so about 1e-7 m of rounding): at 15,625 branches the 16 winds'
    float64 tips alone took 0.6 GB.
    """

    wind: WindCase
    times: np.ndarray          # (K,) s
    combined_b: np.ndarray     # (K, G) rad
    combined_r: np.ndarray     # (K, G) rad
    rest_tips: np.ndarray      # (G, 3) m
    tip_moves: np.ndarray      # (K, G, 3) float32, m from rest_tips
    figures: tuple             # (amplitudes, periods) (2, G) of combined_b, _r (`component_figures`)

    @property
    def tips(self) -> np.ndarray:
        """(K, G, 3) m, float64."""
        return self.rest_tips[None] + self.tip_moves

    def downward_periods(self) -> np.ndarray:
        """(2, G) `downward_periods` of the combined angles, computed once."""
        if "_down" not in self.__dict__:
            self.__dict__["_down"] = downward_periods(self.times, self.combined_b, self.combined_r)
        return self.__dict__["_down"]


def downward_periods(times: np.ndarray, bend: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """(2, G) model.md 6's period of -Θb and -Θr (K, G): the mean spacing of their signals'
    downward crossings of the mean. In the linear regime the opposite wind's response is the
    negative, so this is the period compare reads in the opposite wind; for a sum of members
    of different periods, over a window of a few periods, it differs from the upward one."""
    return np.stack([np.atleast_1d(period(times, -bend)), np.atleast_1d(period(times, -rot))])


class Runs:
    """The original's runs over a set of winds, and comparisons of simplified trees with them.

    dt, steps, every: time step (s), steps per run, keep every k-th sample.
    damping: c or a `plantlod.sim.damping.Damping` (a damping ratio), for both trees' runs.
    """

    def __init__(self, original: Tree, gmap: GroupMap, winds: list[WindCase],
                 dt: float, steps: int, every: int = 1, damping=0.0,
                 simulated: list | None = None, tip_cache: dict | None = None):
        """simulated: the original's runs as `simulate_runs` gives them (a list), when one set
        of runs serves several levels (a chain): the original is then not simulated again.
        tip_cache: a dict a chain's `Runs` share (`motion_fit.shared_runs`): per run, the
        original's tips at the last set of group tips read. A coarser level's group tips are
        among a finer level's (a merged group ends where one of its groups ended), so a chain
        poses the original once, at its finest level's tips; each tip is computed along its
        own ancestors alone (`sim.tips_kernel`), so the values are the same bits."""
        self.original = original
        self.damping = damping
        self.gmap = gmap
        self.dt, self.steps, self.every = dt, steps, every
        self.height = rest_height(original)
        self.winds = list(winds)
        self._reports: dict[bytes, dict[int, Report]] = {}    # tree digest -> run id -> report
        self.runs = []
        want = gmap.tips
        known = [None if tip_cache is None else tip_cache.get(k) for k in range(len(self.winds))]
        known = [c if c is not None and np.all(c[0][want] >= 0) else None for c in known]
        read = (self._read_in_pieces(original, known) if simulated is None
                else self._read(original, simulated, known))
        for k, (wind, times, cb, cr, tips) in enumerate(read):
            if known[k] is not None:
                column = known[k][0][want]
                rest, moves = known[k][1][column], known[k][2][:, column]
            else:
                rest, moves = tips
                if tip_cache is not None:
                    column = np.full(original.n_branches, -1, dtype=np.int64)
                    column[want] = np.arange(len(want))
                    tip_cache[k] = (column, rest, moves)
            self.runs.append(OriginalRun(wind, times, cb, cr, rest, moves,
                                         component_figures(times, cb, cr)))

    def _read(self, original: Tree, simulated, known: list):
        """(wind, times, Θb, Θr (K, G), (rest tips (n, 3), moves (K, n, 3) float32) or None
        where ``known`` has them) of every run in ``simulated`` (`simulate_runs`' runs)."""
        want = self.gmap.tips
        for k, (wind, times, bend, rot) in enumerate(simulated):
            cb, cr = combined_angles(original, self.gmap.paths, bend, rot)
            tips = None
            if known[k] is None:
                posed = tip_series(original, bend, rot, want)
                tips = posed[0].copy(), (posed - posed[0]).astype(np.float32)
            yield wind, times, cb, cr, tips

    def _read_in_pieces(self, original: Tree, known: list):
        """What `_read` gives, from the original's runs simulated a piece of time at a time
        (`simulate_pieces`): the runs themselves are never held whole. Every sample's combined
        angles and tips are computed from that sample alone, so the bits are `_read`'s."""
        want, paths, winds = self.gmap.tips, self.gmap.paths, self.winds
        times = run_times(self.dt, self.steps, self.every)
        rows = len(times) - 1
        cb = np.empty((len(winds), rows + 1, len(paths)))
        cr = np.empty_like(cb)
        rest = [None] * len(winds)
        moves = [None if known[k] is not None else np.empty((rows + 1, len(want), 3), np.float32)
                 for k in range(len(winds))]
        for first, bend, rot in simulate_pieces(original, winds, self.dt, self.steps,
                                                self.every, self.damping):
            span = slice(first, first + bend.shape[1])
            posed = None
            for k in range(len(winds)):
                cb[k, span], cr[k, span] = combined_angles(original, paths, bend[k], rot[k])
                if moves[k] is not None:
                    posed = tip_series(original, bend[k], rot[k], want)
                    if first == 0:
                        rest[k] = posed[0].copy()
                    moves[k][span] = (posed - rest[k]).astype(np.float32)
            del bend, rot, posed          # (not held while the next piece is run)
        for k, wind in enumerate(winds):
            yield wind, times, cb[k], cr[k], None if moves[k] is None else (rest[k], moves[k])

    def _simulated(self, tree: Tree, winds: list[WindCase] | None = None):
        """(wind, times, bend, rot) of ``tree`` for every wind (`simulate_runs`)."""
        return simulate_runs(tree, self.winds if winds is None else winds, self.dt, self.steps,
                             self.every, self.damping)

    def compare(self, simplified: Tree, downward: bool = False) -> list[Report]:
        """One section-6 report per wind. Raises InputError when the simplified run diverges.
        ``downward``: also read the downward crossings' periods of both trees (`downward`).

        The reports of the last few trees compared are kept, per tree (a digest of every
        array the runs read) and original run, and shared with `subset`s: a level that the
        motion fit measured in some winds is simulated only in the others when measured in
        all of them."""
        from plantlod.compare.groups import carry_angles, swing_turns

        key = tree_digest(simplified)
        known = self._reports.pop(key, {})
        self._reports[key] = known                   # the most recent last
        for stale in list(self._reports)[:-REPORTS_KEPT]:
            del self._reports[stale]
        todo = [run for run in self.runs if id(run) not in known
                or (downward and ("down", id(run)) not in known)]
        if todo:
            turn = swing_turns(self.original, simplified, self.gmap.paths)    # W_0, either form
            every_branch = np.arange(simplified.n_branches)
            # a batch of winds at a time (memory)
            simulated = self._simulated(simplified, [run.wind for run in todo])
            try:
                for run, (_wind, _times, bend, rot) in zip(todo, simulated):
                    tips = tip_series(simplified, bend, rot, every_branch)
                    if turn is not None:
                        bend, rot = carry_angles(turn, bend, rot)
                    known[id(run)] = compare_groups(run.times, run.combined_b, run.combined_r,
                                                    bend, rot, run.tips, tips, self.height,
                                                    simplified.address, run.figures)
                    if downward:
                        known[("down", id(run))] = (run.downward_periods(),
                                                    downward_periods(run.times, bend, rot))
            except RunFailure as exc:
                if not finite_parameters(simplified):   # the fit's numbers, not the input's winds
                    raise RunFailure(NOT_FINITE_FIT) from None
                raise InputError(f"the simplified tree is unstable in simplify's winds: {exc}",
                                 self.original.where or simplified.where or None) from None
        return [known[id(run)] for run in self.runs]

    def downward(self, simplified: Tree) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per wind, (original, simplified) periods (2, G) of the downward crossings of each
        group's components (`downward_periods`), for a tree `compare` has just compared with
        ``downward`` set."""
        known = self._reports[tree_digest(simplified)]
        return [known[("down", id(run))] for run in self.runs]

    def subset(self, keep: list[int]) -> "Runs":
        """The same runs for winds ``keep`` only (indices into ``winds``); shares the data."""
        out = object.__new__(Runs)
        out.__dict__.update(self.__dict__)
        out.winds = [self.winds[k] for k in keep]
        out.runs = [self.runs[k] for k in keep]
        return out

    def largest_combined_angle(self) -> list[float]:
        """Per wind, the largest |Θb| or |Θr| of any group over the run (rad)."""
        return [float(max(np.abs(r.combined_b).max(initial=0.0), np.abs(r.combined_r).max(initial=0.0)))
                for r in self.runs]


def tree_digest(tree: Tree) -> bytes:
    """A SHA-256 digest of everything a run and its comparison read from ``tree`` (its
    structure, rest geometry, parameters, leaves and addresses)."""
    h = hashlib.sha256()
    for name in ("parent", "length", "radius", "bend_strength", "rotation_strength",
                 "force_absorbed", "force_propagated", "drag_coefficient", "euler", "offset",
                 "leaf_branch", "leaf_area", "leaf_normal", "force_gain", "swing_roll"):
        value = getattr(tree, name)
        data = b"" if value is None else np.ascontiguousarray(value).tobytes()
        h.update(name.encode() + len(data).to_bytes(8, "little") + data)
    h.update(repr((tree.leaf_force_scale, tree.address, tree.group_root)).encode())
    return h.digest()


def run_times(dt: float, steps: int, every: int) -> np.ndarray:
    """(steps // every + 1,) s: the sample times of a run from rest (row 0 at rest)."""
    return np.arange(steps // every + 1, dtype=np.float64) * every * dt


def wind_vectors(winds: list[WindCase], dt: float, steps: int) -> np.ndarray:
    """The lanes' winds for `run_lanes`: (W, 3) m/s where every wind is steady, else
    (W, steps, 3), each wind at the start of each step."""
    if any(w.gust_strength > 0 for w in winds):
        start = np.arange(steps, dtype=np.float64) * dt
        return np.array([w.wind().sample(start) for w in winds])
    return np.array([w.wind().sample(np.zeros(1))[0] for w in winds])


def simulate_runs(tree: Tree, winds: list[WindCase], dt: float, steps: int, every: int = 1,
                  damping=0.0):
    """(wind, times (K,), bend (K, B), rot (K, B)) for every wind, the winds stepped
    together as lanes on all cores (`plantlod.sim.lanes`), a few lanes at a time so
    that memory stays near RUNS_BATCH_BYTES. A generator; `list` it to keep the runs
    for several `Runs` of one original (``simulated=``)."""
    from plantlod.sim.lanes import LaneModel, run_lanes
    from plantlod.sim.lanes_kernel import BLOCK     # the engine runs lanes in blocks:

    model = LaneModel.from_tree(tree, damping)
    times = run_times(dt, steps, every)
    per_lane = 16 * len(times) * max(tree.n_branches, 1)
    batch = max(BLOCK, RUNS_BATCH_BYTES // per_lane // BLOCK * BLOCK)   # no padding lanes
    for lo in range(0, len(winds), batch):
        chunk = winds[lo:lo + batch]
        bend, rot = run_lanes(model, wind_vectors(chunk, dt, steps), dt, steps, every=every,
                              addresses=tree.address, lane_names=[w.label() for w in chunk])
        rest = np.zeros((1, tree.n_branches))
        for k, wind in enumerate(chunk):
            yield wind, times, np.concatenate([rest, bend[k]]), np.concatenate([rest, rot[k]])


def simulate_pieces(tree: Tree, winds: list[WindCase], dt: float, steps: int, every: int = 1,
                    damping=0.0):
    """The runs of `simulate_runs`, every wind at once and a piece of time at a time: yields
    (first, bend, rot), bend and rot (W, R, B) float64 rad, the sample rows first ..
    first + R - 1 of every wind (row 0: at rest, the times of `simulate_runs`), in order.

    All winds are lanes of one run (`plantlod.sim.lanes`), so that every core has blocks of
    lanes, and a piece holds about RUNS_PIECE_BYTES of angles whatever the tree's size. The
    state is carried from piece to piece (`run_lanes`' first_step), so every sample has the
    bits of one whole run. A consumer that keeps what it reads of each piece (combined
    angles, tips) never holds the runs themselves."""
    from plantlod.sim.lanes import LaneModel, run_lanes, new_state
    from plantlod.sim.lanes_kernel import BLOCK

    if not winds:
        return
    model = LaneModel.from_tree(tree, damping)
    padded = -(-len(winds) // BLOCK) * BLOCK
    per_row = 16 * padded * max(tree.n_branches, 1)
    piece_rows = max(1, RUNS_PIECE_BYTES // per_row)
    vectors = wind_vectors(winds, dt, steps)
    state = new_state(model, len(winds))
    names = [w.label() for w in winds]
    rest = np.zeros((len(winds), 1, tree.n_branches))
    yield 0, rest, rest
    done, first = 0, 1
    while done < steps:
        n = min(piece_rows * every, steps - done)
        wind = vectors if vectors.ndim == 2 else vectors[:, done:done + n]
        bend, rot = run_lanes(model, wind, dt, n, every=every, state=state,
                              first_step=done + 1, addresses=tree.address, lane_names=names)
        rows = bend.shape[1]
        if rows:
            yield first, bend, rot
        del bend, rot                 # (not held while the next piece is run)
        first += rows
        done += n


@dataclass
class Summary:
    """Worst figures over a set of winds (relative errors, NaN where nothing counted):
    model.md 6's per-component amplitude and period errors (the measures for stalks), the
    tip error, and the motion error and major period error (the measures for branching
    trees)."""

    amplitude: float
    period: float
    tip: float
    motion: float = math.nan
    period_major: float = math.nan


def summarize(reports: list[Report]) -> Summary:
    def worst(values):
        vals = [v for v in values if math.isfinite(v)]
        return max(vals) if vals else math.nan
    return Summary(worst(r.amplitude_error for r in reports),
                   worst(r.period_error for r in reports),
                   worst(r.tip_error for r in reports),
                   worst(r.motion_error for r in reports),
                   worst(r.period_error_major for r in reports))
