"""The fast rewriting step for OL-systems: no parameters, no context, no conditions, no chance.

Every character then has exactly one successor (itself, for a character no
production matches), so a step is a table lookup: with ``table_len[c]`` the
successor length of code c and ``table[table_start[c] + l]`` its l-th module,

    lens   = table_len[codes]                    (n,)
    parent = repeat(arange(n), lens)             (n',)
    local  = arange(n') - repeat(cumsum(lens) - lens, lens)
    codes' = table[table_start[codes][parent] + local]

all numpy, a handful of passes over the arrays per step.
"""

from __future__ import annotations

import numpy as np

from .derived import DerivedString, ragged_arange
from .rewrite_param import too_many_modules
from .system import Production


def fast_path_applies(productions: tuple[Production, ...], axiom_has_args: bool) -> bool:
    """True when the table lookup gives the same result as the general step."""
    if axiom_has_args:
        return False
    return all(not p.pred.params and not p.left and not p.right and p.condition is None
               and p.probability is None and all(not m.args for m in p.successor)
               for p in productions)


class FastRewriter:
    """Successor tables per code for a non-parametric, context-free, deterministic system."""

    def __init__(self, productions: tuple[Production, ...], alphabet: list[str]):
        code_of = {ch: i for i, ch in enumerate(alphabet)}
        successors: list[list[int] | None] = [None] * len(alphabet)
        for prod in productions:                       # the first production wins
            c = code_of[prod.pred.name]
            if successors[c] is None:
                successors[c] = [code_of[m.name] for m in prod.successor]
        rows = [s if s is not None else [c] for c, s in enumerate(successors)]
        self.table_len = np.array([len(r) for r in rows], dtype=np.int64)          # (A,)
        self.table_start = np.cumsum(self.table_len) - self.table_len              # (A,)
        self.table = np.array([c for r in rows for c in r] or [0], dtype=np.int32)

    def apply(self, ds: DerivedString, step_label: int | None, max_modules: int | None):
        """Rewrite every module once; same return value as `GeneralRewriter.apply`."""
        lens = self.table_len[ds.codes]
        total = int(lens.sum())
        if max_modules is not None and total > max_modules:
            raise too_many_modules(step_label, total, max_modules)
        parent = np.repeat(np.arange(len(ds), dtype=np.int64), lens)
        local = ragged_arange(lens)
        codes = self.table[self.table_start[ds.codes][parent] + local]
        return codes, np.zeros(total + 1, dtype=np.int64), np.zeros(0, dtype=np.float64), parent, local
