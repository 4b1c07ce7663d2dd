"""The derived string as flat arrays, and the addresses of its modules (model.md section 1).

A string of n modules with m parameters in all is stored as

    codes        (n,)   int32    module character, an index into ``alphabet``
    param_start  (n+1,) int64    module i's parameters are params[param_start[i]:param_start[i+1]]
    params       (m,)   float64

plus the derivation history from which every module's address is recovered:
for each step j = 1..k a pair (parent, local) of (n_j,) int64 arrays, where
``parent[i]`` is the index in step j-1's string of the module that produced
module i of step j, and ``local[i]`` is i's index inside that successor (0 for a
copied module). The address of module i is ``a0.a1.….ak`` with ``ak =
local_k[i]``, ``a(k-1) = local_(k-1)[parent_k[i]]`` and so on down to ``a0``,
the index of its ancestor in the axiom.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .constants import ADDRESS_BLOCK_NUMBERS, ADDRESS_PREFIX_EXCESS


def ragged_arange(lengths: np.ndarray) -> np.ndarray:
    """Concatenated ``arange(l)`` for every l in ``lengths``: (sum(lengths),) int64.

    ``ragged_arange([2, 0, 3]) == [0, 1, 0, 1, 2]``. Used to index runs of
    variable length (the parameters of many modules, the modules of many
    successors) without a Python loop.
    """
    lengths = np.asarray(lengths, dtype=np.int64)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    starts = np.cumsum(lengths) - lengths          # (len(lengths),) start of each run
    return np.arange(total, dtype=np.int64) - np.repeat(starts, lengths)


@dataclass(eq=False)
class DerivedString:
    """A derived string as flat arrays; n modules, m parameters in all.

    alphabet    : list[str]      code -> module character
    codes       : (n,) int32     index into ``alphabet``
    param_start : (n+1,) int64   params of module i are params[param_start[i]:param_start[i+1]]
    params      : (m,) float64
    history     : one (parent, local) pair of (n_j,) int64 arrays per derivation
                  step j = 1..k (see the module docstring); step 0 is the axiom.
    origin      : after interpretation, (n,) int64 index into the pre-interpretation
                  string whose address module i keeps; None before interpretation.
    """

    alphabet: list[str]
    codes: np.ndarray
    param_start: np.ndarray
    params: np.ndarray
    history: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    origin: np.ndarray | None = None
    _code_index: dict[str, int] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._code_index = {ch: i for i, ch in enumerate(self.alphabet)}

    def __len__(self) -> int:
        return int(self.codes.shape[0])

    def steps(self) -> int:
        """Number of derivation steps k behind this string."""
        return len(self.history)

    def code_of(self, ch: str) -> int | None:
        """The code of module character ``ch``, or None if it is not in the alphabet."""
        return self._code_index.get(ch)

    def param_counts(self) -> np.ndarray:
        """(n,) int64: the number of parameters of every module."""
        return np.diff(self.param_start)

    def module_params(self, i: int) -> np.ndarray:
        """(p,) float64: the parameters of module i (a view)."""
        return self.params[self.param_start[i]:self.param_start[i + 1]]

    def address_array(self, idx) -> np.ndarray:
        """(len(idx), k+1) int64: row r is the address a0..ak of module idx[r]."""
        cur = np.asarray(idx, dtype=np.int64).reshape(-1)
        if self.origin is not None:
            cur = self.origin[cur]
        k = len(self.history)
        out = np.empty((cur.shape[0], k + 1), dtype=np.int64)
        for j in range(k, 0, -1):
            parent, local = self.history[j - 1]
            out[:, j] = local[cur]
            cur = parent[cur]
        out[:, 0] = cur
        return out

    def address_strings(self, idx) -> list[str]:
        """The addresses ``"a0.a1.….ak"`` of the modules ``idx``, in that order.

        Builds each distinct prefix once, step by step: the modules of one
        successor share their parent's text, so this costs about one string
        concatenation per module instead of a join of k+1 numbers. Where prefixes
        are hardly shared (a long chain: step t rebuilds t prefixes of t parts each,
        k³/3 characters for k² written), each address is joined from its numbers
        instead (`address_array`, a block of rows at a time).
        """
        cur = np.asarray(idx, dtype=np.int64).reshape(-1)
        if self.origin is not None:
            cur = np.asarray(self.origin)[cur]
        steps = []                             # per step, top down: (inverse, local)
        for parent, local in reversed(self.history):
            up = parent[cur]
            if np.all(up[1:] >= up[:-1]):      # string order: parents are sorted
                first = np.ones(len(up), dtype=bool)
                first[1:] = up[1:] != up[:-1]
                unique, inverse = up[first], np.cumsum(first) - 1
            else:
                unique, inverse = np.unique(up, return_inverse=True)
            steps.append((inverse, local[cur]))
            cur = unique
        k = len(steps)
        built = sum(len(inverse) * (k - t) for t, (inverse, _) in enumerate(steps))
        if built > ADDRESS_PREFIX_EXCESS * (len(idx) * (k + 1) + 1):
            return self._joined_addresses(np.asarray(idx, dtype=np.int64).reshape(-1))
        text = [str(a) for a in cur.tolist()]
        for inverse, local in reversed(steps):
            suffix = [f".{j}" for j in range(int(local.max(initial=0)) + 1)]
            text = [text[i] + suffix[j] for i, j in zip(inverse.tolist(), local.tolist())]
        return text

    def _joined_addresses(self, idx: np.ndarray) -> list[str]:
        """`address_strings` of ``idx``, each joined from its row of `address_array`; rows
        in blocks of at most ADDRESS_BLOCK_NUMBERS numbers (memory)."""
        rows = max(1, ADDRESS_BLOCK_NUMBERS // (len(self.history) + 1))
        text: list[str] = []
        for start in range(0, len(idx), rows):
            block = self.address_array(idx[start:start + rows])
            text.extend(".".join(map(str, row)) for row in block.tolist())
        return text

    def module_text(self, i: int) -> str:
        """Module i in ABOP notation, e.g. ``A(1,0.5)`` (for messages and tests)."""
        from .expr import format_number

        ch = self.alphabet[int(self.codes[i])]
        p = self.module_params(i)
        return ch if len(p) == 0 else f"{ch}({','.join(format_number(v) for v in p)})"
