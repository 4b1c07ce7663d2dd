"""The in-memory form of an ``.lsys`` file: what the parser builds and the writer writes.

Two systems compare equal when they mean the same thing; source positions are
carried for error messages but never compared, so ``parse(write(parse(text)))
== parse(text)``.

Module names are single characters. Turtle symbols (``TURTLE_SYMBOLS``) have a
fixed meaning; branch and leaf symbols are declared in the file; every other
character is a plain module the turtle ignores.
"""

from __future__ import annotations

import re

from dataclasses import dataclass, field

from .constants import DEFAULT_DRAG_COEFFICIENT, DEFAULT_LEAF_FORCE_SCALE, DEFAULT_SEED
from .expr import Expr, Pos

_NOPOS = Pos()

# Turtle symbols of model.md section 2, plus three ABOP extensions:
#   !(r)  set the radius of the branches drawn after it (no parameter: no-op, warned)
#   $     roll about the heading so that the local x axis is horizontal (ABOP's $)
#   %     cut: remove the rest of the branch from the string (lsys/cut.py)
TURTLE_SYMBOLS = frozenset("f+-&^/\\|[]!$%")
# Parameter counts the turtle accepts (docs/lsys-format.md, "Symbols").
TURTLE_OPTIONAL_ARG = frozenset("+-&^/\\f!")   # 0 or 1 parameter
TURTLE_NO_ARG = frozenset("|[]$%")             # no parameter
BRACKETS = frozenset("[]")
# Symbols that cannot be a predecessor or a context pattern: they structure the string.
STRUCTURE_SYMBOLS = frozenset("[]%")
# Characters that are syntax, never module names.
RESERVED_CHARS = frozenset("(),:;#<>=\"'{}~\u2212\u2013\u2227") | frozenset(" \t\r\n")
# Symbols of ABOP (chapter 1 and 5) and L-Py that plantlod does not draw, with what to
# write instead; the parser rejects them with this advice (docs/notation.md).
UNSUPPORTED_SYMBOLS = {
    "{": "'{' (ABOP: start a polygon) is not supported; leaves are declared symbols "
         "('leaf L: area=...'), write L where the polygon stands",
    "}": "'}' (ABOP: complete a polygon) is not supported; leaves are declared symbols "
         "('leaf L: area=...'), write L where the polygon stands",
    "~": "'~' (ABOP: incorporate a predefined surface) is not supported; declare a leaf "
         "symbol ('leaf L: area=...') and write L instead",
    "'": "\"'\" (ABOP: increment the colour index) is not supported; colours do not "
         "matter to the wind model, delete it",
    '"': "'\"' (cpfg and L-Py: multiply the length) is not supported; give the length as "
         "the branch's parameter, F(l*r)",
    ";": "';' (cpfg and L-Py: increment the colour index) is not supported; colours do not "
         "matter to the wind model, delete it",
    # look-alikes that a paste from a PDF of ABOP brings in
    "\u2212": "'\u2212' (a minus sign from a PDF) is not '-'; write the ASCII '-'",
    "\u2013": "'\u2013' (a dash from a PDF) is not '-'; write the ASCII '-'",
    "\u2227": "'\u2227' is ABOP's 'pitch up'; write '^'",
}

# Keyword parameters of a branch symbol declaration and of a branch override:
# name -> (required in a declaration?)
BRANCH_KEYS = {
    "length": True,
    "radius": True,
    "bend_strength": True,
    "rotation_strength": True,
    "force_absorbed": False,
    "force_propagated": False,
    "drag_coefficient": False,
}
LEAF_KEYS = {"area": True}
# The gain matrix of a level's branch (model.md 5), rows [G_bx G_by G_bz G_rx G_ry G_rz]:
# overrides only; a line that sets one sets all six and no force_absorbed.
GAIN_KEYS = ("g_bx", "g_by", "g_bz", "g_rx", "g_ry", "g_rz")
# The roll of a level branch's swing frame about its rest axis, degrees (overrides only;
# docs/model.md, "Swing roll"): S = R_parent Rz(phi) Ry(alpha) Rz(beta) Rot(u, theta), the branch
# frame and so the rest geometry unchanged.
SWING_ROLL_KEY = "swing_roll"
# The row of a branch without a gain matrix: G = k_FA [[1, 0, 0], [0, 1, 0]].
IDENTITY_GAIN = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
# An override may also set the area of one leaf among several drawn at its address:
# area_K is the K-th (from 0, in drawing order) leaf attached there (docs/lsys-format.md).
LEAF_ORDINAL_KEY = re.compile(r"area_(0|[1-9][0-9]*)")


@dataclass(frozen=True)
class Module:
    """A module template in an axiom or successor: ``F``, ``A(l*r1,w)``."""

    name: str
    args: tuple[Expr, ...] = ()
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Pattern:
    """A module pattern in a predecessor or context: ``A(l,w)`` binds l and w."""

    name: str
    params: tuple[str, ...] = ()
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Production:
    """``left < pred > right : condition -> (probability) successor``.

    ``left`` and ``right`` are empty for a context-free production;
    ``condition`` is None for "always"; ``probability`` is None for a
    deterministic production. Productions with the same predecessor, contexts
    and condition, each with a probability, form one stochastic group whose
    probabilities sum to 1.
    """

    pred: Pattern
    successor: tuple[Module, ...]
    left: tuple[Pattern, ...] = ()
    right: tuple[Pattern, ...] = ()
    condition: Expr | None = None
    probability: Expr | None = None
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class BranchSymbol:
    """A declared branch symbol: it draws a branch with these parameters (floats)."""

    name: str
    length: float
    radius: float
    bend_strength: float
    rotation_strength: float
    force_absorbed: float | None = None      # None: the file's force_absorbed
    force_propagated: float | None = None    # None: the file's force_propagated
    drag_coefficient: float | None = None    # None: the file's drag_coefficient
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class LeafSymbol:
    """A declared leaf symbol: it attaches a leaf of this area (m^2)."""

    name: str
    area: float
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Override:
    """Per-branch parameters for the module at one address (model.md section 5).

    ``values`` maps keys of BRANCH_KEYS (for the branch drawn there), LEAF_KEYS
    (every leaf attached there) or matching LEAF_ORDINAL_KEY (``area_K``: the K-th
    leaf attached there) to floats, sorted by key.
    """

    address: tuple[int, ...]
    values: tuple[tuple[str, float], ...]
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class LSystem:
    """A whole ``.lsys`` file. Angles are in degrees, as written in the file."""

    derivation_length: int
    branching_angle: float
    rotation_angle: float
    force_absorbed: float
    force_propagated: float
    axiom: tuple[Module, ...]
    productions: tuple[Production, ...] = ()
    interpretation: tuple[Production, ...] = ()
    branches: tuple[BranchSymbol, ...] = ()
    leaves: tuple[LeafSymbol, ...] = ()
    defines: tuple[tuple[str, float], ...] = ()   # in file order, already evaluated
    ignore: tuple[str, ...] = ()                  # symbols skipped when matching context
    overrides: tuple[Override, ...] = ()
    # explicit form (model.md 5): (address of a branch here, address of the original
    # branch that roots the group it stands for), in file order
    groups: tuple[tuple[tuple[int, ...], str], ...] = ()
    # the line of each groups: entry (0: unknown), for messages; not part of what the file says
    group_lines: tuple[int, ...] = field(default=(), compare=False)
    drag_coefficient: float = DEFAULT_DRAG_COEFFICIENT
    leaf_force_scale: float = DEFAULT_LEAF_FORCE_SCALE
    seed: int = DEFAULT_SEED
    name: str = ""
    source: str = field(default="", compare=False)   # file name, for messages
    # the header comment a writer puts first (simplify records its errors there); not meaning
    comment: str = field(default="", compare=False)

    def grown_from(self, seed: int | None) -> "LSystem":
        """This system with its stochastic productions grown from ``seed`` in place of its
        own ``seed:`` (a scene tree's seed, model.md 7); None: as written."""
        from dataclasses import replace

        return self if seed is None else replace(self, seed=seed)

    @property
    def stochastic(self) -> bool:
        """Whether any production (interpretation included) has a probability: only then
        does ``seed`` change what the file grows (section 1 of docs/model.md)."""
        return any(p.probability is not None for p in self.productions + self.interpretation)

    def branch_symbol(self, name: str) -> BranchSymbol | None:
        for b in self.branches:
            if b.name == name:
                return b
        return None

    def leaf_symbol(self, name: str) -> LeafSymbol | None:
        for leaf in self.leaves:
            if leaf.name == name:
                return leaf
        return None

    def constants(self) -> dict[str, float]:
        """The defines as an environment for expression evaluation."""
        return dict(self.defines)
