"""Context neighbours in a bracketed string, computed for all modules at once.

ABOP's rules for context (docs/lsys-format.md, "Productions"): modules whose
character is in the ignore list are skipped; looking left, a ``]`` skips back
over its whole bracketed branch and a ``[`` is passed over (so the left context
of a branch's first module is the module before the branch); looking right, a
``[`` skips forward over its whole bracketed branch and a ``]`` ends the search.

`neighbours` gives, for every module, the index of its nearest left and right
context module under these rules (-1 where there is none). A context of several
modules is matched module by module by following these arrays repeatedly.

The search is a chain of jumps (``p -> p-1``, ``]`` -> before its ``[``, …)
that ends at a module which is a context candidate; it is resolved for every
start position at once by pointer doubling: O(n log n) numpy work, no Python
loop over modules.
"""

from __future__ import annotations

import numpy as np


def match_brackets(codes: np.ndarray, open_code: int | None, close_code: int | None) -> np.ndarray:
    """(n,) int64: for a bracket, the index of its partner; -1 elsewhere.

    ``codes`` is (n,) int; the brackets must balance (the axiom and every
    successor balance, so every derived string does).
    """
    n = codes.shape[0]
    partner = np.full(n, -1, dtype=np.int64)
    if open_code is None or close_code is None:
        return partner
    is_open = codes == open_code
    is_close = codes == close_code
    pos = np.nonzero(is_open | is_close)[0]
    if pos.size == 0:
        return partner
    step = np.where(is_open[pos], 1, -1)
    depth_after = np.cumsum(step)
    # An opening bracket and its partner share one level: the depth after the
    # '[' equals the depth before the ']'. Within one level, brackets alternate
    # open, close, open, close in string order, so sorting by (level, position)
    # puts every pair side by side.
    level = np.where(step > 0, depth_after, depth_after + 1)
    order = np.lexsort((pos, level))
    paired = pos[order].reshape(-1, 2)
    partner[paired[:, 0]] = paired[:, 1]
    partner[paired[:, 1]] = paired[:, 0]
    return partner


def _resolve(jump: np.ndarray) -> np.ndarray:
    """Follow ``jump`` to its fixed points: (n+1,) -> (n+1,) int64.

    ``jump[p] == p`` marks a final position; index n is the absorbing "none".
    """
    while True:
        nxt = jump[jump]
        if np.array_equal(nxt, jump):
            return jump
        jump = nxt


def neighbours(codes: np.ndarray, open_code: int | None, close_code: int | None,
               ignored: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The left and right context neighbour of every module.

    codes   : (n,) int       module codes
    ignored : (alphabet size,) bool, True for characters in the ignore list
    returns (left, right), each (n,) int64, -1 where there is no neighbour.
    """
    n = codes.shape[0]
    none = n
    idx = np.arange(n, dtype=np.int64)
    partner = match_brackets(codes, open_code, close_code)
    is_open = codes == open_code if open_code is not None else np.zeros(n, bool)
    is_close = codes == close_code if close_code is not None else np.zeros(n, bool)
    skip = ignored[codes]

    def at_or_none(p: np.ndarray) -> np.ndarray:
        return np.where((p >= 0) & (p < n), p, none)

    # Leftward search started at p (inclusive).
    left_jump = idx.copy()
    left_jump[skip | is_open] = (idx - 1)[skip | is_open]
    left_jump[is_close] = partner[is_close] - 1
    left_from = _resolve(np.append(at_or_none(left_jump), none))

    # Rightward search started at p (inclusive).
    right_jump = idx.copy()
    right_jump[skip] = (idx + 1)[skip]
    right_jump[is_open] = partner[is_open] + 1
    right_jump[is_close] = none
    right_from = _resolve(np.append(at_or_none(right_jump), none))

    left = left_from[np.maximum(idx - 1, 0)] if n else idx
    left = np.where(idx == 0, none, left)
    right = right_from[idx + 1]           # right_from[n] is "none"
    return np.where(left == none, -1, left), np.where(right == none, -1, right)
