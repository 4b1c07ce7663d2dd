"""A seeded family of generated trees: .lsys files across kinds, for `make lod-family`.

Each tree is a pure function of (kind, seed): its random draws come from
numpy's `default_rng` seeded with the seed and a CRC of the kind's name, never
from an unseeded stream. The kinds (what issue 21 asks levels of detail to hold
on) are

    stalk       straight stalks, 2-4 branch symbols with their own lengths and
                strengths (doubling, grown from an apex, or written out with
                per-branch strength overrides)
    monopodial  a trunk with whorls of laterals
    sympodial   every apex stops and 2-3 laterals take over (no straight continuation)
    bush        planar bushes (ABOP 1.24 style: turns only about one axis)
    bush3d      3D bushes (phyllotactic rolls, pitches in every direction)
    stochastic  stochastic productions, the file's own seed
    bent_leafy  chains that turn a little at every segment, many leaves
    weeping     laterals that bend further down at every segment
    mixed       several branch symbols with their own k_FA, k_fp and C_d, and
                per-branch overrides of k_FA and k_fp on the trunk's base

Every tree has MIN_BRANCHES to MAX_BRANCHES branches (most under TYPICAL_MAX):
the derivation length is chosen by deriving (plantlod's own derivation, so the
count is exact). Strengths keep the periods at 2-6 s (four or more periods in a
20 s run) and k_FA keeps the largest combined angles mostly under 0.1 rad up to
10 m/s, the regime model.md's targets apply in.

    .venv/bin/python bench/tree_family.py --seeds 0-199 --out DIR [--kinds stalk,bush]

writes DIR/<kind>-<seed>.lsys; seed s is of kind kinds[s % len(kinds)].
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import zlib
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

KINDS = ("stalk", "monopodial", "sympodial", "bush", "bush3d", "stochastic", "bent_leafy",
         "weeping", "mixed")
MIN_BRANCHES, MAX_BRANCHES = 30, 600
TYPICAL_MAX = 300              # most trees draw at most this many branches
LARGE_FRACTION = 0.1           # ... and this fraction aims at TYPICAL_MAX to MAX_BRANCHES
TARGET_LOW = 40                # the smallest branch count a tree aims at
MAX_DEPTH = 80                 # derivation lengths tried (apex-grown stalks are the longest)
# Physical ranges, drawn per tree or per symbol (magnitudes of examples/eval/*.lsys):
BEND_STRENGTH = (15.0, 60.0)   # k_bs (log-uniform): periods 5.1 to 2.6 s at dt 0.01
ROTATION_RATIO = (0.75, 1.33)  # k_rs / k_bs (log-uniform)
MID_STRENGTH = math.sqrt(BEND_STRENGTH[0] * BEND_STRENGTH[1])
FORCE_PROPAGATED = (0.6, 0.8)  # k_fp
LEAF_AREA = (0.001, 0.005)     # m^2 (log-uniform)
DRAG = 0.0015                  # C_d, the thesis' value (mixed trees draw their own per symbol)
DRAG_RANGE = (0.001, 0.003)    # C_d of a mixed tree's symbols
# k_FA (log-uniform) per kind: sized so that the largest combined angle at 10 m/s is
# mostly 0.005-0.08 rad at level 1 (probed on tuning seeds 0-71, never on held-out ones).
FORCE_ABSORBED = {
    "stalk": (0.003, 0.012),
    "monopodial": (0.001, 0.004),
    "sympodial": (0.0005, 0.0015),
    "bush": (0.0005, 0.002),
    "bush3d": (0.001, 0.003),
    "stochastic": (0.001, 0.003),
    "bent_leafy": (0.001, 0.003),
    "weeping": (0.001, 0.003),
    "mixed": (0.0005, 0.002),
}
DIGITS = 3                     # significant digits of every drawn number written
# Planar bush templates (ABOP figure 1.24): productions, axiom, leaf interpretation.
BUSH_TEMPLATES = {
    "1.24a": ("F", ["F -> F [+F] F [-F] F"], ["F -> F [/(90) L]"]),
    "1.24b": ("F", ["F -> F [+F] F [-F] [F]"], ["F -> F [/(90) L]"]),
    "1.24c": ("F", ["F -> F F - [- F + F + F] + [+ F - F - F]"], ["F -> F [/(90) L]"]),
    "1.24d": ("X", ["X -> F [+X] F [-X] + X", "F -> F F"], ["X -> /(90) L"]),
    "1.24e": ("X", ["X -> F [+X] [-X] F X", "F -> F F"], ["X -> /(90) L"]),
    "1.24f": ("X", ["X -> F - [[X] + X] + F [+ F X] - X", "F -> F F"], ["X -> /(90) L"]),
}
# Successors of the stochastic kind's shoot X (each draws F and grows on).
STOCHASTIC_SUCCESSORS = (
    "F [+X L] F X", "F [-X L] / F X", "F [&X] [^X L] F X", "F / [+X] [-X L] X",
    "F [\\X L] F", "F F X", "F [^X] &(10) F X L",
)


def _num(x: float) -> str:
    """``x`` with DIGITS significant digits, as the .lsys reader reads it back."""
    return f"{float(x):.{DIGITS}g}"


class Draw:
    """The random draws of one tree: numpy's default_rng seeded with (seed, crc32(kind))."""

    def __init__(self, kind: str, seed: int):
        self.rng = np.random.default_rng([int(seed), zlib.crc32(kind.encode("utf-8"))])

    def uniform(self, lo: float, hi: float) -> float:
        """A float uniform in [lo, hi)."""
        return float(self.rng.uniform(lo, hi))

    def log_uniform(self, lo: float, hi: float) -> float:
        """A float whose log is uniform in [log lo, log hi)."""
        return float(math.exp(self.rng.uniform(math.log(lo), math.log(hi))))

    def integer(self, lo: int, hi: int) -> int:
        """An int in [lo, hi] (both included)."""
        return int(self.rng.integers(lo, hi + 1))

    def choice(self, items):
        """One of ``items``."""
        return items[int(self.rng.integers(0, len(items)))]

    def chance(self, p: float) -> bool:
        """True with probability p."""
        return bool(self.rng.uniform() < p)

    def target_branches(self) -> int:
        """The branch count a tree aims at: log-uniform in [TARGET_LOW, TYPICAL_MAX], or with
        probability LARGE_FRACTION in [TYPICAL_MAX, MAX_BRANCHES]."""
        lo, hi = (TYPICAL_MAX, MAX_BRANCHES) if self.chance(LARGE_FRACTION) else (TARGET_LOW, TYPICAL_MAX)
        return int(round(self.log_uniform(lo, hi)))


@dataclass
class Spec:
    """One tree before its derivation length is chosen: the text of an .lsys file but for
    `derivation_length`, which `render` fills in."""

    kind: str
    seed: int
    summary: str                                   # one line for the header comment
    header: dict[str, str]                         # header keys after derivation_length
    branches: list[str]                            # 'branch F: ...' lines
    leaves: list[str]                              # 'leaf L: ...' lines
    axiom: str
    productions: list[str] = field(default_factory=list)
    interpretation: list[str] = field(default_factory=list)
    overrides: Callable[[int], list[str]] | None = None   # derivation length -> override lines
    depths: tuple[int, int] = (0, 0)               # derivation lengths to try (both included)

    def render(self, depth: int) -> str:
        """The .lsys text at derivation length ``depth``."""
        lines = [f"# tree_family: kind {self.kind}, seed {self.seed} (bench/tree_family.py)",
                 f"# {self.summary}",
                 f"name: {self.kind}-{self.seed}",
                 f"derivation_length: {depth}"]
        lines += [f"{k}: {v}" for k, v in self.header.items()]
        lines += self.branches + self.leaves + [f"axiom: {self.axiom}"]
        for title, body in (("productions", self.productions), ("interpretation", self.interpretation),
                            ("overrides", self.overrides(depth) if self.overrides else [])):
            if body:
                lines.append(f"{title}:")
                lines += ["  " + line for line in body]
        return "\n".join(lines) + "\n"


def branch_count(text: str) -> int:
    """The number of branches the .lsys ``text`` draws (plantlod's derivation and turtle)."""
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys

    return build(parse_lsys(text), max_modules=200_000).tree.n_branches


def _choose_depth(spec: Spec, target: int) -> str:
    """The text at the derivation length whose branch count lies in [MIN_BRANCHES,
    MAX_BRANCHES] and nearest ``target`` (in ratio), at most TYPICAL_MAX if ``target`` is and
    such a length exists. Raises ValueError if none lies in the range."""
    from plantlod.lsys.errors import InputError

    best = None
    lo, hi = spec.depths
    for depth in range(lo, hi + 1):
        text = spec.render(depth)
        try:
            count = branch_count(text)
        except InputError:                         # too many modules: deeper is larger still
            break
        if MIN_BRANCHES <= count <= MAX_BRANCHES:
            # a typical target never takes a large count while a typical one is possible
            large = count > TYPICAL_MAX >= target
            score = (large, abs(math.log(count / target)))
            if best is None or score < best[0]:
                best = (score, text)
        if count > MAX_BRANCHES:
            break
    if best is None:
        raise ValueError(f"{spec.kind}-{spec.seed}: no derivation length in {lo}-{hi} gives "
                         f"{MIN_BRANCHES}-{MAX_BRANCHES} branches")
    return best[1]


def _strengths(d: Draw, bend: float | None = None) -> str:
    """'bend_strength=… rotation_strength=…': k_bs = ``bend`` (default: drawn from
    BEND_STRENGTH), k_rs = k_bs times a ROTATION_RATIO draw, both clipped to BEND_STRENGTH."""
    lo, hi = BEND_STRENGTH
    bend = min(max(d.log_uniform(lo, hi) if bend is None else bend, lo), hi)
    rot = min(max(bend * d.log_uniform(*ROTATION_RATIO), lo), hi)
    return f"bend_strength={_num(bend)} rotation_strength={_num(rot)}"


def _branch(symbol: str, length: float, radius: float, strengths: str, extra: str = "") -> str:
    """A 'branch S: ...' declaration."""
    return (f"branch {symbol}: length={_num(length)} radius={_num(radius)} {strengths}"
            + (f" {extra}" if extra else ""))


def _header(d: Draw, kind: str, branching: float, rotation: float, seed: int = 0) -> dict[str, str]:
    """The header keys after derivation_length: angles (deg), seed, k_FA (FORCE_ABSORBED[kind]),
    k_fp (FORCE_PROPAGATED), C_d (DRAG)."""
    return {"branching_angle": _num(branching), "rotation_angle": _num(rotation), "seed": str(seed),
            "force_absorbed": _num(d.log_uniform(*FORCE_ABSORBED[kind])),
            "force_propagated": _num(d.uniform(*FORCE_PROPAGATED)),
            "drag_coefficient": _num(DRAG)}


def _leaf(d: Draw, symbol: str = "L") -> str:
    """A 'leaf L: area=…' declaration, area from LEAF_AREA."""
    return f"leaf {symbol}: area={_num(d.log_uniform(*LEAF_AREA))}"


# --- the kinds --------------------------------------------------------------------------


def _stalk(d: Draw, seed: int) -> Spec:
    """A straight chain of 2-4 branch symbols; 'doubling' (X -> X X from a mixed axiom),
    'apex' (A -> F B, B -> G C, ...) or 'written' (derivation length 0, per-branch
    strength overrides falling from base to top)."""
    symbols = "FGHK"[:d.integer(2, 4)]
    variant = d.choice(("doubling", "apex", "written"))
    lengths = {s: d.log_uniform(0.08, 0.4) for s in symbols}
    decls = [_branch(s, lengths[s], d.uniform(0.01, 0.025), _strengths(d)) for s in symbols]
    leaf = f" /({_num(d.uniform(0, 180))}) L" if d.chance(0.5) else " L"
    header = _header(d, "stalk", 30, 90)
    spec = Spec("stalk", seed, f"{variant} stalk of symbols {' '.join(symbols)}", header, decls,
                [_leaf(d)], "")
    if variant == "doubling":
        m = d.integer(2, 6)
        spec.axiom = " ".join(d.choice(symbols) for _ in range(m)) + leaf
        spec.productions = [f"{s} -> {s} {s}" for s in symbols]
        spec.depths = (1, 8)
    elif variant == "apex":
        apexes = "ABCD"[:len(symbols)]
        spec.axiom = "A" + leaf
        spec.productions = [f"{a} -> {s} {apexes[(k + 1) % len(apexes)]}"
                            for k, (a, s) in enumerate(zip(apexes, symbols))]
        spec.depths = (MIN_BRANCHES, MAX_DEPTH)
    else:
        n = d.integer(MIN_BRANCHES, 90)
        chain = [d.choice(symbols) for _ in range(n)]
        spec.axiom = " ".join(chain) + leaf
        fall = d.uniform(1.0, 3.0)                 # base / top strength ratio
        rows = []
        for i in range(n):
            f = fall ** (0.5 - i / (n - 1)) * d.uniform(0.9, 1.1)
            rows.append(f"{i}: {_strengths(d, MID_STRENGTH * f)}")
        spec.overrides = lambda _depth, rows=rows: rows
    return spec


def _whorl(d: Draw, lateral: str, count: int, angle: float) -> str:
    """``count`` laterals [&(angle) lateral] spaced by rolls of 360/count degrees."""
    step = _num(360.0 / count)
    return f" /({step}) ".join([f"[&({_num(angle)}) {lateral}]"] * count)


def _monopodial(d: Draw, seed: int) -> Spec:
    """A trunk T adding a whorl of 2-5 laterals a step, rolled by a phyllotactic angle between
    whorls; laterals are chains of B with leaves ('simple') or with a pair of leafy side shoots
    S at every node ('branched')."""
    whorl = d.integer(2, 5)
    angle = d.uniform(30, 70)
    roll = d.choice((137.5, 360.0 / (2 * whorl), d.uniform(20, 170)))
    variant = d.choice(("simple", "branched"))
    trunk = d.uniform(0.2, 0.5)
    decls = [_branch("T", trunk, d.uniform(0.02, 0.04), _strengths(d)),
             _branch("B", trunk * d.uniform(0.4, 0.8), d.uniform(0.008, 0.015), _strengths(d))]
    productions = [f"A -> T {_whorl(d, 'C', whorl, angle)} /({_num(roll)}) A"]
    if variant == "simple":
        productions.append(f"C -> B [/({_num(d.uniform(45, 135))}) L] C")
    else:
        decls.append(_branch("S", trunk * d.uniform(0.2, 0.4), d.uniform(0.004, 0.008), _strengths(d)))
        side = _num(d.uniform(30, 60))
        productions.append(f"C -> B [+({side}) S L] [-({side}) S L] C")
    return Spec("monopodial", seed, f"{variant} laterals, whorls of {whorl} at {angle:.0f} deg, "
                f"roll {roll:.1f} deg", _header(d, "monopodial", 30, 90), decls, [_leaf(d)], "A",
                productions, depths=(2, 30))


def _sympodial(d: Draw, seed: int) -> Spec:
    """Every apex draws one F(s) and stops; 2 or 3 laterals A(s*r), A(s*r*r), ... take over,
    each pitched 20-50 deg off its parent (no straight continuation), each with a leaf."""
    laterals = d.integer(2, 3)
    ratio = d.uniform(0.78, 0.95)
    parts = []
    for k in range(laterals):
        pitch = _num(d.uniform(20, 50))
        turn = "&" if k % 2 == 0 else "^"
        roll = _num(d.uniform(0, 360 / laterals) + k * 360 / laterals)
        scale = "*".join(["s"] + [_num(ratio)] * (k + 1))
        parts.append(f"[/({roll}) {turn}({pitch}) A({scale}) L]")
    return Spec("sympodial", seed, f"{laterals} laterals a node, length ratio {ratio:.2f}",
                _header(d, "sympodial", 35, 90),
                [_branch("F", d.uniform(0.25, 0.6), d.uniform(0.01, 0.025), _strengths(d))],
                [_leaf(d)], "A(1)", [f"A(s) -> F(s) {' '.join(parts)}"], depths=(3, 10))


def _bush(d: Draw, seed: int) -> Spec:
    """A planar bush from an ABOP 1.24 template, turns 15-35 deg about one axis only; leaves
    rolled out of the plane (drawing nothing after them, so the branches stay planar)."""
    name = d.choice(sorted(BUSH_TEMPLATES))
    axiom, productions, interpretation = BUSH_TEMPLATES[name]
    angle = d.uniform(15, 35)
    return Spec("bush", seed, f"planar bush, template ABOP {name}, angle {angle:.1f} deg",
                _header(d, "bush", angle, 90),
                [_branch("F", d.uniform(0.04, 0.15), d.uniform(0.004, 0.012), _strengths(d))],
                [_leaf(d)], axiom, list(productions), list(interpretation), depths=(1, 8))


def _bush3d(d: Draw, seed: int) -> Spec:
    """A 3D bush: 'shoots' (a stem adding 2-4 pitched shoots a step, each forking left and right
    with leaves; eval/bush3d style) or 'abop' (ABOP 1.25: three pitched apices a node, rolled)."""
    variant = d.choice(("shoots", "abop"))
    rotation = d.uniform(100, 160)
    if variant == "shoots":
        count = d.integer(2, 4)
        pitch = d.uniform(35, 65)
        side = d.uniform(25, 50)
        stem = d.uniform(0.1, 0.3)
        decls = [_branch("F", stem, d.uniform(0.008, 0.015), _strengths(d)),
                 _branch("S", stem * d.uniform(0.3, 0.6), d.uniform(0.003, 0.006), _strengths(d))]
        shoot = f"[&({_num(pitch)}) S L B]"
        productions = ["A -> F " + " / ".join([shoot] * count) + " / A",
                       f"B -> S [+({_num(side)}) S L] [-({_num(side)}) S L] B"]
        axiom = "A"
    else:
        decls = [_branch("F", d.uniform(0.04, 0.1), d.uniform(0.005, 0.01), _strengths(d))]
        r1, r2 = _num(d.uniform(80, 130)), _num(d.uniform(120, 170))
        productions = [f"A -> [&FL!(0.006)A] /({r1}) [&FL!(0.006)A] /({r2}) [&FL!(0.006)A]",
                       f"F -> S /({_num(d.uniform(60, 120))}) F", "S -> F L"]
        axiom = "A"
    return Spec("bush3d", seed, f"3D bush ({variant}), roll {rotation:.1f} deg",
                _header(d, "bush3d", d.uniform(20, 40) if variant == "abop" else 45, rotation),
                decls, [_leaf(d)], axiom, productions, depths=(2, 12))


def _stochastic(d: Draw, seed: int) -> Spec:
    """A shoot X rewritten by one of 3-4 successors (STOCHASTIC_SUCCESSORS) with drawn
    probabilities; the file's seed drawn too, so that two trees of one grammar differ."""
    picks = d.rng.choice(len(STOCHASTIC_SUCCESSORS), size=d.integer(3, 4), replace=False)
    weights = d.rng.dirichlet(np.full(len(picks), 4.0))
    probs = [round(float(w), 2) for w in weights[:-1]]
    probs.append(round(1.0 - sum(probs), 2))
    productions = [f"X -> ({_num(p)}) {STOCHASTIC_SUCCESSORS[int(k)]}" for p, k in zip(probs, picks)]
    header = _header(d, "stochastic", d.uniform(20, 35), 90, seed=d.integer(0, 9999))
    return Spec("stochastic", seed, f"{len(picks)} stochastic successors of X", header,
                [_branch("F", d.uniform(0.08, 0.25), d.uniform(0.004, 0.01), _strengths(d))],
                [_leaf(d)], "X", productions, depths=(3, 14))


def _bent_leafy(d: Draw, seed: int) -> Spec:
    """A main axis A and side chains B that turn a few degrees at every segment ('curl': always
    the same way, 'zigzag': alternating), with a leaf on either side of most segments."""
    turn = d.uniform(5, 20)
    bend = d.uniform(5, 20)
    pitch = _num(d.uniform(25, 55))
    segments = d.integer(2, 4)
    way = d.choice(("curl", "zigzag"))
    side = []
    for k in range(segments):
        sign = "-" if way == "curl" or k % 2 == 0 else "+"
        leaf = "[+L]" if k % 2 == 0 else "[-L]"
        side.append(f"F {leaf} {sign}({_num(bend)})")
    productions = [f"A -> F [&({pitch}) B] +({_num(turn)}) F [^({pitch}) / B] +({_num(turn)}) F A",
                   "B -> " + " ".join(side) + " [/(90) L] B"]
    return Spec("bent_leafy", seed, f"{way} side chains of {segments} segments, turns {turn:.0f} "
                f"and {bend:.0f} deg", _header(d, "bent_leafy", d.uniform(10, 30), 90),
                [_branch("F", d.uniform(0.15, 0.35), d.uniform(0.006, 0.012), _strengths(d))],
                [_leaf(d)], "A", productions, depths=(2, 12))


def _weeping(d: Draw, seed: int) -> Spec:
    """A trunk T adding 1-3 laterals a step; each lateral W(b) grows two segments a step, each
    pitched further down (by b, then b*q), b shrinking by q per segment, so that it turns
    90-120 deg in all past its 50-75 deg start and hangs (140-195 deg from the vertical)."""
    count = d.integer(1, 3)
    start = d.uniform(50, 75)
    shrink = d.uniform(0.6, 0.8)
    first = d.uniform(90, 120) * (1 - shrink)      # the pitches sum to 90-120 deg
    trunk = d.uniform(0.25, 0.5)
    decls = [_branch("T", trunk, d.uniform(0.02, 0.04), _strengths(d)),
             _branch("S", trunk * d.uniform(0.3, 0.6), d.uniform(0.005, 0.012), _strengths(d))]
    lateral = f"W({_num(first)})"
    q = _num(shrink)
    productions = [f"A -> T {_whorl(d, lateral, count, start)} /({_num(d.uniform(100, 160))}) A",
                   f"W(b) -> S [/(90) L] &(b) S [/(90) L] &(b*{q}) W(b*{q}*{q})"]
    return Spec("weeping", seed, f"{count} laterals a node from {start:.0f} deg, pitch {first:.1f} "
                f"deg shrinking by {shrink:.2f}", _header(d, "weeping", 30, 90), decls, [_leaf(d)],
                "A", productions, depths=(3, 30))


def _mixed(d: Draw, seed: int) -> Spec:
    """A trunk T, branches B and twigs S (monopodial), each symbol with its own k_FA, k_fp and C_d;
    the trunk's first two segments (axiom modules) override k_FA and k_fp per branch."""
    angle = d.uniform(30, 60)
    trunk = d.uniform(0.2, 0.5)

    def own(kind: str) -> str:
        """A symbol's own k_FA (FORCE_ABSORBED[kind]), k_fp and C_d keys."""
        lo, hi = FORCE_ABSORBED[kind]
        return (f"force_absorbed={_num(d.log_uniform(lo, hi))} "
                f"force_propagated={_num(d.uniform(*FORCE_PROPAGATED))} "
                f"drag_coefficient={_num(d.uniform(*DRAG_RANGE))}")

    decls = [_branch("T", trunk, d.uniform(0.02, 0.04), _strengths(d), own("mixed")),
             _branch("B", trunk * d.uniform(0.4, 0.7), d.uniform(0.008, 0.015), _strengths(d),
                     own("mixed")),
             _branch("S", trunk * d.uniform(0.15, 0.3), d.uniform(0.003, 0.006), _strengths(d))]
    side = _num(d.uniform(30, 60))
    productions = [f"A -> T {_whorl(d, 'C', d.integer(2, 3), angle)} /({_num(d.uniform(100, 160))}) A",
                   f"C -> B [+({side}) S L] [-({side}) S L] C"]
    overrides = [(d.uniform(0.3, 3.0), d.uniform(*FORCE_PROPAGATED)) for _ in range(2)]

    def rows(depth: int) -> list[str]:
        """The override lines at derivation length ``depth``: an axiom module that no
        production rewrites is copied, index 0 at every step (model.md 1)."""
        return [f"{i}{'.0' * depth}: force_absorbed={_num(f * FORCE_ABSORBED['mixed'][0])} "
                f"force_propagated={_num(p)}" for i, (f, p) in enumerate(overrides)]

    return Spec("mixed", seed, f"symbols T, B, S with their own constants, whorls at {angle:.0f} deg",
                _header(d, "mixed", 30, 90), decls, [_leaf(d)], "T T A", productions,
                overrides=rows, depths=(2, 30))


MAKERS: dict[str, Callable[[Draw, int], Spec]] = {
    "stalk": _stalk, "monopodial": _monopodial, "sympodial": _sympodial, "bush": _bush,
    "bush3d": _bush3d, "stochastic": _stochastic, "bent_leafy": _bent_leafy, "weeping": _weeping,
    "mixed": _mixed,
}


def generate(kind: str, seed: int) -> str:
    """The .lsys text of tree (kind, seed): the same text for the same arguments, always."""
    if kind not in MAKERS:
        raise ValueError(f"unknown kind {kind!r}; expected one of {', '.join(KINDS)}")
    if seed < 0:
        raise ValueError(f"seed {seed}: expected a non-negative integer")
    d = Draw(kind, seed)
    spec = MAKERS[kind](d, seed)
    target = d.target_branches()
    if not spec.depths[1]:                         # written out: derivation length 0
        return spec.render(0)
    return _choose_depth(spec, target)


def kind_of(seed: int, kinds: tuple[str, ...] = KINDS) -> str:
    """The kind of seed ``seed``: kinds[seed % len(kinds)]."""
    return kinds[seed % len(kinds)]


def family(seeds, kinds: tuple[str, ...] = KINDS) -> list[tuple[str, str]]:
    """(name, text) of every seed, name '<kind>-<seed>', in the order of ``seeds``."""
    return [(f"{kind_of(s, kinds)}-{s}", generate(kind_of(s, kinds), s)) for s in seeds]


def parse_seeds(text: str) -> list[int]:
    """'A-B' (both included), 'A' or a comma-separated list of those, as a list of ints."""
    seeds: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.strip().partition("-")
        if not lo.isdigit() or (hi and not hi.isdigit()):
            raise argparse.ArgumentTypeError(f"seeds {text!r}: expected A-B, A or a list of those")
        seeds += list(range(int(lo), int(hi or lo) + 1))
    return seeds


def parse_kinds(text: str) -> tuple[str, ...]:
    """A comma-separated list of kinds, each one of KINDS."""
    kinds = tuple(k.strip() for k in text.split(",") if k.strip())
    unknown = [k for k in kinds if k not in MAKERS]
    if unknown or not kinds:
        raise argparse.ArgumentTypeError(f"kinds {text!r}: expected some of {', '.join(KINDS)}")
    return kinds


def main(argv: list[str] | None = None) -> int:
    """The command line: writes OUT/<kind>-<seed>.lsys for every seed; exit status 0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=parse_seeds, default=parse_seeds("0-199"))
    parser.add_argument("--out", required=True, help="directory for <kind>-<seed>.lsys")
    parser.add_argument("--kinds", type=parse_kinds, default=KINDS)
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in family(args.seeds, args.kinds):
        (out / f"{name}.lsys").write_text(text, encoding="utf-8")
    print(f"{len(args.seeds)} trees in {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
