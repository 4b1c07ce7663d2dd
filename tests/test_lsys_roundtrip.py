"""Writing and reading .lsys files: parse(write(s)) == s and write is a fixed point.

Random systems are built as syntax trees (not text) under the rules a valid file
obeys, written, and read back; random expressions check that the writer's
parenthesisation and the parser's precedence agree."""

from __future__ import annotations

import functools
import io
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plantlod.formats.lsys_file import read_lsys, write_lsys
from plantlod.lsys.constants import MAX_DERIVATION_STEPS
from plantlod.lsys.errors import InputError
from plantlod.lsys.expr import FUNCTIONS, Binary, Call, Name, Num, Unary, format_expr
from plantlod.lsys.parse import OVERRIDE_KEYS, parse_expr, parse_lsys
from plantlod.lsys.system import GAIN_KEYS
from plantlod.lsys.system import (
    BranchSymbol, LeafSymbol, LSystem, Module, Override, Pattern, Production,
)

# --- handwritten systems -----------------------------------------------------------

HANDWRITTEN = """\
name: hand written
derivation_length: 3
branching_angle: 22.5
force_absorbed: 1e-3
force_propagated: 0.7
ignore: + -
define k = 0.25
define tiny = 5e-324
branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20 drag_coefficient=0.003
leaf L: area=0.01
axiom: A(1,-k)[+F]L
productions:
  A(x,y) < B(z) > C D(w) : x*2^-y >= -z && !(w == 1) -> (k) F(x)[-(2^3^2)B(z)]
  A(x,y) < B(z) > C D(w) : x*2^-y >= -z && !(w == 1) -> (1-k) G((x-y)-(z-w))
  A(x,y) -> A(-(x+y), min(x, y)/tiny % 3) L
  L ->
interpretation:
  A(x,y) : * -> F(x)L(y^2)
overrides:
  0.1.0: length=2 force_propagated=0.49
  0.2: area=0.5
"""

EXPECTED_TEXT = """\
# made by a test
#
# second line

name: hand written
derivation_length: 3
branching_angle: 22.5
rotation_angle: 22.5
seed: 0
force_absorbed: 0.001
force_propagated: 0.7
drag_coefficient: 0.0015
leaf_force_scale: 1
ignore: + -

define k = 0.25
define tiny = 5e-324

branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20 drag_coefficient=0.003
leaf L: area=0.01

axiom: A(1,-k)[+F]L

productions:
  A(x,y) < B(z) > C D(w) : x*2^(-y)>=-z&&!(w==1) -> (k) F(x)[-(2^3^2)B(z)]
  A(x,y) < B(z) > C D(w) : x*2^(-y)>=-z&&!(w==1) -> (1-k) G(x-y-(z-w))
  A(x,y) -> A(-(x+y),min(x,y)/tiny%3)L
  L ->

interpretation:
  A(x,y) -> F(x)L(y^2)

overrides:
  0.1.0: force_propagated=0.49 length=2
  0.2: area=0.5
"""


def test_canonical_text_of_a_handwritten_system():
    s = parse_lsys(HANDWRITTEN)
    assert write_lsys(s, header_comment="made by a test\n\nsecond line") == EXPECTED_TEXT
    assert parse_lsys(EXPECTED_TEXT) == s


def test_examples_round_trip(examples_dir):
    for path in sorted(examples_dir.glob("*.lsys")):
        s = parse_lsys(path.read_text(), str(path))
        text = write_lsys(s)
        assert parse_lsys(text) == s, path
        assert write_lsys(parse_lsys(text)) == text, path


def test_positions_are_not_compared():
    a = parse_lsys(HANDWRITTEN)
    b = parse_lsys("\n\n  " + HANDWRITTEN.replace("\n", "\n   "))
    assert a == b


def test_unwritable_name_is_refused_and_a_carriage_return_inside_reads_back():
    """A name the reader cannot give back is refused as bad input (it was a bare ValueError,
    an internal error from `simplify`). A lone "\r" ends a line since session 29 (old Mac
    files), so no file gives a name holding one, and the writer refuses it as it refuses
    "\n"; a header comment holding one (a file name) is written as two comment lines."""
    from plantlod.lsys.errors import InputError

    s = parse_lsys(HANDWRITTEN)
    for name in ("a # b", "two\nlines", " padded", "a\rb"):
        with pytest.raises(InputError):
            write_lsys(LSystem(**{**s.__dict__, "name": name}))
    assert parse_lsys(write_lsys(s, header_comment="source: a\rb.lsys")) == s


# --- read_lsys -------------------------------------------------------------------

def test_read_file_and_stdin(tmp_path, monkeypatch):
    path = tmp_path / "t.lsys"
    path.write_text(HANDWRITTEN, encoding="utf-8")
    from_file = read_lsys(str(path))
    assert from_file == parse_lsys(HANDWRITTEN) and from_file.source == str(path)

    class FakeStdin:
        buffer = io.BytesIO(HANDWRITTEN.encode("utf-8"))
    monkeypatch.setattr("sys.stdin", FakeStdin)
    from_stdin = read_lsys("-")
    assert from_stdin == from_file and from_stdin.source == "<stdin>"


def test_read_errors_name_the_file(tmp_path):
    missing = tmp_path / "nope.lsys"
    with pytest.raises(InputError) as info:
        read_lsys(str(missing))
    assert info.value.file == str(missing) and "no such file" in info.value.message

    with pytest.raises(InputError) as info:
        read_lsys(str(tmp_path))                      # a directory
    assert info.value.file == str(tmp_path)

    bad = tmp_path / "latin1.lsys"
    bad.write_bytes(b"\xef\xbb\xbfname: x\nseed: 1\n# caf\xe9\n")   # BOM, then Latin-1 on line 3
    with pytest.raises(InputError) as info:
        read_lsys(str(bad))
    assert (info.value.file, info.value.line, info.value.col) == (str(bad), 3, 6)
    assert "not UTF-8" in info.value.message and "0xe9" in info.value.message


def test_parse_errors_name_the_file(tmp_path):
    path = tmp_path / "bad.lsys"
    path.write_text("derivation_length: x\n")
    with pytest.raises(InputError) as info:
        read_lsys(str(path))
    assert str(info.value).startswith(f"{path}:1:20: unknown name 'x'")


# --- random expressions: the writer's parentheses against the parser's precedence ------

_BINARY = ["||", "&&", "==", "!=", "<", "<=", ">", ">=", "+", "-", "*", "/", "%", "^"]
_NAMES = st.sampled_from(["x", "y", "len_1", "e", "E", "sin", "_a"])
# The parser never makes a negative Num (it reads -2 as Unary('-', Num(2))).
_NUMS = st.floats(min_value=0, max_value=1e300, allow_nan=False, allow_infinity=False).map(Num)


def _expr_nodes(children):
    calls = st.sampled_from(sorted(FUNCTIONS)).flatmap(
        lambda f: st.lists(children, min_size=FUNCTIONS[f][1], max_size=FUNCTIONS[f][1])
        .map(lambda args, f=f: Call(f, tuple(args))))
    return st.one_of(
        st.builds(Binary, st.sampled_from(_BINARY), children, children),
        st.builds(Unary, st.sampled_from(["-", "+", "!"]), children),
        calls,
    )


EXPRESSIONS = st.recursive(st.one_of(_NUMS, _NAMES.map(Name)), _expr_nodes, max_leaves=12)


@settings(max_examples=400, deadline=None)
@given(EXPRESSIONS)
def test_expression_round_trip(expr):
    text = format_expr(expr)
    assert parse_expr(text) == expr, text
    assert parse_expr(f" ( {text} ) ") == expr        # parentheses make no node


# --- random systems -------------------------------------------------------------------
# Every character has one fixed parameter count, so that the count checks hold;
# expressions in productions use total functions and operators only (no / % ^,
# which a constant part could make fail), bounded numbers so nothing overflows.

_PLAIN = "ABXYZé.*@07"
_BRANCH, _LEAF = "FG", "LK"
_OPTIONAL_TURTLE, _NO_ARG_TURTLE = "+-&^/\\f!", "|$"
_SAFE_BINARY = ["||", "&&", "==", "!=", "<", "<=", ">", ">=", "+", "-", "*"]
_SAFE_FUNCTIONS = ["abs", "sin", "cos", "atan", "floor", "ceil", "min", "max", "atan2"]
_PARAM_NAMES = ["l", "w", "x", "y", "t_2", "ang", "u", "v"]   # >= 4 patterns x 2
_DEFINE_NAMES = ["a", "b", "len_unit", "e", "min", "r1"]
_FINITE = st.floats(allow_nan=False, allow_infinity=False)
_AMOUNT = st.floats(min_value=0, allow_nan=False, allow_infinity=False)   # lengths, areas, ...
_SMALL = st.floats(min_value=0, max_value=1e6, allow_nan=False)
_STRENGTH = st.floats(min_value=0, exclude_min=True, allow_nan=False,   # k_bs, k_rs: > 0
                      allow_infinity=False)


@functools.lru_cache(maxsize=None)
def _safe_expr(names: tuple[str, ...]):
    leaves = _SMALL.map(Num)
    if names:
        leaves = st.one_of(leaves, st.sampled_from(names).map(Name))

    def nodes(children):
        calls = st.sampled_from(_SAFE_FUNCTIONS).flatmap(
            lambda f: st.lists(children, min_size=FUNCTIONS[f][1], max_size=FUNCTIONS[f][1])
            .map(lambda args, f=f: Call(f, tuple(args))))
        return st.one_of(st.builds(Binary, st.sampled_from(_SAFE_BINARY), children, children),
                         st.builds(Unary, st.sampled_from(["-", "+", "!"]), children), calls)
    return st.recursive(leaves, nodes, max_leaves=4)


@st.composite
def _arities(draw) -> dict[str, int]:
    out = {c: draw(st.integers(0, 2)) for c in _PLAIN}
    out.update({c: draw(st.integers(0, 1)) for c in _OPTIONAL_TURTLE + _BRANCH + _LEAF})
    out.update({c: 0 for c in _NO_ARG_TURTLE})
    return out


_SYMBOLS = _PLAIN + _BRANCH + _LEAF + _OPTIONAL_TURTLE + _NO_ARG_TURTLE


@st.composite
def _module_sequence(draw, arity, names, min_size=0, depth=0):
    """Modules with balanced brackets."""
    out: list[Module] = []
    for _ in range(draw(st.integers(min_size, 4))):
        if depth < 2 and draw(st.booleans()) and draw(st.booleans()):
            out += [Module("["), *draw(_module_sequence(arity, names, 0, depth + 1)), Module("]")]
        else:
            c = draw(st.sampled_from(_SYMBOLS))
            args = tuple(draw(_safe_expr(tuple(names))) for _ in range(arity[c]))
            out.append(Module(c, args))
    return tuple(out)


@st.composite
def _pattern(draw, arity, free: list[str]):
    c = draw(st.sampled_from(_SYMBOLS))
    params = tuple(free.pop() for _ in range(arity[c]))
    return Pattern(c, params)


@st.composite
def _rules(draw, arity, defines: list[str]) -> tuple[Production, ...]:
    """Productions whose left sides never mix stochastic and deterministic rules."""
    out: list[Production] = []
    seen: set = set()
    for _ in range(draw(st.integers(0, 4))):
        free = list(draw(st.permutations(_PARAM_NAMES)))
        left = tuple(draw(_pattern(arity, free)) for _ in range(draw(st.integers(0, 2))))
        pred = draw(_pattern(arity, free))
        right = tuple(draw(_pattern(arity, free)) for _ in range(draw(st.integers(0, 1))))
        params = [p for pat in left + (pred,) + right for p in pat.params]
        names = params + defines
        condition = draw(st.none() | _safe_expr(tuple(names)))
        key = (pred, left, right, condition)
        if key in seen:
            continue
        seen.add(key)
        weights = draw(st.lists(st.integers(1, 9), min_size=1, max_size=3))
        stochastic = draw(st.booleans())
        for w in weights if stochastic else [None]:
            probability = None if w is None else Binary("/", Num(float(w)), Num(float(sum(weights))))
            out.append(Production(pred=pred, left=left, right=right, condition=condition,
                                  probability=probability,
                                  successor=draw(_module_sequence(arity, names))))
    return tuple(draw(st.permutations(out)))   # a group's members need not be adjacent


@st.composite
def systems(draw) -> LSystem:
    arity = draw(_arities())
    define_names = draw(st.lists(st.sampled_from(_DEFINE_NAMES), unique=True, max_size=4))
    defines = tuple((n, draw(st.floats(-1e6, 1e6))) for n in define_names)
    branches = tuple(
        BranchSymbol(c, draw(_AMOUNT), draw(_AMOUNT), draw(_STRENGTH), draw(_STRENGTH),
                     **{k: draw(st.none() | _AMOUNT)
                        for k in ("force_absorbed", "force_propagated", "drag_coefficient")})
        for c in _BRANCH if draw(st.booleans()))
    leaves = tuple(LeafSymbol(c, draw(_AMOUNT)) for c in _LEAF if draw(st.booleans()))
    # a gain matrix comes whole (six keys) and without force_absorbed (model.md 5)
    plain_keys = sorted(set(OVERRIDE_KEYS) - set(GAIN_KEYS))
    overrides = tuple(
        Override(address, tuple(sorted(
            [(k, draw(_STRENGTH if k.endswith("_strength") else _AMOUNT)) for k in draw(
                st.lists(st.sampled_from(plain_keys), min_size=1, max_size=3, unique=True))
             if not (gain and k == "force_absorbed")]
            + ([(k, draw(st.floats(-1.0, 1.0))) for k in GAIN_KEYS] if gain else []))))
        for gain in [draw(st.booleans())]
        for address in draw(st.lists(st.lists(st.integers(0, 10**6), min_size=1, max_size=5)
                                     .map(tuple), unique=True, max_size=3)))
    name_chars = st.sampled_from("abcXYZ019 :-_.é()")
    return LSystem(
        name=draw(st.text(name_chars, max_size=12).map(str.strip)),
        derivation_length=draw(st.integers(0, MAX_DERIVATION_STEPS)),   # (more is refused)
        branching_angle=draw(_FINITE), rotation_angle=draw(_FINITE),
        seed=draw(st.integers(0, 2**80)),
        force_absorbed=draw(_AMOUNT), force_propagated=draw(_AMOUNT),
        drag_coefficient=draw(_AMOUNT), leaf_force_scale=draw(_AMOUNT),
        ignore=tuple(draw(st.lists(st.sampled_from(_PLAIN + _OPTIONAL_TURTLE), unique=True, max_size=4))),
        defines=defines, branches=branches, leaves=leaves,
        axiom=draw(_module_sequence(arity, define_names, min_size=1)),
        productions=draw(_rules(arity, define_names)),
        interpretation=draw(_rules(arity, define_names)),
        overrides=overrides,
    )


@settings(max_examples=150, deadline=None)
@given(systems())
def test_system_round_trip(system):
    text = write_lsys(system)
    parsed = parse_lsys(text)
    assert parsed == system, text
    assert write_lsys(parsed) == text


@settings(max_examples=50, deadline=None)
@given(systems(), st.text(st.sampled_from("ab #:\n"), max_size=20))
def test_header_comment_does_not_change_the_system(system, comment):
    assert parse_lsys(write_lsys(system, header_comment=comment)) == system


def test_float_values_are_exact():
    for v in (0.1, 1 / 3, 5e-324, 1.7976931348623157e308, -2.5e-7, 1e16, 123456789.123):
        s = parse_lsys(f"derivation_length: 0\nbranching_angle: {v!r}\nforce_absorbed: 0\n"
                       "force_propagated: 0\naxiom: F\n")
        assert s.branching_angle == v
        assert parse_lsys(write_lsys(s)).branching_angle == v
        assert math.copysign(1, v) == math.copysign(1, parse_lsys(write_lsys(s)).branching_angle)
