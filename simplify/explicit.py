"""The explicit form of a level (model.md 5): groups merged from the tips, chords as rest geometry.

For any tree (stochastic instances, chains that turn, sympodial trees, 3D bushes)
the level-k tree is written out as an L-system of derivation length 0 whose
axiom draws one branch per group, each naming the original branch that roots
its group (the file's ``groups:`` section):

1. **Groups** (`grouping.merge_levels`): level 0 is every original branch on its own.
   Level k+1 merges groups of level k into their parent groups, cheapest first, until at
   most `LEVEL_RATIO` of level k's groups are left; so groups are connected, nested level in
   level, and the chain ends with one group. A merge costs its size times how far it mixes
   periods and turns level branches against their roots' frames (simplify/grouping.py).
2. **Geometry**: a group's branch runs from its root's rest base to its group tip
   (the end of its main path, model.md 5), the chord; so every group tip sits where it
   sits in the original at rest. Its frame is its tip member's, turned onto the chord.
   Where a group hangs from the middle of its parent group, the turtle moves there with
   ``f`` first (an offset).
3. **Equivalent leaves**: the leaves of a group, A_j n_j, give the leaf-force
   response M = sum_j A_j n_j n_j^T (3x3, symmetric, at rest). Its eigenvectors
   e_i with eigenvalues l_i >= 0 give at most three leaves with M = sum_i l_i e_i e_i^T
   exactly, and sum_i l_i = trace M = sum_j A_j: they are drawn with the summed area.
4. **Parameters**: k_FA, k_fp, C_d and leaf force gains per branch come from the
   statics of the groups (`closed_form`, the same least squares the grammar form
   uses: each group's combined angle in a set of wind directions, leaf part ~ v and
   drag part ~ v^2), then a gain matrix per branch (`gain_matrix`); k_bs and k_rs from
   the group's swing (`dominant_strengths`, `own_strengths`); then the level is fitted
   to motion in its own runs (`motion_fit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, NamedTuple

import numpy as np

from plantlod.formats.lsys_file import axiom_lines
from plantlod.lsys.expr import format_number
from plantlod.lsys.tree import Tree
from plantlod.sim.damping import period_of_strength

from .constants import (BASIS_LEAF_ALWAYS, BASIS_LEAF_FLOOR, BASIS_LEAF_TRY,
                        GROUP_SWING_DIRECTIONS, KAPPA_RANGE, LEVEL_BOUNDS, LEVEL_NAME_CHARS,
                        MIXED_CARRY, STRENGTH_SEARCH_EVERY, STRENGTH_SEARCH_POINTS)
from plantlod.compare.constants import COUNTED_AMPLITUDE_FRACTION, MAJOR_AMPLITUDE_FRACTION
from plantlod.compare.groups import main_paths
from .grouping import Grouping, merge_levels  # noqa: F401  (callers import them from here too)
from .static import rest_frames
from .swing_model import carry_mixing, unit_response  # noqa: F401  (tests import it from here)
from .finite import finite_fit


def is_stalk(tree: Tree) -> bool:
    """A chain: more than one branch, none with more than one child (held to relative bounds)."""
    return tree.n_branches > 1 and all(len(c) <= 1 for c in tree.children())


def equivalent_leaves(tree: Tree, frames, members: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Areas (k,) m^2 and world normals (k, 3) of at most three leaves whose leaf-force
    response sum A n n^T equals that of the leaves on ``members`` at rest (see module doc)."""
    on = np.isin(np.asarray(tree.leaf_branch, dtype=np.int64), members)
    if not on.any():
        return np.zeros(0), np.zeros((0, 3))
    normals = np.einsum("kij,kj->ki", frames.frame[np.asarray(tree.leaf_branch)[on]],
                        np.asarray(tree.leaf_normal, dtype=np.float64)[on])
    area = np.asarray(tree.leaf_area, dtype=np.float64)[on]
    if not area.any():                   # leaves of area 0 push nothing: as none (a 0/0 below)
        return np.zeros(0), np.zeros((0, 3))
    values, vectors = principal_leaves(area, normals)
    # sum of the eigenvalues kept = trace = summed area (up to the dropped ~0 ones; summed in
    # eigh's ascending order, as before principal_leaves was split off: the same bits)
    return values * (area.sum() / values[::-1].sum()), vectors


def basis_leaves(frame: np.ndarray, areas: np.ndarray, normals: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Nine leaves on one chord whose normals are its frame's axes and the six diagonals
    between two axes (both signs), with areas (9,) m² whose response Σ a n nᵀ is the
    nearest (non-negative least squares on the six entries) to that of the leaves given,
    areas (k,) and world normals (k, 3); each at least BASIS_LEAF_FLOOR of their sum, so
    that the fit (log scale) can grow any of them. World normals (9, 3).

    Their responses span every symmetric 3×3 matrix, where the ≤ 3 eigen-leaves of
    `equivalent_leaves` span only those with the group's own principal axes: the fit may
    then give the group a force response its leaves' shape does not have (docs/simplify.md).
    """
    from scipy.optimize import nnls

    r = 1.0 / math.sqrt(2.0)
    local = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [r, r, 0], [r, -r, 0], [r, 0, r],
                      [r, 0, -r], [0, r, r], [0, r, -r]], dtype=np.float64)
    world = local @ frame.T
    response = np.einsum("k,ki,kj->ij", areas, normals, normals)
    upper = np.triu_indices(3)
    basis = np.stack([np.outer(n, n)[upper] for n in world], axis=1)          # (6, 9)
    weights = nnls(basis, response[upper])[0]
    return np.maximum(weights, BASIS_LEAF_FLOOR * float(areas.sum())), world


def _zyz(m: np.ndarray) -> tuple[float, float, float]:
    """ZYZ angles (phi, alpha, psi) in radians of the rotation m = Rz(phi) Ry(alpha) Rz(psi)."""
    h = math.hypot(m[0, 2], m[1, 2])
    if h < 1e-12:
        return 0.0, (0.0 if m[2, 2] > 0 else math.pi), math.atan2(m[1, 0], m[0, 0] if m[2, 2] > 0 else -m[0, 0])
    return math.atan2(m[1, 2], m[0, 2]), math.atan2(h, m[2, 2]), math.atan2(m[2, 1], -m[2, 0])


def _chord_frame(root_frame: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The root's rest frame turned by the smallest rotation that takes its z axis to ``direction``."""
    z = root_frame[:, 2]
    axis = np.cross(z, direction)
    s, c = float(np.linalg.norm(axis)), float(np.dot(z, direction))
    if s < 1e-12:
        return root_frame.copy() if c > 0 else root_frame @ np.diag([1.0, -1.0, -1.0])
    k = axis / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    rot = np.eye(3) + s * kx + (1 - c) * kx @ kx
    return rot @ root_frame


def _turn(angles: tuple[float, float, float]) -> str:
    """Turtle modules for M <- M Rz(phi) Ry(alpha) Rz(psi) (degrees in the file)."""
    phi, alpha, psi = (math.degrees(a) for a in angles)
    out = ""
    for sym, a in (("/", phi), ("+", alpha), ("/", psi)):
        if a != 0.0:
            out += f"{sym}({format_number(a)})"
    return out


def _unturn(angles: tuple[float, float, float]) -> str:
    phi, alpha, psi = (math.degrees(a) for a in angles)
    out = ""
    for sym, a in (("/", -psi), ("+", -alpha), ("/", -phi)):
        if a != 0.0:
            out += f"{sym}({format_number(a)})"
    return out


@dataclass
class Skeleton:
    """One level's axiom and what its parameters are fitted with.

    modules        : the axiom (derivation length 0), one module or bracket per entry
    branch_address : (G,) axiom address of each group's branch
    leaf_address   : per group, the axiom addresses of its equivalent leaves
    leaf_area      : per group, their areas (m^2, summing to the group's leaf area)
    leaf_normal    : per group, their rest normals (k, 3) in the world frame
    length         : (G,) chord lengths, m
    """

    modules: list[str]
    branch_address: list[str]
    leaf_address: list[list[str]]
    leaf_area: list[np.ndarray]
    leaf_normal: list[np.ndarray]
    length: np.ndarray


@dataclass
class Chords:
    """The rest chords of one level's groups (world frame, m): base and tip (G, 3), length
    (G,), each chord's branch frame (G, 3, 3) before any roll, and each group's parent group
    (G,) (-1 for a root)."""

    base: np.ndarray
    tip: np.ndarray
    length: np.ndarray
    frame: np.ndarray
    parent_group: np.ndarray


def chords(original: Tree, grouping: Grouping, paths: list[np.ndarray], frames=None) -> Chords:
    """Each group's chord from its root's base to its group tip, and its branch frame: the
    frame of the group's tip member turned onto the chord, so that a group continuing straight
    on from this one's tip gets its root's own swing frame (model.md 3, α = 0: the parent's
    branch frame), as the original has it."""
    frames = rest_frames(original) if frames is None else frames
    parent = np.asarray(original.parent, dtype=np.int64)
    root = grouping.root
    parent_group = np.array([grouping.group[parent[r]] if parent[r] >= 0 else -1 for r in root],
                            dtype=np.int64)
    base = frames.base[root]
    tip = frames.tip[np.array([p[-1] for p in paths], dtype=np.int64)]
    chord = tip - base
    length = np.linalg.norm(chord, axis=1)
    frame = np.empty((grouping.count, 3, 3))
    for g in range(grouping.count):
        direction = chord[g] / length[g] if length[g] > 0 else frames.axis[root[g]]
        frame[g] = _chord_frame(frames.frame[paths[g][-1]], direction)
    return Chords(base, tip, length, frame, parent_group)


def explicit_skeleton(original: Tree, grouping: Grouping, frames, ch: Chords,
                      leaves: "str | list[tuple[np.ndarray, np.ndarray]]" = "eigen") -> Skeleton:
    """The explicit-form axiom of one level; rest geometry: chords (module doc, `chords`).

    leaves: "eigen", at most three equivalent leaves per group (`equivalent_leaves`),
    "basis", nine whose normals are the chord frame's axes and diagonals (`basis_leaves`),
    or per group (areas (k,) m², world normals (k, 3)) as given (`principal_leaves`).
    frames, ch: the original's `rest_frames` and the groups' `chords` (the caller's, made
    once for both leaf sets).
    """
    g_count = grouping.count
    base, tip, length, parent_group, frame = ch.base, ch.tip, ch.length, ch.parent_group, ch.frame
    children: list[list[int]] = [[] for _ in range(g_count)]
    for g in range(g_count):
        if parent_group[g] >= 0:
            children[parent_group[g]].append(g)
    members = [np.flatnonzero(grouping.group == g) for g in range(g_count)]

    tokens: list[str] = []          # one module or bracket per token, as the axiom's modules
    branch_address = [""] * g_count
    leaf_address: list[list[str]] = [[] for _ in range(g_count)]
    leaf_area: list[np.ndarray] = [np.zeros(0)] * g_count
    leaf_normal: list[np.ndarray] = [np.zeros((0, 3))] * g_count
    count = [0]

    def emit(text: str) -> None:
        # every module counts one address: a name with its (...) argument list is one module
        i = 0
        while i < len(text):
            j = i + 1
            if j < len(text) and text[j] == "(":
                j = text.index(")", j) + 1
            tokens.append(text[i:j])
            count[0] += 1
            i = j

    def place(g: int, parent_frame: np.ndarray, parent_tip: np.ndarray) -> None:
        offset_world = base[g] - parent_tip
        if np.linalg.norm(offset_world) > 1e-12 * max(1.0, float(np.abs(base[g]).max())):
            local = parent_frame.T @ offset_world
            d = math.hypot(*local.tolist())         # (no overflow where a root sits 1e300 m out)
            # turn z to the offset direction, move, turn back
            to = _zyz(_chord_frame(np.eye(3), local / d))
            emit(_turn(to) + f"f({format_number(d)})" + _unturn(to))
        emit(_turn(_zyz(parent_frame.T @ frame[g])))
        branch_address[g] = str(count[0])
        emit("F")
        if isinstance(leaves, str):
            areas, normals = equivalent_leaves(original, frames, members[g])
            if leaves == "basis" and len(areas):
                areas, normals = basis_leaves(frame[g], areas, normals)
        else:
            areas, normals = leaves[g]
        leaf_area[g], leaf_normal[g] = areas, normals
        for a, n in zip(areas, normals):
            local = frame[g].T @ n
            ang = (math.atan2(local[1], local[0]), math.asin(max(-1.0, min(1.0, -local[2]))), 0.0)
            emit("[")
            emit(_turn(ang))
            leaf_address[g].append(str(count[0]))
            emit("L")
            emit("]")
        todo.extend(("branch", c, frame[g], tip[g]) for c in reversed(children[g]))

    # depth first, children in order, each bracketed: a stack, not recursion (a chain of
    # 5,000 groups passed Python's recursion limit)
    top = [g for g in range(g_count) if parent_group[g] < 0]
    todo: list = [("branch", g, np.eye(3), np.zeros(3)) for g in reversed(top)]
    while todo:
        item = todo.pop()
        if item == "]":
            emit("]")
            continue
        _, g, parent_frame, parent_tip = item
        emit("[")
        todo.append("]")
        place(g, parent_frame, parent_tip)
    return Skeleton(tokens, branch_address, leaf_address, leaf_area, leaf_normal, length)


def principal_leaves(areas: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At most three leaves whose force equals that of the leaves given, in every wind and
    every pose: areas (k,) m² and world normals (k, 3) -> areas (m,) and normals (m, 3), m <= 3.

    A branch's leaves pull it with Σ_k s_L A_k (V · R n_k) R n_k = s_L R M Rᵀ V (model.md 4),
    M = Σ_k A_k n_k n_kᵀ: only M matters. M is symmetric and, the areas being >= 0, positive
    semi-definite, so M = Σ_i λ_i e_i e_iᵀ (λ_i >= 0, e_i orthonormal; numpy's eigh): the
    leaves (λ_i, e_i) pull the same, and their summed area Σ λ_i = trace M = Σ_k A_k is the
    same too. Eigenvalues at most 1e-12 of the largest are left out (their pull is at most
    that fraction of the largest)."""
    if len(areas) == 0:
        return np.zeros(0), np.zeros((0, 3))
    response = np.einsum("k,ki,kj->ij", areas, normals, normals)
    values, vectors = np.linalg.eigh(response)
    keep = values > 1e-12 * max(float(values.max()), 1e-300)
    return values[keep][::-1], vectors[:, keep].T[::-1]


@dataclass
class GroupSwing:
    """How each group swings from rest in its root's frame W_0 (`dominant_strengths`).

    kb, kr     : (G,) the strengths whose periods are each component's amplitude-weighted mean
    gain       : (G, 2) amplitude factors, Σ_d A_c(d) / Σ_d |X_c(d, ∞)|
    periods    : (G, 2, D) P_c(d), s (NaN: fewer than two crossings)
    amplitudes : (G, 2, D) A_c(d), rad
    statics    : (G, 2, D) X_c(d, ∞), rad: the component's static angle
    """

    kb: np.ndarray
    kr: np.ndarray
    gain: np.ndarray
    periods: np.ndarray
    amplitudes: np.ndarray
    statics: np.ndarray

    def take(self, order: np.ndarray) -> "GroupSwing":
        """The same figures for groups ``order`` (e.g. in a level tree's branch order)."""
        return GroupSwing(*(np.asarray(getattr(self, f))[order] for f in (
            "kb", "kr", "gain", "periods", "amplitudes", "statics")))


def dominant_strengths(original: Tree, paths: list[np.ndarray], dt: float, duration: float,
                       damping_ratio: float = 0.0, directions: np.ndarray | None = None
                       ) -> GroupSwing:
    """Each group's swing in its root's frame W_0 (`GroupSwing`).

    At small angles each main-path member j swings on its own from rest toward its static
    angles (θb_j, θr_j), each component with its own strength (model.md 4), and compare
    reads the group as the members' angles carried into W_0 (model.md 5), so per wind
    direction d the group's combined component c is the superposition

        X_c(d, t) = Σ_j Σ_m C_j[c, m] θ_m,j(d) u_(k_m,j)(t)

    with C_j member j's 2×2 carry map, m over bend and rotation and u_k the unit response
    (`unit_response`, the damping ratio included). Its period P_c(d) and amplitude A_c(d)
    are measured as model.md 6 measures them; the group's strength in W_0 is the one whose
    period is the amplitude-weighted mean of P_c over the directions (``strength_of_period``),
    and its amplitude factor Σ_d A_c(d) / Σ_d |X_c(d, ∞)|, the swing over the static angle
    (1 where every member has one strength and one frame). Directions: 8 horizontal ones.
    """
    from plantlod.compare.groups import carry_matrix, path_rotations
    from plantlod.compare.measures import amplitude, period

    from .static import horizontal_directions, static_angles, static_parts

    if directions is None:
        directions = horizontal_directions(GROUP_SWING_DIRECTIONS)
    d_count = len(directions)
    parts = static_parts(original, directions)
    bend, rot = static_angles(original, parts.leaf + parts.drag)            # (D, B)
    steps = int(round(duration / dt))
    t = np.arange(steps + 1) * dt
    members = np.concatenate(paths) if paths else np.zeros(0, dtype=np.int64)
    carry = carry_matrix(path_rotations(original, paths))                    # (M, 2, 2)
    strength = np.stack([np.asarray(original.bend_strength, dtype=np.float64)[members],
                         np.asarray(original.rotation_strength, dtype=np.float64)[members]],
                        axis=1)                                              # (M, 2)
    distinct, code = np.unique(strength, return_inverse=True)
    code = code.reshape(strength.shape)
    responses = unit_response(distinct, dt, steps, damping_ratio)           # (T, S)
    own_period = period_of_strength(distinct, dt)
    static = np.stack([bend[:, members], rot[:, members]], axis=2)          # (D, M, 2)
    g_count = len(paths)
    out = np.empty((g_count, 2))
    gain = np.ones((g_count, 2))
    periods = np.full((g_count, 2, d_count), np.nan)
    amplitudes = np.zeros((g_count, 2, d_count))
    statics = np.zeros((g_count, 2, d_count))
    at = 0
    for g, p in enumerate(paths):
        m = len(p)
        rows = slice(at, at + m)
        at += m
        for c in range(2):
            # weights (D, M, 2): each member component's part in W_0 component c
            w = carry[rows, c, :][None] * static[:, rows, :]
            mine = code[rows]                                               # (m, 2)
            statics[g, c] = w.sum(axis=(1, 2))
            settled = np.abs(statics[g, c])                                 # |X_c(d, ∞)|
            if np.all(mine == mine[0, c]) and np.all(np.abs(carry[rows, c, 1 - c]) < 1e-12):
                out[g, c] = distinct[mine[0, c]]                            # one strength
                amplitudes[g, c] = settled * amplitude(responses[:, mine[0, c]])
                periods[g, c] = own_period[mine[0, c]]
                continue
            signal = responses[:, mine.reshape(-1)] @ w.reshape(d_count, -1).T
            amp = np.atleast_1d(amplitude(signal))
            amplitudes[g, c] = amp
            per = np.atleast_1d(period(t, signal))
            periods[g, c] = per
            ok = np.isfinite(per) & (amp > 0)
            if ok.any():
                p_mean = float((amp[ok] * per[ok]).sum() / amp[ok].sum())
                out[g, c] = float(strength_of_period(p_mean, dt))
            else:
                out[g, c] = float(np.exp(np.log(distinct[mine.reshape(-1)]).mean()))
            if settled.sum() > 0:
                gain[g, c] = float(amp.sum() / settled.sum())
    return GroupSwing(out[:, 0].copy(), out[:, 1].copy(), gain, periods, amplitudes, statics)


def strength_of_period(period: np.ndarray, dt: float) -> np.ndarray:
    """k whose swing has period P s at time step dt: 1000 (2 - 2 cos(2π dt / P)) / dt, the
    inverse of model.md 4's P = 2π dt / arccos(1 - k dt / 2000)."""
    return 1000.0 * 2.0 * (1.0 - np.cos(2.0 * math.pi * dt / np.asarray(period))) / dt


def level_radii(original: Tree, grouping: "Grouping") -> np.ndarray:
    """(S,) m: each level branch's radius, its group root's; where that is 0 (a branch
    symbol of no radius, legal), the largest of its group's: the radius enters only the drag
    area 2π r L, whose C_d the fit sets, so any radius carries the group's drag, and none
    cannot (a drag coefficient of inf)."""
    radius = np.asarray(original.radius, dtype=np.float64)
    out = radius[grouping.root].copy()
    if np.any(out == 0):
        largest = np.zeros(len(out))
        np.maximum.at(largest, np.asarray(grouping.group), radius)     # each group's largest
        out = np.where(out == 0, largest, out)
    return out


def own_strengths(swing: GroupSwing, carry: np.ndarray, dt: float, duration: float,
                  damping_ratio: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """A chord's own k_bs', k_rs' (S,) from its group's swing in the group root's frame W_0
    (``swing``, `GroupSwing` in chord order).

    compare reads the chord's angles carried into W_0 (model.md 6): y = C θ' with C the 2×2
    carry map (S, 2, 2). Where C maps each own component mostly onto one W_0 component,
    that component's strength goes with it (a chord turned by 90° about its axis swaps
    them). Where C mixes them (both a diagonal and an off-diagonal entry above
    MIXED_CARRY), a bend and a rotation of different periods beat in every W_0 component,
    so the pair is searched (`searched_strengths`) whose beat reads closest to the group's
    periods in every direction.
    """
    c = np.abs(carry)
    w0 = np.stack([swing.kb, swing.kr], axis=1)                            # (S, 2)
    own = np.take_along_axis(w0, c.argmax(axis=1), axis=1)                 # W_0 comp. per own
    mixed = carry_mixing(carry) > MIXED_CARRY
    same = c[:, :, 0].argmax(axis=1) == c[:, :, 1].argmax(axis=1)          # both onto one
    search = np.flatnonzero(mixed | same)
    if search.size:
        a_max = swing.amplitudes.max(axis=(0, 1))                           # (D,) A_max per wind
        own[search] = searched_strengths(swing.take(search), carry[search], a_max, dt,
                                         duration, damping_ratio)
    return own[:, 0].copy(), own[:, 1].copy()


def searched_strengths(swing: GroupSwing, carry: np.ndarray, a_max: np.ndarray, dt: float,
                       duration: float, damping_ratio: float, costs: bool = False):
    """(n, 2) own strengths of n chords whose carry maps mix bend and rotation (and with
    ``costs`` their (n,) costs below at those strengths, 0 where nothing swings).

    A chord's own static angles s(d) = C⁻¹ g X(d, ∞) (the statics it is fitted to, g the group's
    amplitude factors) swing with
    its own strengths (k_b, k_r), so in W_0 it reads y_c(d, t) = Σ_m C[c, m] s_m(d) u_(k_m)(t).
    Over a grid of period pairs (STRENGTH_SEARCH_POINTS log-spaced over the group's periods,
    then again around the best), the pair minimising

        Σ_(c,d major) (ln(P_y,c(d) / P_c(d)) / p)⁴ + Σ_(c,d counted) ((a_y,c(d) - a_c(d)) / m)⁴

    is kept: the group's periods P_c(d) and amplitudes A_c(d) (`GroupSwing`), a = A / A_max(d)
    (``a_max`` (D,): the largest of any group, as model.md 6 counts), the components that
    count and the major ones as compare counts them, each error against level 1's bound (p
    period, m motion; LEVEL_BOUNDS) to the 4th power (a soft maximum), so the pair whose beat
    keeps both the periods and the swing of every direction within bounds wins; plus the same
    errors against the group's own largest swing, squared (a group far below A_max is not
    left free to beat: eval/bent_leafy level 1, 13 -> 24 of 30 winds).
    """
    from plantlod.compare.measures import amplitude, period

    motion_bound, period_bound = LEVEL_BOUNDS[1][:2]
    steps = int(round(duration / dt))
    t = (np.arange(steps + 1) * dt)[::STRENGTH_SEARCH_EVERY]
    own = period_of_strength(np.stack([swing.kb, swing.kr], axis=1), dt)    # (n, 2) s
    target = swing.periods                                                 # (n, 2, D)
    scale = np.where(a_max > 0, a_max, 1.0)[None, None, :]                # (1, 1, D) rad
    swing = swing.take(np.arange(len(own)))
    swing.amplitudes[:] /= scale
    swing.statics[:] /= scale
    # the group's own largest swing (in A_max units): its errors also count against it
    group_max = swing.amplitudes.max(axis=(1, 2), initial=0.0)
    group_max = np.where(group_max > 0, group_max, 1.0)
    major = np.isfinite(target) & (swing.amplitudes >= MAJOR_AMPLITUDE_FRACTION)
    counted = swing.amplitudes >= COUNTED_AMPLITUDE_FRACTION
    weight = np.where(np.isfinite(target), swing.amplitudes ** 2, 0.0)
    # the statics the gain matrix is fitted to: the group's, times its amplitude factors
    own_static = np.einsum("nij,njd->nid", np.linalg.pinv(carry),
                           swing.gain[:, :, None] * swing.statics)          # (n, 2, D)
    lo = np.fmin(own.min(axis=1), np.nanmin(np.where(weight > 0, target, np.inf), axis=(1, 2)))
    hi = np.fmax(own.max(axis=1), np.nanmax(np.where(weight > 0, target, -np.inf), axis=(1, 2)))
    q = STRENGTH_SEARCH_POINTS
    best = own.copy()
    least = np.zeros(len(own))
    for around_best in (False, True):
        if not around_best:
            grid = np.exp(np.linspace(np.log(lo * 0.99), np.log(hi * 1.01), q, axis=1))   # (n, Q)
            grid = np.broadcast_to(grid[:, None, :], (len(own), 2, q))      # (n, m, Q)
        else:
            step = np.log(hi * 1.01 / (lo * 0.99)) / (q - 1)
            grid = np.exp(np.log(best)[:, :, None]
                          + np.linspace(-1.0, 1.0, q)[None, None, :] * step[:, None, None])
        response = unit_response(strength_of_period(grid, dt).reshape(-1), dt, steps,
                                 damping_ratio, every=STRENGTH_SEARCH_EVERY)
        response = response.reshape(len(t), len(own), 2, q)                # (T, n, m, Q)
        for i in range(len(own)):
            if weight[i].sum() <= 0:
                continue
            part = carry[i][:, :, None] * own_static[i][None]                # (c, m, D)
            ub = response[:, i, 0, :]                                       # (T, Q)
            ur = response[:, i, 1, :]
            signal = (ub[:, :, None, None, None] * part[None, None, None, :, 0, :]
                      + ur[:, None, :, None, None] * part[None, None, None, :, 1, :])  # (T,Q,Q,c,D)
            flat = signal.reshape(len(t), -1)
            p = period(t, flat).reshape(q, q, 2, -1)
            a_y = amplitude(flat).reshape(q, q, 2, -1)
            with np.errstate(divide="ignore", invalid="ignore"):
                miss = np.where(np.isfinite(p), np.abs(np.log(p / target[i])), 1.0)
            own_weight = weight[i] / group_max[i] ** 2
            cost = (np.where(major[i], miss / period_bound, 0.0) ** 4).sum(axis=(2, 3)) \
                + (np.where(counted[i], (a_y - swing.amplitudes[i]) / motion_bound, 0.0) ** 4
                   ).sum(axis=(2, 3)) \
                + (own_weight * (miss / period_bound) ** 2).sum(axis=(2, 3)) \
                + (((a_y - swing.amplitudes[i]) / group_max[i] / motion_bound) ** 2).sum(axis=(2, 3))
            a, b = np.unravel_index(int(np.argmin(cost)), cost.shape)
            best[i] = grid[i, 0, a], grid[i, 1, b]
            least[i] = cost[a, b]
    strengths = strength_of_period(best, dt)
    return (strengths, least) if costs else strengths


class LevelFit(NamedTuple):
    """One leaf set's fit of a level (`explicit_system_text`): values (group order, per key),
    leaf_area (per group, its leaves' fitted areas), tree_leaf_area (K,) the same in the
    skeleton's leaf order, text(values, leaf_area) the level's text, static_error
    (`closed_form`), to_group (S,) each skeleton branch's group, carry (S, 2, 2) their carry
    maps, skeleton the level's tree before its parameters, leaf_normal (per group, (k, 3)) its
    leaves' rest normals in the world frame."""

    values: dict
    leaf_area: list
    tree_leaf_area: np.ndarray
    text: Callable
    static_error: float
    to_group: np.ndarray
    carry: np.ndarray
    skeleton: Tree
    leaf_normal: list


# the original's header values an explicit level carries over
LEVEL_HEADER_KEYS = ("branching_angle", "rotation_angle", "seed", "force_absorbed",
                     "force_propagated", "drag_coefficient", "leaf_force_scale")


def level_header(system) -> dict:
    """{key: value} of the original L-system's LEVEL_HEADER_KEYS (``explicit_system_text``'s
    ``header``)."""
    return {key: getattr(system, key) for key in LEVEL_HEADER_KEYS}


@finite_fit
def explicit_system_text(original: Tree, grouping: Grouping, *, name: str, header: dict,
                         level: int, dt: float, duration: float = 20.0,
                         refine: bool = True, gains: bool = True,
                         damping_ratio: float = 0.0, motion: bool = True,
                         runs_for=None, roll: bool = True) -> tuple[str, Tree]:
    """The level's explicit-form L-system (text, header comment not included) and its tree.

    header : the original's header values (`level_header`)
    gains  : give every branch a gain matrix (`gain_matrix`) in place of its k_FA
    damping_ratio : ζ of model.md 4 the groups' swings are measured under
    motion : fit the level to motion (`motion_fit`) after its statics
    roll   : turn level branches' swing frames about their axes where that suits their
             groups' swing (`swing_rolls`, the swing_roll key)
    runs_for : runs_for(tree), the original's `evaluate.Runs` read with a level tree's groups
               (`motion_fit.shared_runs`), in the winds the level is fitted to motion in; by
               default simplify's measurement winds over SIMPLIFY_WIND_RANGE, simulated here
    """
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys

    from .swing_rolls import swing_rolls
    from plantlod.lsys.rotation import rot_z
    from plantlod.lsys.system import SWING_ROLL_KEY
    from .targets import GroupMap
    from .closed_form import EXPLICIT_REFINE, GRAMMAR_REFINE, closed_form
    from plantlod.compare.groups import assign_stated_groups, carry_matrix, swing_turns
    from .gain_matrix import fit_gain_matrices
    from plantlod.lsys.system import GAIN_KEYS

    root_address = [original.address[r] for r in grouping.root]
    radius = level_radii(original, grouping)
    # (a name is cut to LEVEL_NAME_CHARS: a name of 999,990 characters, which a file may
    # give, made a level line longer than the reader's limit)
    shown = name if len(name) <= LEVEL_NAME_CHARS else name[:LEVEL_NAME_CHARS].rstrip() + "…"
    head = [f"name: {shown} level {level} (explicit form)", "derivation_length: 0"]
    # (the seed whole: a seed of 1e16 or more written as a float would not read back)
    head += [f"{key}: {int(header[key]) if key == 'seed' else format_number(header[key])}"
             for key in LEVEL_HEADER_KEYS]
    declarations = ["branch F: length=1 radius=1 bend_strength=1 rotation_strength=1", "leaf L: area=1"]

    # the groups' own strengths and amplitude factors, in group order (any leaf set)
    paths = main_paths(original, grouping.group, grouping.count)
    group_swing = dominant_strengths(original, paths, dt, duration, damping_ratio)
    gain_group = group_swing.gain
    # a stalk keeps the relative bounds (issue 12): fit relative errors
    settings = GRAMMAR_REFINE if is_stalk(original) else EXPLICIT_REFINE
    frames = rest_frames(original)
    ch = chords(original, grouping, paths, frames)
    rolls_of: dict[bytes, np.ndarray] = {}       # swing rolls (degrees); the leaf sets share them

    strengths_of: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}   # the leaf sets share them

    def framed(sk: Skeleton) -> tuple[Callable, Tree, np.ndarray]:
        """The level's text function (values, leaf areas -> text), its skeleton tree (chord
        lengths, radii and the skeleton's leaf areas set) and each skeleton branch's group."""

        def text(values: dict[str, np.ndarray] | None, leaf_area: list[np.ndarray]) -> str:
            """The level's text; without ``values``, no overrides section (the skeleton)."""
            lines = []
            for g, address in enumerate(sk.branch_address if values is not None else ()):
                kv = " ".join(f"{k}={format_number(values[k][g])}" for k in sorted(values)
                              if k != SWING_ROLL_KEY or values[k][g] != 0)
                lines.append(f"  {address}: {kv}")
                for a, area in zip(sk.leaf_address[g], leaf_area[g]):
                    lines.append(f"  {a}: area={format_number(area)}")
            lines.sort(key=lambda line: int(line.split(":")[0]))
            groups = [f"  {a}: {r}" for a, r in zip(sk.branch_address, root_address)]
            overrides = "overrides:\n" + "\n".join(lines) + "\n\n" if lines else ""
            return "\n".join(head) + "\n\n" + "\n".join(declarations) + "\n\n" \
                + "\n".join(axiom_lines(sk.modules)) + "\n\n" \
                + overrides + "groups:\n" + "\n".join(groups) + "\n"

        # the skeleton: its structure parsed (axiom and groups), its chord lengths, radii and
        # leaf areas set as the overrides would read back (format_number is exact), without
        # parsing thousands of override lines (tests/test_simplify_explicit.py compares the two)
        skeleton = build(parse_lsys(text(None, sk.leaf_area), name)).tree
        # the skeleton's branches come in axiom order; map them to group numbers
        order = np.array([int(a) for a in skeleton.address])
        position = {int(a): g for g, a in enumerate(sk.branch_address)}
        to_group = np.array([position[a] for a in order])
        area_of = {a: area for g in range(grouping.count)
                   for a, area in zip(sk.leaf_address[g], sk.leaf_area[g].tolist())}
        skeleton = replace(skeleton, length=np.array(sk.length[to_group], dtype=np.float64),
                           radius=np.array(radius[to_group], dtype=np.float64),
                           leaf_area=np.array([area_of[a] for a in skeleton.leaf_address],
                                              dtype=np.float64))
        return text, skeleton, to_group

    def fit(leaves: str) -> "LevelFit":
        """The level's values with one leaf set, its text and its static error (`closed_form`)."""
        sk = explicit_skeleton(original, grouping, frames, ch, leaves)
        text, skeleton, to_group = framed(sk)
        groups = assign_stated_groups(original, skeleton)
        gmap = GroupMap(groups, [paths[to_group[s]] for s in range(skeleton.n_branches)])
        turn = swing_turns(original, skeleton, gmap.paths)
        # swing rolls (`swing_rolls`): the skeleton as the text with its swing_roll keys reads
        roll_deg = np.zeros(skeleton.n_branches)
        if roll:
            key = to_group.tobytes() + turn.tobytes()
            if key not in rolls_of:          # the swing frames depend on neither leaf set
                rolls_of[key] = swing_rolls(original, gmap.paths, turn, group_swing.take(to_group),
                                            dt, duration, damping_ratio)
            roll_deg = rolls_of[key]
        if roll_deg.any():
            beta = np.radians(roll_deg)
            skeleton = replace(skeleton, swing_roll=beta)
            turn = turn @ rot_z(beta)
        carry = carry_matrix(turn)
        key = to_group.tobytes() + carry.tobytes()
        if key not in strengths_of:       # the strength search depends on neither leaf set
            strengths_of[key] = own_strengths(group_swing.take(to_group), carry, dt, duration,
                                              damping_ratio)
        kb, kr = strengths_of[key]
        params = closed_form(original, skeleton, gmap, refine=refine, turn=turn,
                             kappa_range=KAPPA_RANGE, strengths=(kb, kr),
                             target_gain=gain_group[to_group], settings=settings,
                             lengths=sk.length[to_group])
        fitted = {"length": sk.length[to_group], "radius": radius[to_group], "bend_strength": kb,
                  "rotation_strength": kr}
        if roll_deg.any():
            fitted[SWING_ROLL_KEY] = roll_deg
        for key in ("force_absorbed", "force_propagated", "drag_coefficient"):
            fitted[key] = params.branch[key]
        back = np.argsort(to_group)                      # group number -> skeleton branch
        values = {k: v[back] for k, v in fitted.items()}
        # leaf areas as fitted (the model's only leaf-specific gain; docs/simplify.md)
        by_address = {addr: area for (addr, _k), area in params.leaf_areas.items()}
        leaf_area = [np.array([by_address[a] for a in sk.leaf_address[g]])
                     for g in range(grouping.count)]
        tree_leaf_area = np.array([by_address[a] for a in skeleton.leaf_address],
                                  dtype=np.float64)              # the skeleton's leaf order
        if gains:
            # k_FA becomes each branch's gain matrix, fitted to its group's static response
            # (the skeleton with the fitted values: what the text would read back as)
            level = replace(skeleton, **{k: np.asarray(fitted[k], dtype=np.float64) for k in (
                "bend_strength", "rotation_strength", "force_absorbed", "force_propagated",
                "drag_coefficient")}, leaf_area=tree_leaf_area)
            matrices = fit_gain_matrices(level, original, gmap, turn=turn,
                                         target_gain=gain_group[to_group])[back]
            del values["force_absorbed"]
            values.update({key: matrices[:, k] for k, key in enumerate(GAIN_KEYS)})
        return LevelFit(values, leaf_area, tree_leaf_area, text, params.static_error, to_group,
                        carry, skeleton, sk.leaf_normal)

    def principal(fitted: LevelFit) -> LevelFit:
        """``fitted`` with each group's leaves replaced by its `principal_leaves` (at most
        three, pulling as the fitted ones do in every wind and pose): the same level, cheaper
        to simulate and draw (nine basis leaves a branch cost a level of 60 % of the branches
        as much simulation time as its original, family bush3d-184: 420 branches and 420
        leaves against 252 and 2,268)."""
        leaves = [principal_leaves(a, n) for a, n in zip(fitted.leaf_area, fitted.leaf_normal)]
        sk = explicit_skeleton(original, grouping, frames, ch, leaves)
        text, skeleton, to_group = framed(sk)
        if not np.array_equal(to_group, fitted.to_group):   # (leaves never reorder branches)
            raise AssertionError("the principal leaves reordered the level's branches")
        skeleton = replace(skeleton, swing_roll=fitted.skeleton.swing_roll)
        return fitted._replace(leaf_area=sk.leaf_area, tree_leaf_area=skeleton.leaf_area.copy(),
                               text=text, skeleton=skeleton, leaf_normal=sk.leaf_normal)

    # the eigen-leaves, unless the basis leaves fit the statics better (a lower static error;
    # without the refinement there is none to compare); a level of more than
    # BASIS_LEAF_ALWAYS branches tries them only where the eigen-leaves miss the statics by
    # more than BASIS_LEAF_TRY (a second fit costs as much as the first)
    best = fit("eigen")
    if refine and (grouping.count <= BASIS_LEAF_ALWAYS or best.static_error > BASIS_LEAF_TRY):
        basis = fit("basis")
        if basis.static_error < best.static_error:
            best = principal(basis)
    values, leaf_area, text = best.values, best.leaf_area, best.text
    to_group, carry, skeleton = best.to_group, best.carry, best.skeleton

    def rebuild(v: dict[str, np.ndarray]) -> tuple[str, Tree]:
        """The level's text with values ``v`` and the tree it reads back as: the skeleton with
        v's arrays (format_number writes each value so that it reads back exactly; a branch
        with a gain matrix reads as k_FA = 1; tests/test_simplify_explicit.py checks this
        against the parsed text), without parsing thousands of lines again."""
        arrays = {k: np.asarray(v[k], dtype=np.float64)[to_group] for k in (
            "length", "radius", "bend_strength", "rotation_strength", "force_propagated",
            "drag_coefficient")}
        if all(k in v for k in GAIN_KEYS):
            arrays["force_gain"] = np.stack([np.asarray(v[k], dtype=np.float64)[to_group]
                                             for k in GAIN_KEYS], axis=1)
            arrays["force_absorbed"] = np.ones(len(to_group))
        else:
            arrays["force_absorbed"] = np.asarray(v["force_absorbed"], dtype=np.float64)[to_group]
        return text(v, leaf_area), replace(skeleton, **arrays,
                                           leaf_area=best.tree_leaf_area.copy())

    if not motion:
        return rebuild(values)
    from .motion_fit import motion_fit

    if runs_for is None:
        from .motion_fit import measurement_runs_for

        runs_for = measurement_runs_for(original, dt, duration, damping_ratio)
    return motion_fit(original, values, rebuild, to_group, carry, runs_for, level, dt)
