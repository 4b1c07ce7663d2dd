"""The general rewriting step: parameters, conditions, context and stochastic choice.

Productions are compiled once into `RuleGroup` objects. One step then works on
whole groups of modules, never one module at a time:

1. for each rule group in file order, the modules of its predecessor character
   and parameter count that no earlier group took are the candidates;
2. context patterns are checked through the neighbour arrays of `lsys.context`;
3. the pattern parameters are bound as arrays and the condition is evaluated
   for all candidates at once (`lsys.expr.compile_expr` accepts arrays);
4. a stochastic group hashes the addresses of the modules it matched
   (`lsys.stochastic`), and only of those;
5. the output string is assembled with repeat/cumsum/fancy indexing, and every
   successor argument is evaluated once per successor module, as an array over
   all the modules that chose that successor.

The same step applies interpretation rules (`lsys.derive.interpret`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constants import MODULE_LIMIT_SAID
from .context import neighbours
from .errors import InputError
from .derived import DerivedString, ragged_arange
from .expr import Compiled, compile_expr
from .stochastic import address_fractions, choose
from .system import LSystem, Pattern, Production


@dataclass(frozen=True)
class Successor:
    """One successor, compiled.

    codes    : (s,) int32   module codes
    nargs    : (s,) int64   number of arguments of each module
    arg_fns  : (position in the successor, argument index, compiled expression)
    """

    codes: np.ndarray
    nargs: np.ndarray
    arg_fns: tuple[tuple[int, int, Compiled], ...]


@dataclass(frozen=True)
class RuleGroup:
    """A deterministic production, or a stochastic group of alternatives.

    pred_code / pred_params : the predecessor character's code and parameter names
    left / right            : context patterns as (code, parameter names), in text order
    condition               : compiled condition, None for "always"
    probabilities           : compiled probability per alternative, None if deterministic
    successors              : one `Successor` per alternative (one if deterministic)
    """

    pred_code: int
    pred_params: tuple[str, ...]
    left: tuple[tuple[int, tuple[str, ...]], ...]
    right: tuple[tuple[int, tuple[str, ...]], ...]
    condition: Compiled | None
    probabilities: tuple[Compiled, ...] | None
    successors: tuple[Successor, ...]


def compile_successor(modules, code_of: dict[str, int]) -> Successor:
    """Compile a successor (a tuple of `system.Module`) against an alphabet."""
    codes = np.array([code_of[m.name] for m in modules], dtype=np.int32)
    nargs = np.array([len(m.args) for m in modules], dtype=np.int64)
    arg_fns = tuple((pos, a, compile_expr(expr))
                    for pos, m in enumerate(modules) for a, expr in enumerate(m.args))
    return Successor(codes, nargs, arg_fns)


def compile_rules(productions: tuple[Production, ...], code_of: dict[str, int]) -> list[RuleGroup]:
    """Compile productions into rule groups in file order.

    Productions with a probability and the same predecessor, contexts and
    condition form one stochastic group, placed where its first member stands.
    """
    groups: list[list[Production]] = []
    stochastic_index: dict[tuple, int] = {}
    for prod in productions:
        if prod.probability is None:
            groups.append([prod])
            continue
        key = (prod.pred, prod.left, prod.right, prod.condition)
        if key in stochastic_index:
            groups[stochastic_index[key]].append(prod)
        else:
            stochastic_index[key] = len(groups)
            groups.append([prod])

    def pattern(p: Pattern) -> tuple[int, tuple[str, ...]]:
        if p.name in "[]":
            raise InputError(f"a context pattern must be a module, not '{p.name}'",
                             p.pos.file, p.pos.line, p.pos.col)
        return code_of[p.name], p.params

    rules = []
    for members in groups:
        first = members[0]
        stochastic = first.probability is not None
        rules.append(RuleGroup(
            pred_code=code_of[first.pred.name],
            pred_params=first.pred.params,
            left=tuple(pattern(p) for p in first.left),
            right=tuple(pattern(p) for p in first.right),
            condition=None if first.condition is None else compile_expr(first.condition),
            probabilities=tuple(compile_expr(p.probability) for p in members) if stochastic else None,
            successors=tuple(compile_successor(p.successor, code_of) for p in members),
        ))
    return rules


def _as_column(value, m: int) -> np.ndarray:
    """An expression result (float or array) as an (m,) float64 array."""
    return np.broadcast_to(np.asarray(value, dtype=np.float64), (m,))


def _select(env: dict, mask: np.ndarray) -> dict:
    """The environment restricted to the modules where ``mask`` holds (arrays only)."""
    return {k: (v[mask] if isinstance(v, np.ndarray) else v) for k, v in env.items()}


class GeneralRewriter:
    """Applies compiled rule groups to a `DerivedString` (see the module docstring)."""

    def __init__(self, system: LSystem, rules: list[RuleGroup], alphabet: list[str]):
        self.rules = rules
        self.seed = system.seed
        self.constants = system.constants()
        self.ignored = np.array([ch in system.ignore for ch in alphabet], dtype=bool)
        code_of = {ch: i for i, ch in enumerate(alphabet)}
        self.open_code, self.close_code = code_of.get("["), code_of.get("]")
        self.needs_context = any(r.left or r.right for r in rules)
        flat = [s for r in rules for s in r.successors]
        self.succ_len = np.array([len(s.codes) for s in flat] + [1], dtype=np.int64)
        self.succ_offset = np.concatenate([[0], np.cumsum(self.succ_len[:-1])]).astype(np.int64)
        # One trailing entry stands for "copy": the copy pseudo-successor (id len(flat)).
        self.flat_codes = np.concatenate([s.codes for s in flat] + [np.zeros(1, np.int32)])
        self.flat_nargs = np.concatenate([s.nargs for s in flat] + [np.zeros(1, np.int64)])
        self.first_id = np.cumsum([0] + [len(r.successors) for r in rules])[:-1]
        self.copy_id = len(flat)
        self.flat = flat
        # The addresses of the modules the last step chose among (`_addresses`): (steps
        # behind that string, {module index: address}). A rewriter serves one derivation.
        self._chosen: tuple[int, dict[int, str]] | None = None

    # --- matching ---------------------------------------------------------------------
    def _match(self, ds: DerivedString):
        """Choose a successor for every module.

        Returns (choice, pending): choice is (n,) int64 successor id (``copy_id``
        for a copied module); pending lists (successor id, module indices, env)
        for the argument evaluation.
        """
        n = len(ds)
        codes, starts, params = ds.codes, ds.param_start, ds.params
        nparams = np.diff(starts)
        choice = np.full(n, self.copy_id, dtype=np.int64)
        chosen: dict[int, str] = {}              # this step's `_addresses`
        unmatched = np.ones(n, dtype=bool)
        by_key: dict[tuple[int, int], np.ndarray] = {}
        left_nb = right_nb = None
        if self.needs_context:
            left_nb, right_nb = neighbours(codes, self.open_code, self.close_code, self.ignored)
        pending = []
        for rule_no, rule in enumerate(self.rules):
            key = (rule.pred_code, len(rule.pred_params))
            if key not in by_key:
                by_key[key] = np.nonzero((codes == key[0]) & (nparams == key[1]))[0]
            cand = by_key[key]
            cand = cand[unmatched[cand]]
            bound = [(rule.pred_params, cand)]     # (names, module indices aligned with cand)
            for patterns, nb in ((rule.left[::-1], left_nb), (rule.right, right_nb)):
                cur = cand
                for code, names in patterns:
                    nxt = nb[cur]
                    ok = nxt >= 0
                    ok[ok] = (codes[nxt[ok]] == code) & (nparams[nxt[ok]] == len(names))
                    cand, cur = cand[ok], nxt[ok]
                    bound = [(nm, idx[ok]) for nm, idx in bound] + [(names, cur)]
            if cand.size == 0:
                continue
            env = dict(self.constants)
            for names, idx in bound:
                for j, name in enumerate(names):
                    env[name] = params[starts[idx] + j]
            if rule.condition is not None:
                holds = _as_column(rule.condition(env), cand.size) != 0
                cand = cand[holds]
                env = _select(env, holds)
                if cand.size == 0:
                    continue
            unmatched[cand] = False
            first = int(self.first_id[rule_no])
            if rule.probabilities is None:
                choice[cand] = first
                pending.append((first, cand, env))
                continue
            weights = np.stack([_as_column(p(env), cand.size) for p in rule.probabilities], axis=1)
            picked = choose(weights, address_fractions(self.seed, self._addresses(ds, cand, chosen)))
            for alt in range(len(rule.successors)):
                sel = picked == alt
                if sel.any():
                    choice[cand[sel]] = first + alt
                    pending.append((first + alt, cand[sel], _select(env, sel)))
        self._chosen = (len(ds.history), chosen)
        return choice, pending

    def _addresses(self, ds: DerivedString, cand: np.ndarray, chosen: dict[int, str]) -> list[str]:
        """``ds.address_strings(cand)``, each also kept in ``chosen``. A module whose parent
        the last step chose for (a stochastic module's successors are mostly stochastic
        modules again) has its parent's address and ".j", j its place in the successor
        (`DerivedString.history`); the others are read from the history, which walks every
        step: once a step, a derivation of k steps would walk it k²/2 times."""
        known = self._chosen
        out: list[str | None] = [None] * len(cand)
        if known is not None and ds.origin is None and ds.history and known[0] == len(ds.history) - 1:
            parent, local = ds.history[-1]
            last = known[1]
            for r, (p, j) in enumerate(zip(parent[cand].tolist(), local[cand].tolist())):
                if p in last:
                    out[r] = f"{last[p]}.{j}"
        missing = [r for r, a in enumerate(out) if a is None]
        if missing:
            for r, a in zip(missing, ds.address_strings(cand[missing])):
                out[r] = a
        chosen.update(zip(cand.tolist(), out))
        return out

    # --- assembly ---------------------------------------------------------------------
    def apply(self, ds: DerivedString, step_label: int | None, max_modules: int | None):
        """Rewrite every module once.

        Returns (codes, param_start, params, parent, local) of the new string;
        ``parent``/``local`` are (n_out,) int64 as in `DerivedString.history`.
        Raises `InputError` if the result would exceed ``max_modules``.
        """
        choice, pending = self._match(ds)
        lens = self.succ_len[choice]
        total = int(lens.sum())
        if max_modules is not None and total > max_modules:
            raise too_many_modules(step_label, total, max_modules)
        n = len(ds)
        out_start = np.cumsum(lens) - lens
        parent = np.repeat(np.arange(n, dtype=np.int64), lens)
        local = ragged_arange(lens)
        src = self.succ_offset[choice][parent] + local
        is_copy = choice[parent] == self.copy_id
        out_codes = np.where(is_copy, ds.codes[parent], self.flat_codes[src]).astype(np.int32)
        nparams = np.diff(ds.param_start)
        out_np = np.where(is_copy, nparams[parent], self.flat_nargs[src])
        out_pstart = np.zeros(total + 1, dtype=np.int64)
        np.cumsum(out_np, out=out_pstart[1:])
        out_params = np.empty(int(out_pstart[-1]), dtype=np.float64)
        # copied modules keep their parameters
        q = np.nonzero(is_copy & (out_np > 0))[0]
        counts = out_np[q]
        r = ragged_arange(counts)
        out_params[np.repeat(out_pstart[q], counts) + r] = \
            ds.params[np.repeat(ds.param_start[parent[q]], counts) + r]
        # produced modules get their evaluated arguments
        for succ_id, mods, env in pending:
            base = out_start[mods]
            for pos, a, fn in self.flat[succ_id].arg_fns:
                out_params[out_pstart[base + pos] + a] = _as_column(fn(env), mods.size)
        return out_codes, out_pstart, out_params, parent, local


def too_many_modules(step_label: int | None, total: int, max_modules: int) -> InputError:
    """The `max_modules` guard's error (`derive` and `interpret` add the file)."""
    what = "interpretation" if step_label is None else f"step {step_label}"
    return InputError(f"{what} would produce {total:,} modules, {MODULE_LIMIT_SAID.format(max_modules)}")
