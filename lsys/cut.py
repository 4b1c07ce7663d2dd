"""The cut symbol ``%``: it removes itself and the rest of its branch from the string.

As in cpfg and L-Py (ABOP's table of turtle symbols: "%: cut off the remainder
of the branch"), a ``%`` removes every module after it up to the ``]`` that
closes the bracket it stands in (that ``]`` stays), or to the end of the string
at the top level. The cut is applied to the axiom, after every derivation step
and after interpretation, so the turtle never reads a ``%``. The modules that
remain keep their addresses (the history rows of the removed ones are dropped).

All in numpy: one cumulative sum gives every module's bracket level, one stable
sort pairs the brackets, one ``searchsorted`` finds the ``[`` enclosing each
``%``, and a difference array marks the removed runs.
"""

from __future__ import annotations

import numpy as np

CUT_SYMBOL = "%"


def cut_keep_mask(codes: np.ndarray, cut_code: int | None, open_code: int | None,
                  close_code: int | None) -> np.ndarray | None:
    """(n,) bool: the modules a cut keeps; None when the string holds no ``%``.

    codes : (n,) int module codes; the codes of ``%``, ``[`` and ``]`` (None
    when that character is not in the alphabet). Brackets are assumed balanced
    (every axiom and successor is checked when read).
    """
    if cut_code is None:
        return None
    is_cut = codes == cut_code
    if not is_cut.any():
        return None
    n = len(codes)
    is_open = (codes == open_code) if open_code is not None else np.zeros(n, dtype=bool)
    is_close = (codes == close_code) if close_code is not None else np.zeros(n, dtype=bool)
    step = is_open.astype(np.int64) - is_close
    before = np.cumsum(step) - step                    # depth before each module
    level = before - is_close                          # the level a module stands at
    cuts = np.flatnonzero(is_cut)
    cut_level = level[cuts]
    # Pair the brackets: at one level, '[' and ']' alternate in string order.
    brackets = np.flatnonzero(is_open | is_close)
    paired = brackets[np.argsort(level[brackets], kind="stable")]
    closer = np.full(n, n, dtype=np.int64)             # '[' -> its ']' (n: unmatched)
    m = len(paired) // 2 * 2
    closer[paired[0:m:2]] = paired[1:m:2]
    # The '[' enclosing each cut: the last '[' before it one level out.
    opens = np.flatnonzero(is_open)
    key = level[opens] * (n + 1) + opens               # increasing by (level, position)
    order = np.argsort(key, kind="stable")
    sorted_key, sorted_opens = key[order], opens[order]
    end = np.full(len(cuts), n, dtype=np.int64)        # top level: to the end
    if len(opens):
        probe = np.searchsorted(sorted_key, (cut_level - 1) * (n + 1) + cuts) - 1
        found = (cut_level > 0) & (probe >= 0)
        found[found] = level[sorted_opens[probe[found]]] == cut_level[found] - 1
        end[found] = closer[sorted_opens[probe[found]]]
    marks = np.zeros(n + 1, dtype=np.int64)
    np.add.at(marks, cuts, 1)
    np.add.at(marks, end, -1)
    return np.cumsum(marks[:n]) == 0


def keep_modules(keep: np.ndarray, codes: np.ndarray, param_start: np.ndarray,
                 params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The string restricted to the modules where ``keep`` holds.

    Returns (codes (n',), param_start (n'+1,), params (m',)) in the layout of
    `DerivedString`.
    """
    counts = np.diff(param_start)
    kept_counts = counts[keep]
    new_start = np.zeros(len(kept_counts) + 1, dtype=np.int64)
    np.cumsum(kept_counts, out=new_start[1:])
    param_keep = np.repeat(keep, counts)
    return codes[keep], new_start, params[param_keep]
