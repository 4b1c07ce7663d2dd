"""A derived string as text in ABOP notation: ``F(1)[+(25)A(0.5,2)]F``.

Modules are written one after another with no spaces; a module's parameters
follow it in parentheses, comma-separated, each number as
`lsys.expr.format_number` writes it (the shortest text that reads back
exactly). The text ends with one newline.

Millions of modules are written without a Python loop over modules: every
distinct parameter value is formatted once, each module becomes a run of
tokens (character, ``(``, number, ``,``, number, ``)``) in one index array, and
a chunk of tokens is joined by one ``str.join`` over a table lookup.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from .constants import DERIVED_TEXT_CHUNK_MODULES
from plantlod.lsys.derived import DerivedString, ragged_arange
from plantlod.lsys.expr import format_number


def _plain_text(codepoints: np.ndarray) -> str:
    """Text of modules without parameters: (n,) uint32 code points -> str."""
    return codepoints.astype("<u4").tobytes().decode("utf-32-le")


def _tokens(codes: np.ndarray, counts: np.ndarray, value_ids: np.ndarray,
            n_chars: int) -> np.ndarray:
    """The token indices of a run of modules.

    codes     : (n,) module codes (tokens 0..n_chars-1 are the characters)
    counts    : (n,) int64 parameters per module
    value_ids : (m,) int64 index of each parameter among the distinct values
    Token n_chars is "(", n_chars+1 is ",", n_chars+2 is ")", and n_chars+3+v
    is distinct value v. Returns (T,) int64.
    """
    lparen, comma, rparen, first_value = n_chars, n_chars + 1, n_chars + 2, n_chars + 3
    per_module = np.where(counts > 0, 2 * counts + 2, 1)     # c ( p , p ... )
    start = np.cumsum(per_module) - per_module
    tokens = np.full(int(per_module.sum()), comma, dtype=np.int64)   # gaps are commas
    tokens[start] = codes
    has = counts > 0
    tokens[start[has] + 1] = lparen
    tokens[start[has] + 2 * counts[has] + 1] = rparen
    owner_start = np.repeat(start, counts)
    tokens[owner_start + 2 + 2 * ragged_arange(counts)] = first_value + value_ids
    return tokens


def format_derived(d: DerivedString) -> Iterator[str]:
    """Yield the text of ``d`` in chunks; the concatenation ends with a newline."""
    n = len(d)
    codepoints = np.array([ord(ch) for ch in d.alphabet] or [0], dtype=np.uint32)
    counts_all = np.diff(d.param_start)
    if d.params.size:
        values, value_ids_all = np.unique(d.params, return_inverse=True)
        table = np.array(list(d.alphabet) + ["(", ",", ")"]
                         + [format_number(v) for v in values.tolist()], dtype=object)
    for lo in range(0, n, DERIVED_TEXT_CHUNK_MODULES):
        hi = min(n, lo + DERIVED_TEXT_CHUNK_MODULES)
        codes = d.codes[lo:hi]
        p_lo, p_hi = int(d.param_start[lo]), int(d.param_start[hi])
        if p_lo == p_hi:
            yield _plain_text(codepoints[codes])
            continue
        tokens = _tokens(codes, counts_all[lo:hi], value_ids_all[p_lo:p_hi], len(d.alphabet))
        yield "".join(table[tokens].tolist())
    yield "\n"
