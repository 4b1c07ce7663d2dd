"""The level-n L-system: same axiom and productions, N - n steps, new parameters.

`level_system` makes the skeleton (derivation length N - n, and, where the
level-n tree loses leaves, *equivalent leaves*: interpretation rules that
attach the leaves the dropped step would have attached); `write_parameters` turns per-branch and per-leaf values into symbol
declarations where one value per symbol suffices and per-address overrides
where it does not (docs/lsys-format.md, "Overrides").
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace

import numpy as np

from plantlod.compare.runs import check_extent
from plantlod.lsys.build import build
from .constants import SIMPLIFY_WRITE_DIGITS
from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import leaf_keys
from plantlod.lsys.system import (
    TURTLE_SYMBOLS, LSystem, Module, Override, Pattern, Production,
)



def round_sig(x: float, digits: int = SIMPLIFY_WRITE_DIGITS) -> float:
    """``x`` rounded to ``digits`` significant digits (0 and non-finite values unchanged)."""
    x = float(x)
    if x == 0.0 or not math.isfinite(x):
        return x
    return float(f"{x:.{digits}g}")


def check_moves(original, source: str | None, height: bool = True) -> None:
    """Raise InputError unless the original tree (a `Tree`) can move and be measured: it has
    branches; some branch absorbs force (k_FA > 0, or a gain matrix); the wind acts on it
    (model.md 4: some branch has drag, C_d r L > 0, or some leaf a force, s_L A > 0); and it
    rises above its base (a rest height > 0, which model.md 6's tip errors are fractions of;
    ``height=False`` leaves that to the caller: a scene runs such a tree at full detail).
    A tree that absorbs or feels no force stands still in every wind, and every fit divides
    by its zero swing (it was 'unstable in simplify's winds' or a drag coefficient of NaN);
    one lying flat or hanging below z = 0 has no height to state its tip errors in (a flat
    one gave tip errors of 1e15 % of its rounding-noise height)."""
    if original.n_branches == 0:
        raise InputError("the original tree has no branches; expected a tree to simplify", source)
    check_extent(original, source)              # (simplify measures tip positions)
    gain = original.force_gain
    absorbs = np.asarray(original.force_absorbed, dtype=np.float64)
    if gain is not None:
        absorbs = absorbs * np.abs(np.asarray(gain)).max(axis=1)
    if not np.any(absorbs != 0):
        raise InputError("the tree absorbs no force (force_absorbed is 0 for every branch): it "
                         "stands still in every wind, so there is no motion to simplify; "
                         "expected force_absorbed > 0", source)
    drag = np.asarray(original.drag_coefficient) * np.asarray(original.radius) \
        * np.asarray(original.length)
    leaf = original.leaf_force_scale * np.asarray(original.leaf_area, dtype=np.float64)
    if not (np.any(drag != 0) or np.any(leaf != 0)):
        raise InputError("the wind exerts no force on the tree (no branch has drag, C_d r L = 0, "
                         "and no leaf a force, s_L A = 0): it stands still in every wind, so "
                         "there is no motion to simplify; expected a drag_coefficient, radius or "
                         "leaf area > 0", source)
    if height and not rises(original):
        raise InputError(f"{lies_flat(original)}: tip errors are stated as fractions of the rest "
                         "height (model.md 6), so it has no levels to measure; expected a tree "
                         "that rises above z = 0", source)


def rises(original) -> bool:
    """Whether the tree's highest tip at rest is above z = 0 (`sim.kinematics.rest_height`)."""
    from plantlod.sim.kinematics import rest_height

    return rest_height(original) > 0


def lies_flat(original) -> str:
    """What a tree that does not rise (`rises`) is, for a message."""
    from plantlod.sim.kinematics import rest_height

    return (f"the tree's highest tip at rest is at z = {rest_height(original):g} m (it lies "
            "flat or hangs below z = 0; model.md 6 measures tip errors against the highest "
            "tip's z, so a tree must rise above z = 0)")


def round_sig_down(x: float, digits: int = SIMPLIFY_WRITE_DIGITS) -> float:
    """``x`` > 0 cut (toward zero) to ``digits`` significant digits: never above ``x``."""
    from decimal import ROUND_DOWN, Decimal

    d = Decimal(float(x))                        # (exact)
    return float(d.quantize(Decimal(1).scaleb(d.adjusted() - digits + 1), rounding=ROUND_DOWN))


def _rounded(key: str, x: float, strength_below: float | None) -> float:
    """A value as `write_parameters` writes it: `round_sig`, except a strength that rounding
    would carry from below ``strength_below`` to it or past (`round_sig_down` then)."""
    r = round_sig(x)
    if strength_below is not None and key in ("bend_strength", "rotation_strength") \
            and float(x) < strength_below <= r:
        return round_sig_down(x)
    return r


def check_level(system: LSystem, level: int) -> None:
    """Raise InputError unless 1 <= level < the derivation length."""
    n = system.derivation_length
    if level < 1:
        raise InputError(f"level {level}: expected a level of at least 1 (level 0 is the "
                         f"original)", system.source or None)
    if level >= n:
        raise InputError(f"level {level}: expected a level below the derivation length {n} "
                         f"(a level-n tree derives N - n >= 1 steps)", system.source or None)


def level_system(system: LSystem, level: int, equivalent_leaves: bool) -> tuple[LSystem, list[str]]:
    """The level-``level`` skeleton of ``system`` and the symbols given equivalent leaves.

    The skeleton derives N - level steps and drops the input's overrides (their
    addresses belong to step N). With ``equivalent_leaves``, every symbol X with
    one unconditional, context-free, deterministic production gets an
    interpretation rule that draws what X draws now and, in brackets, the leaves
    that X's successor would attach, with the same turns (so with the same
    rest normals), its branches and moves left out (`equivalent_leaf_rules`).
    `write_parameters` then gives each of those leaves its area (``area`` or
    ``area_K`` overrides).
    """
    check_level(system, level)
    skeleton = replace(system, derivation_length=system.derivation_length - level, overrides=())
    if not equivalent_leaves:
        return skeleton, []
    rules = equivalent_leaf_rules(system)
    if not rules:
        return skeleton, []
    replaced = {r.pred.name for r in rules}
    kept = tuple(r for r in system.interpretation if r.pred.name not in replaced)
    return replace(skeleton, interpretation=kept + tuple(rules)), sorted(replaced)


def _single_rule(rules, name: str) -> Production | None:
    """The one plain rule for ``name`` (no context, condition or probability), else None."""
    mine = [r for r in rules if r.pred.name == name]
    if len(mine) != 1:
        return None
    r = mine[0]
    if r.left or r.right or r.condition is not None or r.probability is not None:
        return None
    return r


def _substitute(expr, mapping: dict):
    """``expr`` with the names in ``mapping`` replaced by expressions."""
    from plantlod.lsys.expr import Binary, Call, Name, Unary
    if isinstance(expr, Name):
        return mapping.get(expr.name, expr)
    if isinstance(expr, Unary):
        return Unary(expr.op, _substitute(expr.operand, mapping))
    if isinstance(expr, Binary):
        return Binary(expr.op, _substitute(expr.left, mapping), _substitute(expr.right, mapping))
    if isinstance(expr, Call):
        return Call(expr.func, tuple(_substitute(a, mapping) for a in expr.args))
    return expr


def _apply_rule(rule: Production, module: Module) -> tuple[Module, ...]:
    """``rule``'s successor for ``module``, its parameters replaced by the module's arguments."""
    mapping = dict(zip(rule.pred.params, module.args))
    return tuple(Module(m.name, tuple(_substitute(a, mapping) for a in m.args))
                 for m in rule.successor)


def _leaf_part(modules, system: LSystem) -> list[Module]:
    """The turns, brackets and leaves of ``modules`` after interpretation; branches, moves dropped."""
    leaves = {leaf.name for leaf in system.leaves}
    out: list[Module] = []
    for m in modules:
        rule = _single_rule(system.interpretation, m.name)
        if rule is not None and len(rule.pred.params) == len(m.args):
            out += _leaf_part(_apply_rule(rule, m), replace(system, interpretation=()))
        elif m.name in leaves or m.name in "+-&^/\\|[]$":
            out.append(m)
    return _prune(out, leaves)


def _prune(modules: list[Module], leaves: set[str]) -> list[Module]:
    """Drop bracketed parts without a leaf and turns that no later leaf in their scope follows."""
    def parse(i):
        items = []
        while i < len(modules) and modules[i].name != "]":
            if modules[i].name == "[":
                inner, i = parse(i + 1)
                items.append(inner)
            else:
                items.append(modules[i])
            i += 1
        return items, i

    def has_leaf(items):
        return any(has_leaf(x) if isinstance(x, list) else x.name in leaves for x in items)

    def emit(items):
        out = []
        keep_until = max((k for k, x in enumerate(items)
                          if (has_leaf(x) if isinstance(x, list) else x.name in leaves)), default=-1)
        for k, x in enumerate(items[:keep_until + 1]):
            if isinstance(x, list):
                if has_leaf(x):
                    out += [Module("[")] + emit(x) + [Module("]")]
            else:
                out.append(x)
        return out

    return emit(parse(0)[0])


def equivalent_leaf_rules(system: LSystem) -> list[Production]:
    """Interpretation rules that add, at each module, the leaves its next step would attach.

    For a symbol X with exactly one plain production ``X(p) -> S``: the rule is
    ``X(p) -> X(p)[L]`` for a branch symbol (it still draws its branch) and
    ``X(p) -> [L]`` for any other symbol (in the original it has been replaced
    by S, so what it shows now, e.g. an apex leaf, goes), L being the leaf part
    of S (`_leaf_part`); for a leaf (``L ->`` erasing old leaves) or a module
    shown through interpretation whose successor attaches no leaf, the rule is
    empty, since in the original it is gone. A module whose interpretation draws
    branches keeps them (they are the level's branches, each standing for its group):
    its rule draws its interpretation with the leaves left out, then, in brackets, the
    turns of that interpretation undone and the leaf part of S (whose turns start from
    X's own frame): ``X -> P X`` shown as ``X -> /(30) P L`` gives
    ``X -> /(30)P[\\(30)/(30)L]``, the leaf at the tip of the level's P, turned as the
    original's (a module whose interpretation rolls with ``$``, which no turn undoes,
    gets no rule). Branch symbols whose
    successor attaches no leaf, plain modules that show nothing, branch symbols with
    interpretation rules of their own, and modules shown through several or
    conditional interpretation rules get no rule.
    """
    branches = {b.name for b in system.branches}
    leaf_names = {leaf.name for leaf in system.leaves}
    interpreted = {r.pred.name for r in system.interpretation}
    rules = []
    for name in sorted({r.pred.name for r in system.productions}):
        if name in TURTLE_SYMBOLS or (name in branches and name in interpreted):
            continue
        prod = _single_rule(system.productions, name)
        if prod is None:
            continue
        params = tuple(_name_expr(p) for p in prod.pred.params)
        if name in branches:
            head = (Module(name, params),)
        elif name in interpreted:
            head = _drawn_without_leaves(system, name, params)
            if head is None:
                continue
            if not any(m.name in branches for m in head):
                head = ()                         # (it shows leaves and turns only: they go)
        else:
            head = ()
        leaves = _leaf_part(prod.successor, system)
        shows_now = name in leaf_names or name in interpreted
        if not leaves and (name in branches or not shows_now):
            continue
        if leaves and name not in branches and head:
            undo = _undone_turns(head)
            if undo is None:
                continue
            leaves = list(undo) + list(leaves)
        tail = (Module("["),) + tuple(leaves) + (Module("]"),) if leaves else ()
        rules.append(Production(Pattern(name, prod.pred.params), tuple(head) + tail))
    return rules


def _drawn_without_leaves(system: LSystem, name: str, params: tuple) -> tuple[Module, ...] | None:
    """What module ``name`` draws through its one plain interpretation rule, leaves left out
    (its branches, moves and turns, so every branch keeps its place), with the rule's
    parameters renamed to ``params`` (the production's); None where the module is shown
    through several or conditional rules, or one of another parameter count."""
    rule = _single_rule(system.interpretation, name)
    if rule is None or len(rule.pred.params) != len(params):
        return None
    leaf_names = {leaf.name for leaf in system.leaves}
    shown = _apply_rule(rule, Module(name, params))
    return tuple(m for m in shown if m.name not in leaf_names)


_INVERSE_TURN = {"+": "-", "-": "+", "&": "^", "^": "&", "/": "\\", "\\": "/", "|": "|"}


def _undone_turns(modules: tuple[Module, ...]) -> tuple[Module, ...] | None:
    """The turns that bring the turtle back to the frame it had before ``modules`` (their
    turns outside brackets, inverted, last first; branches and moves do not turn it); None
    where one of them cannot be undone (``$``, a roll to the horizontal)."""
    out: list[Module] = []
    depth = 0
    for m in reversed(modules):
        if m.name == "]":
            depth += 1
        elif m.name == "[":
            depth -= 1
        elif depth == 0 and m.name == "$":
            return None
        elif depth == 0 and m.name in _INVERSE_TURN:
            out.append(Module(_INVERSE_TURN[m.name], m.args))
    return tuple(out)


def _mode(values: list[float]) -> float:
    """The most common value; ties: the smallest."""
    counts = Counter(values)
    best = max(counts.values())
    return min(v for v, c in counts.items() if c == best)


def _base_address(address: str) -> tuple[int, ...]:
    return tuple(int(p) for p in address.partition(":")[0].split("."))


def write_parameters(skeleton: LSystem, branch_values: dict[str, np.ndarray],
                     leaf_areas: dict[tuple[str, int], float],
                     strength_below: float | None = None) -> LSystem:
    """``skeleton`` with the given parameters, per symbol where possible, else per address.

    branch_values : key of BRANCH_KEYS -> (B,) values for the skeleton tree's
                    branches (in its branch order); keys not given keep the
                    skeleton's values
    leaf_areas    : (leaf address, K) -> area (m^2) of the K-th leaf at that
                    address (`plantlod.lsys.tree.leaf_keys`)

    strength_below: the strength that the level's time step reaches the stability limit at
                    (`sim.stability`); a strength below it that rounding would carry to it
                    or past is rounded down instead (399999.9999999 at dt 0.01 was written
                    400000, and the level refused as unstable).

    Every value is rounded to SIMPLIFY_WRITE_DIGITS significant digits. A symbol gets the
    most common value of its branches; a branch whose resolved value (module
    parameter or symbol) then differs gets an override. Raises InputError when
    a value is not finite or not positive where the model needs it.
    """
    built = build(skeleton)
    tree = built.tree
    values = {k: np.array([_rounded(k, x, strength_below) for x in v])
              for k, v in branch_values.items()}
    for key, v in values.items():
        if v.shape != (tree.n_branches,):
            raise ValueError(f"{key}: expected {tree.n_branches} values, got {v.shape}")
        bad = ~np.isfinite(v) | (v < 0) | ((v == 0) & (key in ("length", "bend_strength",
                                                                "rotation_strength")))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputError(f"simplify computed {key} = {v[i]:g} for the branch at "
                             f"{tree.address[i]}; expected a finite positive value "
                             f"(this tree cannot be simplified to this level)",
                             skeleton.source or None)
    symbols = []
    for sym in skeleton.branches:
        mine = [i for i, s in enumerate(tree.symbol) if s == sym.name]
        changes = {key: _mode(values[key][mine].tolist()) for key in values if mine}
        symbols.append(replace(sym, **changes))
    keys = leaf_keys(tree)
    missing = sorted(set(leaf_areas) - set(keys))
    if missing:
        raise ValueError(f"no leaf {missing[:3]} (address, K) in the level-n tree")
    wanted = {}
    for key, area in leaf_areas.items():
        a = round_sig(area)
        if not (math.isfinite(a) and a >= 0):
            raise InputError(f"simplify computed a leaf area {a:g} at {key[0]} (leaf {key[1]}); "
                             "expected >= 0", skeleton.source or None)
        wanted[key] = a
    symbol_of = _leaf_symbols(skeleton, built, tree)
    by_symbol: dict[str, list[float]] = {}
    for key, name in zip(keys, symbol_of or ()):
        if key in wanted:
            by_symbol.setdefault(name, []).append(wanted[key])
    leaves = [replace(sym, area=_mode(by_symbol[sym.name])) if sym.name in by_symbol else sym
              for sym in skeleton.leaves]
    declared = replace(skeleton, branches=tuple(symbols), leaves=tuple(leaves))

    resolved = build(declared).tree
    overrides: dict[tuple[int, ...], dict[str, float]] = {}
    for key, v in values.items():
        have = getattr(resolved, key)
        for i in np.flatnonzero(have != v).tolist():
            overrides.setdefault(_base_address(resolved.address[i]), {}).setdefault(key, float(v[i]))
    _leaf_overrides(keys, resolved.leaf_area.tolist(), wanted, overrides)
    lines = tuple(Override(addr, tuple(sorted(kv.items())))
                  for addr, kv in sorted(overrides.items()))
    return replace(declared, overrides=lines)


def _leaf_overrides(keys: list[tuple[str, int]], have: list[float],
                    wanted: dict[tuple[str, int], float],
                    overrides: dict[tuple[int, ...], dict[str, float]]) -> None:
    """Add ``area`` (every leaf at an address) or ``area_K`` (leaf K) overrides where needed.

    keys, have: every leaf's (address, K) and its area as the file now gives it.
    """
    at: dict[str, list[int]] = {}
    for i, (addr, _) in enumerate(keys):
        at.setdefault(addr, []).append(i)
    for addr in sorted(at):
        idx = at[addr]
        want = [wanted.get(keys[i], have[i]) for i in idx]
        if all(w == h for w, h in zip(want, (have[i] for i in idx))):
            continue
        line = overrides.setdefault(_base_address(addr), {})
        if len(set(want)) == 1:
            line["area"] = want[0]
            continue
        for i, w in zip(idx, want):
            if w != have[i]:
                line[f"area_{keys[i][1]}"] = w


def _leaf_symbols(skeleton: LSystem, built, tree) -> list[str] | None:
    """The leaf symbol of every leaf of ``tree`` (the built skeleton's), in its order.

    Read from the interpreted string. None where the turtle dropped leaves (read
    while no branch was current): which ones is not known here, so the caller
    leaves the symbols' areas alone and gives every leaf its area by override.
    """
    interpreted = built.interpreted
    names = {leaf.name for leaf in skeleton.leaves}
    alphabet = interpreted.alphabet
    codes = np.asarray(interpreted.codes)
    is_leaf = np.isin(codes, [alphabet.index(n) for n in names if n in alphabet])
    symbols = [alphabet[c] for c in codes[np.flatnonzero(is_leaf)].tolist()]
    return symbols if len(symbols) == tree.n_leaves else None


def _name_expr(name: str):
    from plantlod.lsys.expr import Name
    return Name(name)
