"""Carrying a tree's state across a level switch (model.md 7).

State is (4, B) [θb, θ̇b, θr, θ̇r] (rad, rad/s) per branch of the level running.

- **Fine to coarse** (from the full tree): each simplified branch takes its group's
  combined angles and rates (`groups.combined_angles`, the same sum model.md 5 defines
  for the targets), carried from the group root's swing frame into the branch's own
  (explicit-form chords turn it: `groups.swing_turns`).
- **Coarse to fine** (to the full tree): the members of each group share the group's
  combined angle in proportion to their static deflection under the current wind,
  s_j = (θb_j, θr_j) static (`simplify.static`): θb_j = α_g sb_j, θr_j = β_g sr_j with the
  two numbers (α_g, β_g) per group solved so that the members' combined angles are the
  group's again (a 2 x 2 system; rates the same way). Where the wind is calm, or a
  component has no static deflection in a group, its main-path members share equally.
- Between two simplified levels the state goes through the full tree: coarse to fine,
  then fine to coarse. Every map is linear in the state; carrying a level's state to the
  full tree and back gives it unchanged.
"""

from __future__ import annotations

import numpy as np

from plantlod.lsys.tree import Tree
from plantlod.compare.groups import (carry_angles, carry_matrix, combined_angles, main_paths,
                                     path_rotations, swing_turns)
from plantlod.simplify.static import rest_frames, static_angles, static_parts

from .constants import SHARE_FLOOR


class Transfer:
    """State maps between the levels of one chain (`levels.Chain`)."""

    def __init__(self, trees: list[Tree], groups: list[np.ndarray], damping_ratio: float = 0.0):
        self.damping_ratio = damping_ratio
        self._unit: dict[tuple[int, bytes], tuple[np.ndarray, np.ndarray]] = {}
        self.original = trees[0]
        self.trees = trees
        self.groups = [np.asarray(g, dtype=np.int64) for g in groups]
        self.frames0 = rest_frames(self.original)
        self._paths: dict[int, list[np.ndarray]] = {}
        self._turn: dict[int, np.ndarray] = {}
        self._frames: dict[int, object] = {}
        self._carry: dict[int, np.ndarray] = {}
        self._targets: dict[tuple[int, int], np.ndarray | None] = {}

    def paths(self, level: int) -> list[np.ndarray]:
        if level not in self._paths:
            self._paths[level] = main_paths(self.original, self.groups[level],
                                            self.trees[level].n_branches)
        return self._paths[level]

    def frames(self, level: int):
        """The rest frames of level ``level`` (`simplify.static.rest_frames`), once per level."""
        if level not in self._frames:
            self._frames[level] = rest_frames(self.trees[level])
        return self._frames[level]

    def turn(self, level: int) -> np.ndarray:
        """(G, 3, 3) W_0^T W'_g: from level branch g's swing frame to its group root's."""
        if level not in self._turn:
            self._turn[level] = swing_turns(self.original, self.trees[level], self.paths(level))
        return self._turn[level]

    def carry(self, a: int, b: int, state: np.ndarray, wind: np.ndarray) -> np.ndarray:
        """The state (4, B_a) of level ``a`` as a state (4, B_b) of level ``b``; ``wind`` (3,)
        m/s is the wind the tree feels now, in its own frame (for the static shares)."""
        if a == b:
            return state.copy()
        if 0 < a < b:          # between two levels: its tips where the finer level has them
            targets = self._tip_targets(a, b)
            if targets is not None:
                return self._tips_matched_state(a, b, targets, state)
        full = state if a == 0 else self.to_original(a, state, wind)
        return full.copy() if b == 0 else self.to_level(b, full)

    def _tip_targets(self, a: int, b: int) -> np.ndarray | None:
        """(B_b,) the branch of level ``a`` whose tip each branch of level ``b`` stands for
        (a coarser level's group tips are among a finer level's); None where one is not.
        Once per pair of levels."""
        if (a, b) not in self._targets:
            fine_tip = {int(p[-1]): j for j, p in enumerate(self.paths(a)) if len(p)}
            found = [fine_tip.get(int(p[-1])) if len(p) else None for p in self.paths(b)]
            self._targets[(a, b)] = (None if any(j is None for j in found)
                                     else np.array(found, dtype=np.int64))
        return self._targets[(a, b)]

    def _tips_matched_state(self, a: int, b: int, targets: np.ndarray,
                            state: np.ndarray) -> np.ndarray:
        """Level ``a``'s state (4, B_a) as level ``b``'s (4, B_b), b coarser: angles from
        `tips_matched`, rates their derivative along level a's rates (the same map at the
        angles moved by TIP_RATE_STEP_S of them, differenced). The combined angles sum the
        members' rotation vectors, exact to first order; from the full tree they hold at a
        strong wind too (a sympodial tree at 15 m/s: level 2's tips 5.5 mm from the tree's),
        but between two levels the way through the full tree shares level a's angles among
        the members by linear statics, and there they put level 2's tips 12 cm from level
        1's (level 2's own tip error 2.9 cm, level 1's 1.7 cm; matched: 1.7 cm; session 30),
        and it inverts each chord's 2 x 2 carry map, whose near-singular determinant blew a
        twin_draw switch from level 1 to 2 at 20 m/s up to 5e11 rad/s (84 px at 1 px; a
        helper's scenes). model.md 7 leaves how a switch carries state free."""
        from .constants import TIP_RATE_STEP_S

        out = np.empty((4, self.trees[b].n_branches))
        out[0], out[2] = self.tips_matched(b, a, targets, state[0], state[2])
        h = TIP_RATE_STEP_S
        moved_b, moved_r = self.tips_matched(b, a, targets, state[0] + h * state[1],
                                             state[2] + h * state[3])
        out[1], out[3] = (moved_b - out[0]) / h, (moved_r - out[2]) / h
        return out

    def tips_matched(self, b: int, a: int, targets: np.ndarray, bend_a: np.ndarray,
                     rot_a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angles (B_b,) x 2 of the coarser level ``b`` that point each of its chords, from
        where its parent chords put its base, at the tip of the branch ``targets`` names in
        level ``a`` posed at ``bend_a``, ``rot_a``, parents first: with the swing frame S (at
        the branch's own angles 0) and the unit direction d = Sᵀ (tip - base) / |tip - base|,
        model.md 3's Rot turns e_z to (sin θ b/θ, sin θ r/θ, cos θ), so θ = arccos d_z and
        (θb, θr) = θ (d_x, d_y) / |(d_x, d_y)|; 0 where the target is the base itself."""
        from plantlod.sim.kinematics import depth_levels, pose

        fine, coarse = self.trees[a], self.trees[b]
        tips = pose(fine, bend_a, rot_a).tip[targets]                         # (B_b, 3)
        at = np.zeros((2, coarse.n_branches))       # level b's angles set so far (parents)
        for depth in depth_levels(np.asarray(coarse.parent, dtype=np.int64)):
            posed = pose(coarse, at[0], at[1])      # (this depth's own angles still 0)
            reach = tips[depth] - posed.base[depth]
            d = np.einsum("gji,gj->gi", posed.swing[depth], reach)          # Sᵀ (tip - base)
            size = np.linalg.norm(d, axis=1)
            side = np.hypot(d[:, 0], d[:, 1])
            theta = np.arccos(np.clip(d[:, 2] / np.where(size > 0, size, 1.0), -1.0, 1.0))
            scale = np.where(side > 0, theta / np.where(side > 0, side, 1.0), 0.0)
            at[0, depth], at[1, depth] = scale * d[:, 0], scale * d[:, 1]
        return at[0], at[1]

    def to_level(self, level: int, full: np.ndarray) -> np.ndarray:
        """Fine to coarse: each level branch takes its group's combined angles and rates."""
        paths, back = self.paths(level), np.transpose(self.turn(level), (0, 2, 1))
        out = np.empty((4, self.trees[level].n_branches))
        for rb, rr in ((0, 2), (1, 3)):                    # angles, then rates
            cb, cr = combined_angles(self.original, paths, full[rb], full[rr])
            out[rb], out[rr] = carry_angles(back, cb, cr)
        return out

    def to_original(self, level: int, state: np.ndarray, wind: np.ndarray) -> np.ndarray:
        """Coarse to fine: members share their group's combined angle by static deflection."""
        paths, groups = self.paths(level), self.groups[level]
        back = np.transpose(self.turn(level), (0, 2, 1))
        sb, sr = self._shares(level, wind)
        ab, ar = combined_angles(self.original, paths, sb, np.zeros_like(sr))   # (G,) each
        bb, br = combined_angles(self.original, paths, np.zeros_like(sb), sr)
        det = ab * br - bb * ar
        diagonal = np.abs(det) <= 1e-12 * np.maximum(np.abs(ab * br), np.finfo(float).tiny)
        g = np.where(groups >= 0, groups, 0)
        inside = groups >= 0
        out = np.zeros((4, self.original.n_branches))
        for rb, rr in ((0, 2), (1, 3)):                    # angles, then rates
            cb, cr = _uncarry(back, state[rb], state[rr])  # the group's combined values
            with np.errstate(divide="ignore", invalid="ignore"):
                alpha = np.where(diagonal, cb / ab, (cb * br - bb * cr) / det)
                beta = np.where(diagonal, cr / br, (ab * cr - ar * cb) / det)
            alpha = np.where(np.isfinite(alpha), alpha, 0.0)
            beta = np.where(np.isfinite(beta), beta, 0.0)
            out[rb] = np.where(inside, alpha[g] * sb, 0.0)
            out[rr] = np.where(inside, beta[g] * sr, 0.0)
        return out

    def _shares(self, level: int, wind: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Static (θb, θr) (B0,) of the original under ``wind``; per group and component, a
        main-path deflection too small to share by (or none: calm) is replaced, on the main
        path, by the diagonal entry of each member's carry map (1 where its frame is W_0's,
        -1 where it is turned half round, so that members add up in W_0 and never cancel),
        and by 0 elsewhere in the group."""
        wind = np.asarray(wind, dtype=np.float64)
        speed = float(np.linalg.norm(wind))
        b0 = self.original.n_branches
        if speed > 0:
            parts = static_parts(self.original, (wind / speed)[None], self.frames0)
            sb, sr = static_angles(self.original, speed * parts.leaf + speed ** 2 * parts.drag,
                                   self.frames0)
            sb, sr = sb[0].copy(), sr[0].copy()
        else:
            sb, sr = np.zeros(b0), np.zeros(b0)
        groups = self.groups[level]
        inside = groups >= 0
        paths = self.paths(level)
        on_path = np.concatenate(paths) if paths else np.zeros(0, dtype=np.int64)
        path_group = np.repeat(np.arange(len(paths)), [len(p) for p in paths])
        carried = self._path_carry(level)                                   # (M, 2, 2)
        for s, own in ((sb, carried[:, 0, 0]), (sr, carried[:, 1, 1])):
            # judged on the main path, which the combined angle reads (a group whose side
            # members alone deflect would share nothing back)
            size = np.zeros(self.trees[level].n_branches)
            np.maximum.at(size, path_group, np.abs(s[on_path]))
            largest = float(np.abs(s).max()) if b0 else 0.0
            flat = (size <= SHARE_FLOOR * largest) | (size == 0.0)          # (G,)
            s[inside & flat[np.where(inside, groups, 0)]] = 0.0
            fill = flat[path_group]
            s[on_path[fill]] = own[fill]
        return sb, sr

    def _path_carry(self, level: int) -> np.ndarray:
        """(M, 2, 2) carry maps of the main-path members of level ``level`` into their group
        roots' frames, in path order (`groups.carry_matrix` of `groups.path_rotations`)."""
        if level not in self._carry:
            self._carry[level] = carry_matrix(path_rotations(self.original, self.paths(level)))
        return self._carry[level]


    def predicted(self, level: int, history: np.ndarray, dt: float) -> np.ndarray | None:
        """Going finer: the state (4, B) level ``level`` would have now had it run from rest
        under ``history`` (s, 3) m/s (the tree's wind at the start of each step so far), to
        first order: each branch's components are oscillators driven toward their static
        angles (model.md 4's step with k_FA F·S e = k θ_eq), θ_eq = g a + g|g| d for a wind
        g(t) V̂ of one direction V̂ (a, d: the leaf and drag parts of the level's static
        angles at unit speed, the gain matrix included). None where the direction changes.
        No level's error is carried into the finer one, only the linear theory's."""
        from scipy.signal import lfilter

        from plantlod.sim.damping import ratio_coefficient

        tree = self.trees[level]
        speeds = np.linalg.norm(history, axis=1)
        top = float(speeds.max()) if len(speeds) else 0.0
        if top == 0.0:
            return np.zeros((4, tree.n_branches))
        ref = history[int(np.argmax(speeds))] / top
        g = history @ ref
        if np.abs(history - g[:, None] * ref[None]).max() > 1e-9 * top:
            return None
        key = (level, ref.tobytes())
        if key not in self._unit:
            frames = self.frames(level)       # the key is per tree (headings): frames per level
            parts = static_parts(tree, ref[None], frames)
            self._unit[key] = tuple(np.stack(static_angles(tree, part, frames))[:, 0]
                                    for part in (parts.leaf, parts.drag))
        leaf, drag = self._unit[key]                                      # (2, B) each
        out = np.empty((4, tree.n_branches))
        # the drives, and a zero after them: filtered, sample s is θ after the s-th step
        drive = np.stack([np.append(g, 0.0), np.append(g * np.abs(g), 0.0)])   # (2, s + 1)
        for c, strength in enumerate((tree.bend_strength, tree.rotation_strength)):
            k = np.asarray(strength, dtype=np.float64) / 1000.0
            distinct, inverse = np.unique(k, return_inverse=True)
            damp = ratio_coefficient(distinct, dt, self.damping_ratio)
            theta = np.empty((2, len(distinct)))
            rate = np.empty((2, len(distinct)))
            for j, (kj, cj) in enumerate(zip(distinct, damp)):
                # model.md 4's step, v <- (1 - c) v + k (x - θ), θ <- θ + v dt, as a filter:
                # Θ/X = k dt z⁻¹ / (1 - (2 - c - k dt) z⁻¹ + (1 - c) z⁻²)
                y = lfilter([0.0, kj * dt], [1.0, -(2.0 - cj - kj * dt), 1.0 - cj], drive,
                            axis=1)
                theta[:, j] = y[:, -1]
                rate[:, j] = (y[:, -1] - y[:, -2]) / dt
            out[2 * c] = leaf[c] * theta[0, inverse] + drag[c] * theta[1, inverse]
            out[2 * c + 1] = leaf[c] * rate[0, inverse] + drag[c] * rate[1, inverse]
        return out


def _uncarry(back: np.ndarray, bend: np.ndarray, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (Θb, Θr) that `carry_angles(back, Θb, Θr)` turns into (bend, rot): its 2 x 2 map
    inverted exactly, so that coarse -> fine -> coarse returns the state it started from."""
    a, b = back[:, 1, 1], -back[:, 1, 0]                 # bend' = a Θb + b Θr
    c, d = -back[:, 0, 1], back[:, 0, 0]                 # rot'  = c Θb + d Θr
    det = a * d - b * c
    return (d * bend - b * rot) / det, (a * rot - c * bend) / det


def switch_errors(chain, transfer: Transfer, levels, speed: float, dt: float,
                  duration: float, gusts=None) -> np.ndarray:
    """(L,) metres, 0 for levels not in ``levels``: how far each level in ``levels``, switched
    into, puts its tips from the full tree's (the original's group tips, as a level's tip
    error is measured), the worst over winds of ``speed`` m/s toward TIP_ERROR_DIRECTIONS
    (relative to the tree), steady or with ``gusts`` (`levels.Gusts`: the scene's own, as
    the levels' tip errors are measured), switches every SWITCH_SAMPLE_S of a run of
    ``duration`` s (at its end where it is shorter) and SWITCH_FOLLOW_S after each.

    A switch to a finer level starts it from `Transfer.predicted`, linear theory, and in the
    undamped model what that misses swings on; in a strong wind the tree's lean makes it
    cm where the level's own tip error is mm (docs/scene.md, "Where the budget does not
    hold"). The schedule spends it as the level's error after such a switch
    (`schedule.held_levels`). Measured against the full tree, not against the level run from
    rest (session 30: the two misses then added up, though they are largest at other times
    and toward other sides: twin_draw at 15 m/s, level 6 switched into is 62 mm from the full
    tree where its tip error and its miss against itself summed to 106 mm). chain:
    `levels.Chain`; transfer: its `Transfer`. Work: the full tree's run, then each level's
    branches x (the run plus one follow-up per switch), per direction.
    """
    from plantlod.compare.runs import tip_series
    from plantlod.sim.lanes import run_lanes
    from plantlod.sim.wind import GustyWind, wind_from_speed
    from plantlod.simplify.targets import group_map

    from .constants import (SWITCH_FOLLOW_S, SWITCH_SAMPLE_EVERY_S, SWITCH_SAMPLE_S,
                            TIP_ERROR_DIRECTIONS)

    out = np.zeros(len(chain.trees))
    original = chain.trees[0]
    every = max(1, int(round(SWITCH_SAMPLE_EVERY_S / dt)))       # steps between tip samples
    gap = every * max(1, int(round(SWITCH_SAMPLE_S / (every * dt))))   # steps between switches
    steps = int(round(duration / dt))
    follow = every * max(1, int(round(SWITCH_FOLLOW_S / (every * dt))))
    starts = list(range(gap, steps + 1, gap)) or [steps // every * every]   # (a short run: its end)
    levels = sorted(int(k) for k in levels)
    if not levels or not starts[0] or original.n_branches == 0 or speed <= 0:
        return out
    # each level's branches' group tips on the full tree (a level's branches in its order)
    tips_of = {k: (np.arange(original.n_branches) if k == 0
                   else group_map(original, chain.trees[k]).tips) for k in levels}
    wanted = np.unique(np.concatenate(list(tips_of.values())))
    column = np.searchsorted(wanted, np.arange(original.n_branches))
    rows_at = [slice(s // every - 1, (s + follow) // every) for s in starts]   # steps s .. s + follow
    for direction in TIP_ERROR_DIRECTIONS:
        # the wind at the start of each step, (steps, 3) m/s
        wind = wind_from_speed(speed, direction)
        if gusts is not None:
            wind = GustyWind(wind, seed=gusts.seed, strength=gusts.strength)
        history = wind.sample(np.arange(starts[-1] + follow) * dt)
        # the full tree from rest, its angles after every ``every``-th step (row j: step (j+1) every)
        bend, rot = run_lanes(chain.lane_model(0), history[None], dt, starts[-1] + follow,
                              every=every)
        full = tip_series(original, bend[0], rot[0], wanted)              # (rows, n, 3)
        after = np.stack([history[s:s + follow] for s in starts])        # (switches, follow, 3)
        for k in levels:
            tree = chain.trees[k]
            if tree.n_branches == 0:
                continue
            state = np.stack([transfer.predicted(k, history[:s], dt) for s in starts])
            # each switch followed on from its predicted state (rows every ``every`` steps after it)
            b_on, r_on = run_lanes(chain.lane_model(k), after, dt, follow, every=every,
                                   state=state.copy())
            want = full[:, column[tips_of[k]]]
            for j, rows in enumerate(rows_at):
                got = tip_series(tree, np.concatenate([state[j, :1], b_on[j]]),
                                 np.concatenate([state[j, 2:3], r_on[j]]),
                                 np.arange(tree.n_branches))
                gap_m = np.linalg.norm(got - want[rows], axis=-1).max()
                out[k] = max(out[k], float(gap_m))
    return out
