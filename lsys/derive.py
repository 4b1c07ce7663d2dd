"""Derivation and interpretation of an L-system (model.md section 1).

`derive` rewrites the axiom ``steps`` times in parallel and records, per step,
where each module came from, so that every module's address ``a0.a1.….ak`` can
be recovered (`DerivedString.address_array`). `interpret` applies the
interpretation rules once; the modules they produce keep the address of the
module they replace.

Two engines do the rewriting, with identical results where both apply:
`rewrite_fast.FastRewriter` (table lookup) for OL-systems without parameters,
context, conditions or probabilities, and `rewrite_param.GeneralRewriter`
(vectorised per rule) for everything else.
"""

from __future__ import annotations

import numpy as np

from .checks import steps_past_limit
from .constants import DEFAULT_MAX_MODULES, DERIVATION_HISTORY_FACTOR
from .cut import CUT_SYMBOL, cut_keep_mask, keep_modules
from .derived import DerivedString
from .errors import InputError
from .expr import evaluate
from .rewrite_fast import FastRewriter, fast_path_applies
from .rewrite_param import GeneralRewriter, compile_rules
from .system import LSystem, Production

__all__ = ["DerivedString", "derive", "interpret", "system_alphabet"]


def system_alphabet(system: LSystem) -> list[str]:
    """Every module character of the system, in order of first appearance.

    Axiom first, then productions (predecessor, contexts, successor), then
    interpretation rules.
    """
    seen: dict[str, None] = {}
    for m in system.axiom:
        seen.setdefault(m.name)
    for prod in system.productions + system.interpretation:
        for p in (*prod.left, prod.pred, *prod.right):
            seen.setdefault(p.name)
        for m in prod.successor:
            seen.setdefault(m.name)
    return list(seen)


def _check_brackets(modules, what: str) -> None:
    """Raise `InputError` unless the brackets of ``modules`` balance."""
    depth = 0
    for m in modules:
        if m.name == "[":
            depth += 1
        elif m.name == "]":
            depth -= 1
            if depth < 0:
                raise InputError(f"']' without a matching '[' in {what}",
                                 m.pos.file, m.pos.line, m.pos.col)
    if depth > 0:
        pos = modules[0].pos
        raise InputError(f"{depth} '[' not closed by ']' in {what}", pos.file, pos.line, pos.col)


def _check_system(system: LSystem) -> None:
    _check_brackets(system.axiom, "the axiom")
    for prod in system.productions + system.interpretation:
        _check_brackets(prod.successor, "a successor")


def axiom_string(system: LSystem, alphabet: list[str]) -> DerivedString:
    """The axiom as a `DerivedString` (step 0); arguments are evaluated with the defines."""
    code_of = {ch: i for i, ch in enumerate(alphabet)}
    env = system.constants()
    codes = np.array([code_of[m.name] for m in system.axiom], dtype=np.int32)
    counts = np.array([len(m.args) for m in system.axiom], dtype=np.int64)
    starts = np.zeros(len(codes) + 1, dtype=np.int64)
    np.cumsum(counts, out=starts[1:])
    params = np.array([float(evaluate(a, env)) for m in system.axiom for a in m.args],
                      dtype=np.float64)
    keep = _cut_mask(alphabet, codes)
    if keep is not None:
        codes, starts, params = keep_modules(keep, codes, starts, params)
    return DerivedString(list(alphabet), codes, starts, params)


def _cut_mask(alphabet: list[str], codes: np.ndarray) -> np.ndarray | None:
    """The modules the cut symbol `%` keeps (lsys.cut), None if there is no `%`."""
    code_of = {ch: i for i, ch in enumerate(alphabet)}
    return cut_keep_mask(codes, code_of.get(CUT_SYMBOL), code_of.get("["), code_of.get("]"))


def _apply_cut(alphabet, codes, starts, params, parent, local):
    """One rewriting result with the cut applied (parent/local filtered alike)."""
    keep = _cut_mask(alphabet, codes)
    if keep is None:
        return codes, starts, params, parent, local
    codes, starts, params = keep_modules(keep, codes, starts, params)
    return codes, starts, params, parent[keep], local[keep]


def _unchanged(ds: DerivedString, codes, starts, params, parent) -> bool:
    """True when a step gave back the same string, each module its own only successor."""
    return (len(codes) == len(ds) and np.array_equal(parent, np.arange(len(ds)))
            and np.array_equal(codes, ds.codes) and np.array_equal(starts, ds.param_start)
            and np.array_equal(params, ds.params))


def _rewriter(system: LSystem, rules: tuple[Production, ...], alphabet: list[str],
              string_has_params: bool, fast: bool):
    if fast and fast_path_applies(rules, string_has_params):
        return FastRewriter(rules, alphabet)
    code_of = {ch: i for i, ch in enumerate(alphabet)}
    return GeneralRewriter(system, compile_rules(rules, code_of), alphabet)


def derive(system: LSystem, steps: int | None = None,
           max_modules: int = DEFAULT_MAX_MODULES, *, fast: bool = True) -> DerivedString:
    """Apply the productions ``steps`` times (default: ``system.derivation_length``).

    Raises `InputError` when a step would produce more than ``max_modules``
    modules (checked before the step's string is built). ``fast=False`` forces
    the general engine even where the table lookup applies (for tests and
    benchmarks; the result is the same).
    """
    k = system.derivation_length if steps is None else steps
    if k < 0:
        raise InputError(f"the number of derivation steps must be >= 0, got {k}")
    past = steps_past_limit(k)
    if past:
        raise InputError(past, system.source or None)
    _check_system(system)
    alphabet = system_alphabet(system)
    ds = axiom_string(system, alphabet)
    if len(ds) > max_modules:
        # (no derivation length makes an axiom shorter: it was advised; a fuzzing round)
        raise InputError(f"the axiom has {len(ds):,} modules, more than the {max_modules:,} "
                         "modules allowed; expected a shorter axiom (or derive --max-modules, "
                         "the API's max_modules)", system.source or None)
    rewriter = _rewriter(system, system.productions, alphabet, ds.params.size > 0, fast)
    # A step that gives the string back unchanged is a fixed point when no choice
    # depends on the address (no stochastic productions): every later step is the
    # same copy, so its history rows are shared instead of recomputed.
    can_settle = all(p.probability is None for p in system.productions)
    history_budget = DERIVATION_HISTORY_FACTOR * max_modules
    held = 0
    for j in range(1, k + 1):
        codes, starts, params, parent, local = _apply_cut(
            alphabet, *_located(system, rewriter.apply, ds, j, max_modules))
        settled = can_settle and _unchanged(ds, codes, starts, params, parent)
        held += len(codes) * (k - j + 1 if settled else 1)
        if held > history_budget:
            raise InputError(f"{k} steps would make the derivation history (the addresses) hold "
                             f"{held:,} module-steps or more, more than {DERIVATION_HISTORY_FACTOR} "
                             f"x --max-modules {max_modules:,}; expected fewer steps",
                             system.source or None)
        if settled:
            copy = (parent, local)
            history = ds.history + [copy] * (k - j + 1)
            return DerivedString(ds.alphabet, ds.codes, ds.param_start, ds.params, history)
        ds = DerivedString(ds.alphabet, codes, starts, params, ds.history + [(parent, local)])
    return ds


def _located(system: LSystem, apply, *args):
    """apply(*args), its InputError (the module limit, an expression's value) given the
    system's file where it names none: a scene of several trees said which limit, not which
    tree (a helper's fuzzing, session 38)."""
    try:
        return apply(*args)
    except InputError as exc:
        if exc.file is None and system.source:
            exc.file = system.source
        raise


def interpret(system: LSystem, derived: DerivedString, *, fast: bool = True,
              max_modules: int = DEFAULT_MAX_MODULES) -> DerivedString:
    """Apply the interpretation rules once (a homomorphism for the turtle).

    The modules a rule produces keep, through ``origin``, the address of the
    module they replace; rules are not applied to their own output. Without
    interpretation rules the result has the same arrays and ``origin = arange(n)``.
    Raises `InputError` when the result would exceed ``max_modules`` (checked
    before it is built).
    """
    prior = derived.origin if derived.origin is not None else np.arange(len(derived), dtype=np.int64)
    if not system.interpretation:
        return DerivedString(derived.alphabet, derived.codes, derived.param_start,
                             derived.params, derived.history, prior)
    _check_system(system)
    alphabet = list(derived.alphabet)
    for ch in system_alphabet(system):
        if derived.code_of(ch) is None:
            alphabet.append(ch)
    ds = derived if len(alphabet) == len(derived.alphabet) else DerivedString(
        alphabet, derived.codes, derived.param_start, derived.params, derived.history, derived.origin)
    rewriter = _rewriter(system, system.interpretation, alphabet, ds.params.size > 0, fast)
    codes, starts, params, parent, _local = _apply_cut(
        alphabet, *_located(system, rewriter.apply, ds, None, max_modules))
    return DerivedString(alphabet, codes, starts, params, derived.history, prior[parent])
