"""The turtle: from the interpreted derived string to the branch tree (model.md section 2).

`build_tree` reads a `DerivedString` the way a turtle would (docs/lsys-format.md,
"Symbols") and returns the `Tree` of the branches and leaves it draws. It does
so without a per-module Python loop, in numpy:

1. Every module gets a *kind* (turn, move, branch, leaf, bracket, ...) from a
   table over the alphabet.
2. The bracket structure gives each module its *turtle predecessor*: the
   nearest earlier module, among those that matter, whose state it inherits
   (the previous one in the same bracket scope, else the one before the
   enclosing ``[``, recursively). `_Scopes` answers these nearest-ancestor
   queries with one sort by bracket level and a few cumulative maxima.
3. The state a branch or leaf needs is *relative to the current branch*: the
   rotation Q = R_parent^T M, the offset o (turtle moves since the parent's tip,
   in the parent's frame) and the current branch itself. Each turtle module is a
   rigid transform of that state (a turn rotates it, ``f`` shifts it, a branch
   resets it to (I, 0, itself)), so the state at every module is the
   composition of the transforms on its path back to the nearest branch.
   `_compose_to_barrier` computes all of them at once by pointer jumping:
   about log2(modules between a module and its branch) rounds of batched 3x3
   products, usually one or two.
4. ``$`` needs the absolute orientation. Its rolls are computed first, one
   level of the tree of ``$`` modules at a time (a ``$`` at level k has k
   ``$`` above it), and then enter step 3 as ordinary turns. Strings without
   ``$`` skip this; with it the cost is one more pointer-jumping pass plus a
   few small numpy operations (~0.1 ms) per level.

Speed (2-core shared VM, best of 4): ABOP 1.24a at n = 8 (1.17 M modules,
390,625 branches) 0.44 s, 2.6 M modules/s; the same with ``$`` in every
successor (1.46 M modules, 3,280 nested ``$`` levels) 1.06 s, 1.4 M modules/s;
ABOP 2.6 (``$``, ``!``, parameters) at n = 16: 2.2 M modules/s. About half of
the time goes into the address strings.

The ``!(r)`` radius is the parameter of the nearest ``!`` above the branch
(a nearest-ancestor query), else the symbol's radius.

Warnings (leaves read while no branch is current, overrides that match no module) go
through `warnings.warn`; `plantlod.lsys.build` collects them for the CLI.

Addresses: a branch carries the address of the module that drew it. Through
interpretation one module can draw several branches; the second, third, ...
branch under one address get the suffixes ``:1``, ``:2``, ... (drawing order).
Leaves carry the plain address. An override applies to every branch (its
branch keys) and every leaf (``area``) drawn under its address.
"""

from __future__ import annotations

import math
import warnings
import numpy as np

from .constants import DEFAULT_MOVE_LENGTH, DOLLAR_VERTICAL_TOL
from .derived import DerivedString
from .errors import InputError
from .rotation import rot_x, rot_y, rot_z, zyz_from_matrix
from .system import BRANCH_KEYS, GAIN_KEYS, IDENTITY_GAIN, LEAF_ORDINAL_KEY, SWING_ROLL_KEY, LSystem
from .tree import Tree, chain_depths, occurrence_numbers

# Module kinds.
PLAIN, OPEN, CLOSE, TURN, MOVE, RADIUS, ROLL, BRANCH, LEAF = range(9)

# Turn symbols: character -> (axis 0/1/2 = local x/y/z, sign, default angle).
# The default is "branching" (system.branching_angle), "rotation"
# (system.rotation_angle) or a fixed number of degrees.
_TURNS = {
    "+": (1, 1.0, "branching"), "-": (1, -1.0, "branching"),
    "&": (0, 1.0, "branching"), "^": (0, -1.0, "branching"),
    "/": (2, 1.0, "rotation"), "\\": (2, -1.0, "rotation"),
    "|": (1, 1.0, 180.0),
}
_FIXED_KINDS = {"[": OPEN, "]": CLOSE, "f": MOVE, "!": RADIUS, "$": ROLL}

# How many dropped-leaf addresses (unmatched overrides) a warning lists (warns about).
_WARN_LIST = 5
_ADDRESS_PARTS_SHOWN = 12      # parts of a long address shown in a message


def build_tree(system: LSystem, derived: DerivedString) -> Tree:
    """Run the turtle over ``derived`` (the interpreted string) and return its tree.

    Branches are in drawing order (parent before child); angles in the string
    are degrees, in the Tree radians. Raises `InputError` for a ``]`` without
    its ``[`` and for a non-finite parameter of a turtle module. Leaves read
    while no branch is current are dropped with a warning (`warnings.warn`).
    """
    n = len(derived)
    codes = np.asarray(derived.codes, dtype=np.int64)
    counts = np.diff(np.asarray(derived.param_start, dtype=np.int64))
    value = np.full(n, np.nan)                  # (n,) first parameter, NaN if none
    has_param = counts > 0
    value[has_param] = derived.params[derived.param_start[:-1][has_param]]

    kind = _kind_table(system, derived.alphabet)[codes]
    bare = (kind == RADIUS) & ~has_param
    if bare.any():
        warnings.warn(f"{int(bare.sum()):,} '!' without a parameter (ABOP: decrement the "
                      "diameter) do nothing here; write !(r) to set the radius of the "
                      "branches after it", stacklevel=2)
        kind[bare] = PLAIN
    _check_finite(system, derived, kind, has_param, value)

    scopes = _Scopes(kind, system, derived)
    turns = _turn_rotations(system, derived.alphabet, codes, kind, value, has_param)
    rolls = _roll_rotations(scopes, kind, turns) if np.any(kind == ROLL) else None
    return _assemble(system, derived, codes, kind, value, has_param, scopes, turns, rolls)


# --- module kinds and parameters ------------------------------------------------

def _kind_table(system: LSystem, alphabet: list[str]) -> np.ndarray:
    """(len(alphabet),) int8: the kind of every module character."""
    branch_names = {b.name for b in system.branches}
    leaf_names = {leaf.name for leaf in system.leaves}
    table = np.full(len(alphabet), PLAIN, dtype=np.int8)
    for code, ch in enumerate(alphabet):
        if ch in _TURNS:
            table[code] = TURN
        elif ch in _FIXED_KINDS:
            table[code] = _FIXED_KINDS[ch]
        elif ch in branch_names:
            table[code] = BRANCH
        elif ch in leaf_names:
            table[code] = LEAF
    return table


def _check_finite(system, derived, kind, has_param, value) -> None:
    """Raise InputError if a turtle module's parameter is infinite or NaN, or if a
    length (branch), area (leaf) or radius (`!`) is negative."""
    used = has_param & np.isin(kind, (TURN, MOVE, RADIUS, BRANCH, LEAF))
    bad = np.flatnonzero(used & ~np.isfinite(value))
    if bad.size:
        i = int(bad[0])
        address = derived.address_strings([i])[0]
        raise InputError(f"module {derived.module_text(i)} at address {address} has a "
                         "non-finite parameter; expected a finite number", system.source)
    amount = has_param & np.isin(kind, (RADIUS, BRANCH, LEAF))
    bad = np.flatnonzero(amount & (value < 0))
    if bad.size:
        i = int(bad[0])
        address = derived.address_strings([i])[0]
        what = {RADIUS: "radius", BRANCH: "length", LEAF: "area"}[int(kind[i])]
        raise InputError(f"module {derived.module_text(i)} at address {address} has a negative "
                         f"{what}; expected a number >= 0", system.source)


def _turn_rotations(system, alphabet, codes, kind, value,
                    has_param) -> tuple[np.ndarray, np.ndarray]:
    """The rotations of the t turn modules: (turn_rot (t, 3, 3), turn_of (n,) int64).

    Turn module i rotates the turtle by turn_rot[turn_of[i]] in its own frame
    (M <- M turn_rot[...]); turn_of is -1 for other modules. Angles: the first
    parameter in degrees, else the system's default; ``|`` is always Ry(pi).
    """
    axis = np.full(len(alphabet), -1, dtype=np.int64)
    sign = np.zeros(len(alphabet))
    default = np.zeros(len(alphabet))
    flip_code = np.zeros(len(alphabet), dtype=bool)
    for code, ch in enumerate(alphabet):
        if ch in _TURNS:
            ax, sg, dflt = _TURNS[ch]
            axis[code], sign[code], flip_code[code] = ax, sg, ch == "|"
            default[code] = {"branching": system.branching_angle,
                             "rotation": system.rotation_angle}.get(dflt, dflt)
    turn = np.flatnonzero(kind == TURN)
    tcode = codes[turn]
    flip = flip_code[tcode]           # `|` ignores a parameter: Ry(pi) exactly
    degrees = np.where(has_param[turn] & ~flip, value[turn], default[tcode])
    radians = sign[tcode] * np.radians(degrees)
    radians[flip] = math.pi
    turn_rot = np.empty((len(turn), 3, 3))
    for ax, rot in ((0, rot_x), (1, rot_y), (2, rot_z)):
        pick = axis[tcode] == ax
        turn_rot[pick] = rot(radians[pick])
    turn_of = np.full(len(kind), -1, dtype=np.int64)
    turn_of[turn] = np.arange(len(turn))
    return turn_rot, turn_of


def _local_rotations(modules, turns, rolls=None) -> np.ndarray:
    """(k, 3, 3) the rotation each of ``modules`` applies in the turtle frame.

    turns = (turn_rot, turn_of) of `_turn_rotations`; rolls = (roll_rot,
    roll_of) likewise for the ``$`` modules (identity when None); others: I.
    """
    out = np.broadcast_to(np.eye(3), (len(modules), 3, 3)).copy()
    for table in (turns, rolls):
        if table is not None:
            rot, row_of = table
            row = row_of[modules]
            out[row >= 0] = rot[row[row >= 0]]
    return out


# --- bracket structure ------------------------------------------------------------

class _Scopes:
    """The bracket scopes of a string, for nearest-ancestor queries.

    A module's *level* is the number of ``[`` open before it (for a ``[``
    itself: the level of the scope it opens). Sorting modules by (level,
    position) puts every scope's own modules in one contiguous *segment* that
    starts with its ``[``; level 0 is one segment without an opener.

    Arrays over ranks r = 0..n-1 of that order:
      order     : (n,) int64  module at rank r
      seg_start : (n,) int64  rank where r's segment starts
      opener    : (n,) int64  module index of r's segment's ``[`` (-1: level 0)
    Per module: rank (n,) int64, scope_id (n,) int64 (index among the ``[``, -1).
    Per scope s (its ``[`` is the s-th ``[``):
      probe_rank   : (S,) int64  rank of the last module before the ``[`` in the
                                 enclosing segment (-1 if none)
      parent_scope : (S,) int64  the enclosing scope (-1: level 0)
    """

    def __init__(self, kind: np.ndarray, system: LSystem, derived: DerivedString):
        n = len(kind)
        is_open = (kind == OPEN).astype(np.int64)
        is_close = (kind == CLOSE).astype(np.int64)
        after = np.cumsum(is_open - is_close)              # depth after each module
        if n and after.min() < 0:
            i = int(np.flatnonzero(after < 0)[0])
            address = derived.address_strings([i])[0]
            raise InputError(f"']' at address {address} closes no '['; "
                             "expected balanced brackets", system.source)
        before = after - is_open + is_close               # depth before each module
        level = before + is_open
        sort_key = level.astype(np.int16) if n and level.max() < 2**15 else level
        self.order = np.argsort(sort_key, kind="stable")   # radix sort for int16
        self.rank = np.empty(n, dtype=np.int64)
        self.rank[self.order] = np.arange(n)
        sorted_level = level[self.order]
        ranks = np.arange(n)
        starts = is_open[self.order].astype(bool)
        starts[:1] = True
        starts[1:] |= sorted_level[1:] != sorted_level[:-1]
        self.seg_start = np.maximum.accumulate(np.where(starts, ranks, 0))
        first = self.order[self.seg_start]
        self.opener = np.where(is_open[first] == 1, first, -1)

        opens = np.flatnonzero(is_open)
        self.scope_id = np.full(n, -1, dtype=np.int64)
        self.scope_id[opens] = np.arange(len(opens))
        # The last module at the outer level before each `[`: sorted keys
        # level * (n + 1) + position are increasing along the order.
        sorted_key = sorted_level * (n + 1) + self.order
        probe = np.searchsorted(sorted_key, before[opens] * (n + 1) + opens) - 1
        valid = probe >= 0
        valid[valid] = sorted_level[probe[valid]] == before[opens][valid]
        self.probe_rank = np.where(valid, probe, -1)
        outer_opener = np.where(valid, self.opener[np.maximum(probe, 0)], -1)
        self.parent_scope = np.where(outer_opener >= 0,
                                     self.scope_id[np.maximum(outer_opener, 0)], -1)

    def nearest_ancestor(self, member: np.ndarray, queries: np.ndarray) -> np.ndarray:
        """(len(queries),) int64: for each query module, the nearest member before it.

        "Before" in the turtle's sense: the module whose state the query's
        state derives from, skipping non-members, bracket pairs closed in
        between, and brackets. -1 where there is none. member: (n,) bool.
        """
        ranks = np.arange(len(member))
        # last[r]: rank of the last member at ranks <= r (-1: none)
        last = np.maximum.accumulate(np.where(member[self.order], ranks, -1))

        def last_member(upto, seg_start):
            """Module of the last member at rank <= upto and >= seg_start, else -1."""
            lm = np.where(upto >= 0, last[np.maximum(upto, 0)], -1)
            return np.where((upto >= 0) & (lm >= seg_start), self.order[np.maximum(lm, 0)], -1)

        probe = self.probe_rank
        scope_anc = _resolve_up(last_member(probe, self.seg_start[np.maximum(probe, 0)]),
                                self.parent_scope)
        r = self.rank[queries]
        found = last_member(r - 1, self.seg_start[r])
        opener = self.opener[r]
        inside = opener >= 0
        inherited = np.full(len(r), -1, dtype=np.int64)
        inherited[inside] = scope_anc[self.scope_id[opener[inside]]]
        return np.where(found >= 0, found, inherited)


def _resolve_up(value: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """Fill each -1 in ``value`` with the value of the nearest ancestor that has one.

    value, parent: (k,) int64 over the nodes of a forest (parent -1 at a root).
    Pointer jumping: log2(depth) rounds.
    """
    value = value.copy()
    ptr = parent.copy()
    todo = np.flatnonzero((value < 0) & (ptr >= 0))
    while todo.size:
        p = ptr[todo]
        value[todo] = value[p]
        ptr[todo] = ptr[p]
        todo = todo[(value[todo] < 0) & (ptr[todo] >= 0)]
    return value


# --- composing transforms along the module tree -------------------------------------

def _matmul3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k, 3, 3) batched product a @ b with a fixed summation order (deterministic)."""
    return (a[:, :, 0, None] * b[:, None, 0, :] + a[:, :, 1, None] * b[:, None, 1, :]
            + a[:, :, 2, None] * b[:, None, 2, :])


def _matvec3(a: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(k, 3) batched product a @ v with a fixed summation order."""
    return a[:, :, 0] * v[:, 0, None] + a[:, :, 1] * v[:, 1, None] + a[:, :, 2] * v[:, 2, None]


def _compose_to_barrier(anc: np.ndarray, rot: np.ndarray, shift: np.ndarray,
                        tag: np.ndarray) -> None:
    """Compose every node's transform with its ancestors' up to the nearest barrier.

    Nodes form a forest (anc: (k,) int64 parent node, -1 at a root). Node j
    holds a rigid transform (rot (k,3,3), shift (k,3)) acting on a state
    (Q, d) as (Q, d) -> (Q rot, d + Q shift). A node with tag >= 0 is a
    barrier: its transform is the state it sets, whatever came before. On
    return (arrays updated in place) each node holds the composition of the
    transforms from its nearest barrier-ancestor-or-self down to itself, and
    tag the barrier's tag (-1: composed from the root, whose state is (I, 0)).
    ``anc`` is consumed.
    """
    todo = np.flatnonzero((tag < 0) & (anc >= 0))
    while todo.size:
        a = anc[todo]
        rot_a = rot[a]
        shift[todo] = shift[a] + _matvec3(rot_a, shift[todo])
        rot[todo] = _matmul3(rot_a, rot[todo])
        tag[todo] = tag[a]
        anc[todo] = anc[a]
        todo = todo[(tag[todo] < 0) & (anc[todo] >= 0)]


def _node_parents(scopes: _Scopes, kind: np.ndarray, modules: np.ndarray,
                  queries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parents in the tree of ``modules`` (numbered 0..k-1 in string order).

    Returns (node_parent (k,), query_parent (len(queries),)): for each module
    and each query, the number of the nearest of ``modules`` before it in the
    turtle's sense, -1 if none.
    """
    mask = np.zeros(len(kind), dtype=bool)
    mask[modules] = True
    number = np.full(len(kind), -1, dtype=np.int64)
    number[modules] = np.arange(len(modules))
    found = scopes.nearest_ancestor(mask, np.concatenate([modules, queries]))
    found = np.where(found >= 0, number[np.maximum(found, 0)], -1)
    return found[:len(modules)], found[len(modules):]


def _horizontal_x(m: np.ndarray) -> np.ndarray:
    """(k, 3, 3) frames rolled about their heading so that x is horizontal (ABOP's `$`).

    x = (world z) x h / |(world z) x h|, y = h x x; frames whose heading h is
    vertical within DOLLAR_VERTICAL_TOL (|h_x, h_y| below it) are returned unchanged.
    """
    h = m[:, :, 2]
    norm = np.hypot(h[:, 0], h[:, 1])
    ok = norm >= DOLLAR_VERTICAL_TOL
    safe = np.where(ok, norm, 1.0)
    x = np.stack([-h[:, 1] / safe, h[:, 0] / safe, np.zeros(len(h))], axis=1)
    y = np.cross(h, x)
    rolled = np.stack([x, y, h], axis=2)
    return np.where(ok[:, None, None], rolled, m)


def _roll_rotations(scopes: _Scopes, kind: np.ndarray, turns) -> tuple[np.ndarray, np.ndarray]:
    """The roll of every ``$`` module, as (roll_rot (r,3,3), roll_of (n,) int64).

    A ``$``'s roll (a rotation about the heading, in the turtle's frame)
    depends on the absolute orientation M before it: the orientation after
    the nearest ``$`` above it (or I at the root) times the turns in between.
    Those products come from one pointer-jumping pass over the turn and ``$``
    modules (``$`` as barriers); the rolls are then resolved one level of the
    tree of ``$`` modules at a time.
    """
    modules = np.flatnonzero((kind == TURN) | (kind == ROLL))
    parent, _ = _node_parents(scopes, kind, modules, np.zeros(0, dtype=np.int64))
    is_roll = kind[modules] == ROLL
    rot = _local_rotations(modules, turns)                  # rolls start as I
    tag = np.where(is_roll, np.arange(len(modules)), -1)   # barrier: the roll's node
    before = parent.copy()
    _compose_to_barrier(parent, rot, np.zeros((len(modules), 3)), tag)

    rolls = np.flatnonzero(is_roll)                         # node numbers
    pre = before[rolls]                                     # node just before each roll
    has_pre = pre >= 0
    above = np.where(has_pre, tag[np.maximum(pre, 0)], -1)  # node of the roll above
    roll_row = np.full(len(modules), -1, dtype=np.int64)
    roll_row[rolls] = np.arange(len(rolls))
    above = np.where(above >= 0, roll_row[np.maximum(above, 0)], -1)
    # turns since the roll above (or since the root), absolute at level 1
    between = np.where(has_pre[:, None, None], rot[np.maximum(pre, 0)], np.eye(3))
    level = chain_depths(above)                             # 1 for a top-level roll
    by_level = np.argsort(level, kind="stable")
    bounds = np.searchsorted(level[by_level], np.arange(2, level.max(initial=0) + 2))
    post = np.empty((len(rolls), 3, 3))                     # absolute M after each roll
    roll_rot = np.empty((len(rolls), 3, 3))
    start = 0
    for stop in bounds:
        group = by_level[start:stop]
        start = stop
        m_pre = between[group]
        up = above[group]
        inner = up >= 0
        if inner.any():
            m_pre[inner] = _matmul3(post[up[inner]], m_pre[inner])
        post[group] = _horizontal_x(m_pre)
        roll_rot[group] = _matmul3(np.swapaxes(m_pre, 1, 2), post[group])
    roll_of = np.full(len(kind), -1, dtype=np.int64)
    roll_of[modules[rolls]] = np.arange(len(rolls))
    return roll_rot, roll_of


# --- the tree -------------------------------------------------------------------------

def _assemble(system, derived, codes, kind, value, has_param, scopes, turns, rolls) -> Tree:
    """Compute every branch's and leaf's record from the module transforms."""
    n = len(kind)
    branches = np.flatnonzero(kind == BRANCH)
    leaves = np.flatnonzero(kind == LEAF)
    modules = np.flatnonzero(np.isin(kind, (TURN, MOVE, ROLL, BRANCH)))
    parent, query_parent = _node_parents(scopes, kind, modules,
                                         np.concatenate([branches, leaves]))
    k = len(modules)
    rot = _local_rotations(modules, turns, rolls)
    shift = np.zeros((k, 3))
    moves = kind[modules] == MOVE
    shift[moves, 2] = np.where(has_param[modules[moves]], value[modules[moves]],
                               DEFAULT_MOVE_LENGTH)
    tag = np.where(kind[modules] == BRANCH, modules, -1)    # barrier: the branch module
    _compose_to_barrier(parent, rot, shift, tag)

    def state_before(qp):
        """(Q (q,3,3), d (q,3), current branch module (q,)) before each query."""
        if k == 0:
            return (np.broadcast_to(np.eye(3), (len(qp), 3, 3)), np.zeros((len(qp), 3)),
                    np.full(len(qp), -1, dtype=np.int64))
        ok = qp >= 0
        safe = np.maximum(qp, 0)
        q_rel = np.where(ok[:, None, None], rot[safe], np.eye(3))
        d = np.where(ok[:, None], shift[safe], 0.0)
        return q_rel, d, np.where(ok, tag[safe], -1)

    branch_number = np.full(n, -1, dtype=np.int64)
    branch_number[branches] = np.arange(len(branches))
    q_rel, offset, current = state_before(query_parent[:len(branches)])
    parent_branch = np.where(current >= 0, branch_number[np.maximum(current, 0)], -1)
    euler = np.stack(zyz_from_matrix(q_rel), axis=-1).reshape(len(branches), 3)
    unplaced = ~(np.isfinite(euler).all(axis=1) & np.isfinite(offset).all(axis=1))
    if unplaced.any():
        address = derived.address_strings([branches[int(np.flatnonzero(unplaced)[0])]])[0]
        raise InputError(f"the branch at address {address} has a position or orientation that "
                         "is not a finite number (moves or lengths too large); expected "
                         "smaller f(l) and lengths", system.source)

    leaf_rel, _, leaf_current = state_before(query_parent[len(branches):])
    kept = leaf_current >= 0
    if not kept.all():
        _warn_dropped(derived, leaves[~kept])
    leaves = leaves[kept]
    leaf_normal = leaf_rel[kept][:, :, 0]
    leaf_branch = branch_number[leaf_current[kept]]

    values = _branch_values(system, derived.alphabet, codes[branches],
                            value[branches], has_param[branches])
    radius_from = scopes.nearest_ancestor(kind == RADIUS, branches)
    values["radius"] = np.where(radius_from >= 0, value[np.maximum(radius_from, 0)],
                                values["radius"])
    leaf_area = _leaf_areas(system, derived.alphabet, codes[leaves], value[leaves],
                            has_param[leaves])
    for key in GAIN_KEYS + (SWING_ROLL_KEY,):    # NaN: no gain matrix (swing roll) set there
        values[key] = np.full(len(branches), np.nan)
    _apply_overrides(system, derived, branches, values, leaves, leaf_area)
    values["force_gain"] = _gain_rows(values)
    values["swing_roll"] = _swing_rolls(values.pop(SWING_ROLL_KEY))

    tree = Tree(
        address=_branch_addresses(derived, branches),
        symbol=[derived.alphabet[c] for c in codes[branches].tolist()],
        parent=parent_branch.astype(np.int64),
        euler=euler + 0.0,          # + 0.0 turns -0.0 into 0.0
        offset=offset + 0.0,
        leaf_branch=leaf_branch.astype(np.int64),
        leaf_area=leaf_area,
        leaf_normal=leaf_normal + 0.0,
        leaf_address=derived.address_strings(leaves),
        leaf_force_scale=float(system.leaf_force_scale),
        source=system.source,
        **values,
    )
    tree.check()
    return tree


def _branch_values(system, alphabet, bcodes, bvalue, bhas) -> dict[str, np.ndarray]:
    """Per-branch parameters (B,) float64 from the module parameter, symbol and header."""
    header = {"force_absorbed": system.force_absorbed,
              "force_propagated": system.force_propagated,
              "drag_coefficient": system.drag_coefficient}
    table = {key: np.zeros(len(alphabet)) for key in BRANCH_KEYS}
    for sym in system.branches:
        if sym.name not in alphabet:
            continue
        code = alphabet.index(sym.name)
        for key in BRANCH_KEYS:
            v = getattr(sym, key)
            table[key][code] = header[key] if v is None else v
    values = {key: table[key][bcodes] for key in BRANCH_KEYS}
    values["length"] = np.where(bhas, bvalue, values["length"])
    return values


def _gain_rows(values: dict[str, np.ndarray]) -> np.ndarray | None:
    """Pop the six gain keys from ``values``: (B, 6) rows (model.md 5), None where no branch
    sets a gain matrix. A branch that sets one gets k_FA = 1 (G replaces it); the others
    the row IDENTITY_GAIN, which with their k_FA is the original model's update."""
    columns = np.stack([values.pop(key) for key in GAIN_KEYS], axis=1)
    has = ~np.isnan(columns[:, 0])
    if not has.any():
        return None
    rows = np.where(has[:, None], columns, np.asarray(IDENTITY_GAIN))
    values["force_absorbed"] = np.where(has, 1.0, values["force_absorbed"])
    return np.ascontiguousarray(rows)


def _swing_rolls(degrees: np.ndarray) -> np.ndarray | None:
    """(B,) swing rolls in radians from the overrides' degrees (NaN: not set, 0), None where
    no branch sets one (`Tree.swing_roll`)."""
    if np.isnan(degrees).all():
        return None
    return np.radians(np.where(np.isnan(degrees), 0.0, degrees)) + 0.0


def _leaf_areas(system, alphabet, lcodes, lvalue, lhas) -> np.ndarray:
    """(F,) float64 leaf areas: the module parameter, else the symbol's area."""
    table = np.zeros(len(alphabet))
    for sym in system.leaves:
        if sym.name in alphabet:
            table[alphabet.index(sym.name)] = sym.area
    return np.where(lhas, lvalue, table[lcodes])


def _apply_overrides(system, derived, branches, values, leaves, leaf_area) -> None:
    """Overwrite branch values and leaf areas at the addresses of system.overrides."""
    if not system.overrides:
        return
    merged: dict[tuple[int, ...], dict[str, float]] = {}
    for ov in system.overrides:
        merged.setdefault(tuple(ov.address), {}).update(dict(ov.values))
    width = derived.steps() + 1
    keys = [a for a in merged if len(a) == width]
    matched = np.zeros(len(keys), dtype=bool)
    if keys:
        key_rows = np.array(keys, dtype=np.int64).reshape(len(keys), width)
        kinds = []                                   # (keys matched, names that apply) per kind
        for idx, targets in ((branches, values), (leaves, {"area": leaf_area})):
            which = _match_rows(derived.address_array(idx), key_rows)
            hit = which >= 0
            matched[which[hit]] = True
            kinds.append((set(which[hit].tolist()), set(targets)))
            for name, arr in targets.items():
                col = np.array([merged[a].get(name, np.nan) for a in keys])
                take = hit & ~np.isnan(col[np.maximum(which, 0)])
                arr[take] = col[which[take]]
        _apply_leaf_ordinal_overrides(merged, keys, key_rows, derived.address_array(leaves),
                                      leaf_area)
        _warn_kind_mismatches(merged, keys, kinds)
    unmatched = [a for a in merged if len(a) != width] + [a for a, m in zip(keys, matched) if not m]
    for address in unmatched[:_WARN_LIST]:
        warnings.warn(f"override for address {_short_address(address)} matches no "
                      "branch or leaf module", stacklevel=3)
    if len(unmatched) > _WARN_LIST:
        warnings.warn(f"{len(unmatched) - _WARN_LIST:,} more overrides match no branch or leaf "
                      "module", stacklevel=3)


def _warn_kind_mismatches(merged, keys, kinds) -> None:
    """A warning for each override line whose values are set at an address that draws only the other
    kind of module: a branch's key where only leaves attach, a leaf's area where only a branch
    is drawn (it applies to nothing; such values were dropped without a word, session 36).
    kinds: ((branch keys matched, branch names), (leaf keys matched, {"area"}))."""
    (branch_hit, branch_names), (leaf_hit, leaf_names) = kinds
    said = 0
    for k, address in enumerate(keys):
        if (k in branch_hit) == (k in leaf_hit):     # both kinds there, or neither (said)
            continue
        names, other = ((leaf_names, "no leaf attaches there, only a branch") if k in branch_hit
                        else (branch_names, "no branch is drawn there, only leaves"))
        dropped = [name for name in merged[address] if name in names]
        if dropped:        # (one line per address: a gain matrix's six keys said six lines)
            if said < _WARN_LIST:
                warnings.warn(f"override {', '.join(dropped)} for address "
                              f"{_short_address(address)} applies to nothing: {other}",
                              stacklevel=4)
            said += 1
    if said > _WARN_LIST:
        warnings.warn(f"{said - _WARN_LIST:,} more override lines apply to nothing",
                      stacklevel=4)


def _short_address(address: tuple[int, ...]) -> str:
    """An address for a message: dotted, cut to its first parts when it is very long."""
    if len(address) <= _ADDRESS_PARTS_SHOWN:
        return ".".join(map(str, address))
    head = ".".join(map(str, address[:_ADDRESS_PARTS_SHOWN]))
    return f"{head}... ({len(address):,} parts)"


def _apply_leaf_ordinal_overrides(merged, keys, key_rows, leaf_rows, leaf_area) -> None:
    """``area_K`` overrides: the area of the K-th leaf attached at an address (drawing order;
    leaves dropped for want of a branch do not count).

    They are applied after ``area``, so on one line ``area`` sets every leaf
    there and ``area_K`` then sets leaf K. A K beyond the leaves drawn at the
    address gets a warning.
    """
    wanted = [(k, name, value) for k, a in enumerate(keys) for name, value in merged[a].items()
              if LEAF_ORDINAL_KEY.fullmatch(name)]
    if not wanted:
        return
    which = _match_rows(leaf_rows, key_rows)
    ordinal = occurrence_numbers(which)
    for k, name, value in wanted:
        hit = (which == k) & (ordinal == int(name[len("area_"):]))
        if not hit.any():
            warnings.warn(f"override {name} for address {_short_address(keys[k])} matches no "
                          f"leaf ({int(np.sum(which == k))} attached there)", stacklevel=4)
        leaf_area[hit] = value


def _match_rows(rows: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """(len(rows),) int64: index of the key row equal to each row, -1 if none.

    rows: (r, w) int64; keys: (k, w) int64 with distinct rows.
    """
    void = np.dtype((np.void, 8 * rows.shape[1]))
    rv = np.ascontiguousarray(rows, dtype=np.int64).view(void).ravel()
    kv = np.ascontiguousarray(keys, dtype=np.int64).view(void).ravel()
    order = np.argsort(kv)
    pos = np.minimum(np.searchsorted(kv[order], rv), len(kv) - 1)
    cand = order[pos]
    return np.where(kv[cand] == rv, cand, -1)


def _branch_addresses(derived: DerivedString, branches: np.ndarray) -> list[str]:
    """Addresses of the branch modules, ``:j`` added to the j-th repeat of one address."""
    addresses = derived.address_strings(branches)
    if derived.origin is None or len(branches) == 0:
        return addresses                      # no interpretation: all distinct
    source = np.asarray(derived.origin)[branches]   # equal source module = equal address
    order = np.argsort(source, kind="stable")
    s = source[order]
    first = np.ones(len(s), dtype=bool)
    first[1:] = s[1:] != s[:-1]
    ranks = np.arange(len(s))
    repeat = np.empty(len(s), dtype=np.int64)
    repeat[order] = ranks - np.maximum.accumulate(np.where(first, ranks, 0))
    for i in np.flatnonzero(repeat).tolist():
        addresses[i] = f"{addresses[i]}:{repeat[i]}"
    return addresses


def _warn_dropped(derived: DerivedString, dropped: np.ndarray) -> None:
    """One warning for all leaves read while no branch was current."""
    shown = derived.address_strings(dropped[:_WARN_LIST])
    more = ", ..." if len(dropped) > _WARN_LIST else ""
    warnings.warn(f"{len(dropped)} leaf module(s) read while no branch was current were "
                  f"dropped (addresses {', '.join(shown)}{more})", stacklevel=3)
