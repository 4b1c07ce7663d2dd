"""The branch tree: what the turtle builds and what `simulate` moves (model.md section 2).

All arrays are numpy, indexed by branch (B branches) or by leaf (F leaves).
Branches are stored parent-before-child: ``parent[i] < i`` for every branch
with a parent, so one forward pass computes positions and one backward pass
accumulates forces. Lengths are metres, angles radians, areas m^2.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import re
import unicodedata

import numpy as np

from .errors import InputError


# Addresses a0.a1...ak as derive writes them; a branch's may end in ":j" (a repeat, `Tree`).
# Numbers without leading zeros: tree files, archives and groups: sections match addresses
# as text, and "0.01" is the address "0.1" as compare reads addresses (by number).
_NUMBER = r"(?:0|[1-9][0-9]*)"
_ADDRESS = rf"{_NUMBER}(?:\.{_NUMBER})*"
BRANCH_ADDRESS = re.compile(rf"{_ADDRESS}(?::{_NUMBER})?\Z")
LEAF_ADDRESS = re.compile(rf"{_ADDRESS}\Z")
ADDRESS_FORM = "numbers without leading zeros"    # (for messages)


def is_symbol(text) -> bool:
    """Whether ``text`` can be a branch's symbol: one character, neither half of a surrogate
    pair (no file can hold it) nor a control character. Any other character an L-system's
    module may be named by is one (a soft hyphen, U+00AD, too: the writers write it)."""
    return (isinstance(text, str) and len(text) == 1
            and unicodedata.category(text) not in ("Cs", "Cc"))


BRANCH_FLOAT_FIELDS = (
    "length", "radius", "bend_strength", "rotation_strength",
    "force_absorbed", "force_propagated", "drag_coefficient",
)


def chain_depths(parent: np.ndarray) -> np.ndarray:
    """(k,) int64: the number of nodes from each node up to its root, itself included.

    parent: (k,) int64, -1 at a root (any order). Pointer jumping.
    """
    depth = np.ones(len(parent), dtype=np.int64)
    ptr = np.asarray(parent, dtype=np.int64).copy()
    todo = np.flatnonzero(ptr >= 0)
    while todo.size:
        p = ptr[todo]
        depth[todo] += depth[p]
        ptr[todo] = ptr[p]
        todo = todo[ptr[todo] >= 0]
    return depth


def occurrence_numbers(keys) -> np.ndarray:
    """(k,) int64: how many earlier entries of ``keys`` (k,) equal each one.

    ``keys``: a 1-D sequence of strings or integers (for address rows, pass one
    code per row). For the leaves' address strings in drawing order this is each
    leaf's ordinal among the leaves attached at its address (the K of an
    ``area_K`` override).
    """
    arr = np.asarray(keys)
    if arr.ndim != 1:
        raise ValueError(f"occurrence_numbers takes a 1-D sequence, got shape {arr.shape}")
    _, codes = np.unique(arr, return_inverse=True)
    codes = codes.reshape(-1)
    order = np.argsort(codes, kind="stable")
    sorted_codes = codes[order]
    start = np.r_[0, np.flatnonzero(np.diff(sorted_codes)) + 1]
    run_start = np.repeat(start, np.diff(np.r_[start, len(codes)]))
    out = np.empty(len(codes), dtype=np.int64)
    out[order] = np.arange(len(codes)) - run_start
    return out


def leaf_keys(tree: "Tree") -> list[tuple[str, int]]:
    """(address, K) of every leaf of ``tree``: K its ordinal among the leaves attached there.

    The keys of simplify's leaf areas; K is the K of an ``area_K`` override
    (docs/lsys-format.md).
    """
    return list(zip(tree.leaf_address, occurrence_numbers(tree.leaf_address).tolist()))


@dataclass
class Tree:
    """A branch tree at rest.

    Branch arrays, shape (B,) unless stated:
      address : list[str]   address "a0.a1...ak" of the module that drew it,
                            with a suffix ":j" (j >= 1) for the j-th further
                            branch drawn under the same address (interpretation)
      symbol  : list[str]   the branch symbol that drew it
      parent  : int64       index of the parent branch, -1 for a root
      length, radius                      : float64, m
      bend_strength, rotation_strength    : float64, k_bs and k_rs
      force_absorbed, force_propagated    : float64, k_FA and k_fp (resolved per branch)
      drag_coefficient                    : float64, C_d (resolved per branch)
      euler   : (B, 3) float64  rest rotation relative to the parent frame,
                                ZYZ angles (phi, alpha, psi), radians
      offset  : (B, 3) float64  translation from the parent's tip to this base,
                                in the parent's frame (from the origin for a root)
    Leaf arrays, shape (F,) unless stated:
      leaf_branch  : int64        the branch it sits on
      leaf_area    : float64      m^2
      leaf_normal  : (F, 3) float64  rest normal in its branch's frame (unit)
      leaf_address : list[str]    address of the module that made it
    Optional, levels only (model.md 5):
      force_gain   : (B, 6) float64 or None  the gain matrix G per branch, rows
                     [G_bx G_by G_bz G_rx G_ry G_rz], read with k_FA as a factor: a branch
                     that sets G has k_FA = 1, one that does not has the row
                     [1 0 0 0 1 0]; None when no branch sets one
      swing_roll   : (B,) float64 or None  the roll β of each branch's swing frame about its
                     rest axis (radians; docs/model.md, "Swing roll"): S_i = R_parent Rz(phi)
                     Ry(alpha) Rz(beta) Rot(u, theta), R_i = S_i Rz(psi - beta), so the rest
                     geometry is unchanged; None when no branch sets one (β = 0)
    Tree-level:
      leaf_force_scale : s_L
      source           : the .lsys it was derived from (for headers)
      read_from        : the tree file (.jsonl, .npz) it was read from, "" for a derived tree
      where            : the file messages about its values name: read_from, else source
      first_record_line: the line of branch 0's record in the JSON-lines tree file read
                         (0: none); `record_line` gives branch i's
    """

    address: list[str]
    symbol: list[str]
    parent: np.ndarray
    length: np.ndarray
    radius: np.ndarray
    bend_strength: np.ndarray
    rotation_strength: np.ndarray
    force_absorbed: np.ndarray
    force_propagated: np.ndarray
    drag_coefficient: np.ndarray
    euler: np.ndarray
    offset: np.ndarray
    leaf_branch: np.ndarray
    leaf_area: np.ndarray
    leaf_normal: np.ndarray
    leaf_address: list[str]
    leaf_force_scale: float = 1.0
    source: str = field(default="")
    # explicit form: per branch, the address of the original branch rooting its group
    # (the file's `groups:` section); empty for a tree whose addresses say it
    group_root: list[str] = field(default_factory=list)
    # the line of each one's groups: entry in the .lsys (0: unknown), for messages only
    group_line: list[int] = field(default_factory=list, compare=False)
    force_gain: np.ndarray | None = None
    swing_roll: np.ndarray | None = None
    read_from: str = field(default="")
    # the line of branch 0's record in the JSON-lines tree file it was read from (branch i's:
    # this + i), 0 for any other tree: for messages only
    first_record_line: int = field(default=0, compare=False)

    @property
    def where(self) -> str:
        """The file a message about this tree's values names: the tree file the user gave
        where it was read from one, else the .lsys it was derived from ("" for neither)."""
        return self.read_from or self.source

    def broken(self, exc: BaseException):
        """The InputError for a Tree whose arrays break its invariants (``exc`` says which).
        A Tree read or derived holds them, so it was changed since: the file it came from is
        named as its origin, not blamed with its place (an API fuzzing round)."""
        origin = f" (a Tree changed since it came from {self.where})" if self.where else ""
        return InputError(f"the Tree breaks its invariants: {exc}{origin}")

    def record_line(self, i: int) -> int | None:
        """The line of branch ``i``'s record in the JSON-lines tree file this tree was read
        from, for messages; None for a tree read otherwise."""
        return self.first_record_line + i if self.first_record_line else None

    @property
    def n_branches(self) -> int:
        return len(self.parent)

    @property
    def n_leaves(self) -> int:
        return len(self.leaf_branch)

    def depth(self) -> int:
        """Number of branches on the longest root-to-tip chain (0 for no branches)."""
        return int(chain_depths(self.parent).max(initial=0))

    def children(self) -> list[list[int]]:
        """Child branch indices of every branch, in index order."""
        out: list[list[int]] = [[] for _ in range(self.n_branches)]
        for i, p in enumerate(self.parent):
            if p >= 0:
                out[p].append(i)
        return out

    def named(self, name: str) -> "Tree":
        """This tree as read from the tree file ``name``: messages about its values name that
        file (`where`; they named the .lsys its header gives, which the user may not have,
        or no file), and so does its ``source`` where its header named none."""
        return replace(self, read_from=name, source=self.source or name)

    def check(self) -> None:
        """Raise ValueError when the arrays break the invariants stated above."""
        b = self.n_branches
        if not (len(self.address) == len(self.symbol) == b):
            raise ValueError("address/symbol length differs from branch count")
        for name in BRANCH_FLOAT_FIELDS:
            if getattr(self, name).shape != (b,):
                raise ValueError(f"{name} must have shape ({b},)")
        if self.euler.shape != (b, 3) or self.offset.shape != (b, 3):
            raise ValueError("euler and offset must have shape (B, 3)")
        idx = np.arange(b)
        if np.any(self.parent >= idx) or np.any(self.parent < -1):
            i = int(np.flatnonzero((self.parent >= idx) | (self.parent < -1))[0])
            raise ValueError(f"branches must be stored parent-before-child (parent[i] < i, -1 "
                             f"for a root): branch {i} has parent {int(self.parent[i])}")
        if self.force_gain is not None and np.shape(self.force_gain) != (b, 6):
            raise ValueError(f"force_gain must have shape ({b}, 6)")
        if self.swing_roll is not None and np.shape(self.swing_roll) != (b,):
            raise ValueError(f"swing_roll must have shape ({b},)")
        f = self.n_leaves
        if self.leaf_area.shape != (f,) or self.leaf_normal.shape != (f, 3) or len(self.leaf_address) != f:
            raise ValueError("leaf arrays disagree in length")
        if f and (self.leaf_branch.min() < 0 or self.leaf_branch.max() >= b):
            raise ValueError("leaf on a branch that does not exist")
