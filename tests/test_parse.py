"""The .lsys parser: valid input against hand-built trees and hand-computed values,
and one test per error kind at its exact line and column."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from plantlod.lsys.errors import InputError
from plantlod.lsys.expr import Binary, Name, Num, Unary, evaluate
from plantlod.lsys.parse import parse_expr, parse_lsys, parse_modules
from plantlod.lsys.system import (
    BranchSymbol, LeafSymbol, LSystem, Module, Override, Pattern, Production,
)

# Four header lines: every required key except the axiom.
HEAD = "derivation_length: 2\nbranching_angle: 30\nforce_absorbed: 0.1\nforce_propagated: 0.5\n"


def parse(body: str) -> LSystem:
    return parse_lsys(HEAD + body, "t.lsys")


def error(text: str) -> InputError:
    with pytest.raises(InputError) as info:
        parse_lsys(text, "t.lsys")
    return info.value


def where(exc: InputError) -> tuple[str, int, int]:
    return exc.file, exc.line, exc.col


def value(text: str, **env) -> float:
    return evaluate(parse_expr(text), env)


# --- expressions ------------------------------------------------------------------

@pytest.mark.parametrize("text, expected", [
    ("1+2*3", 7.0),
    ("(1+2)*3", 9.0),
    ("-2^2", -4.0),          # ^ binds tighter than unary minus
    ("(-2)^2", 4.0),
    ("2^3^2", 512.0),        # right-associative: 2^(3^2), not (2^3)^2 = 64
    ("2^-1", 0.5),
    ("2-3-4", -5.0),         # left-associative
    ("2/4/2", 0.25),
    ("7%4", 3.0),
    ("-7%4", -3.0),          # C fmod: the sign of the dividend
    ("1 < 2 && 3 > 4", 0.0),
    ("1 < 2 && 3 < 4", 1.0),
    ("1 || 0 && 0", 1.0),    # && binds tighter: 1 || (0 && 0)
    ("(1 || 0) && 0", 0.0),
    ("1 == 1 < 2", 1.0),     # 1 == (1 < 2)
    ("2 != 3", 1.0),
    ("2 <= 2", 1.0),
    ("3 >= 4", 0.0),
    ("!0", 1.0),
    ("!2 + 1", 1.0),         # (!2) + 1
    ("--3", 3.0),
    ("+4", 4.0),
    ("-2*3", -6.0),
    ("max(1,2)+min(3,4)*2", 8.0),
    ("pow(2, 10)", 1024.0),
    ("sqrt(16) + abs(-3) + floor(2.7) + ceil(2.2)", 4.0 + 3.0 + 2.0 + 3.0),
    (".5 + 2e-3 + 1.", 1.502),
    ("2E+2", 200.0),
])
def test_precedence_and_values(text, expected):
    assert value(text) == pytest.approx(expected, abs=1e-15)


def test_functions_take_radians():
    assert value("atan2(1, 1)") == pytest.approx(math.pi / 4)
    assert value("sin(x)", x=math.pi / 6) == pytest.approx(0.5)


def test_minus_two_is_unary_minus_of_two():
    assert parse_expr("-2") == Unary("-", Num(2.0))
    assert parse_expr("-2^2") == Unary("-", Binary("^", Num(2.0), Num(2.0)))
    assert parse_expr("a-2") == Binary("-", Name("a"), Num(2.0))


def test_tree_shape_of_mixed_precedence():
    expected = Binary("||",
                      Binary("&&", Binary("<", Name("a"), Num(1.0)),
                             Binary("==", Name("b"), Binary("+", Num(2.0), Binary("*", Num(3.0), Name("c"))))),
                      Unary("!", Name("d")))
    assert parse_expr("a < 1 && b == 2 + 3*c || !d") == expected


def test_positions_are_first_characters_and_binary_at_its_operator():
    e = parse_expr("  sin(ab) + -3", source="f", line=4, col=10)
    # text index -> column 10 + index
    assert (e.pos.line, e.pos.col) == (4, 10 + 10)           # the '+'
    assert e.left.pos.col == 10 + 2                          # 'sin'
    assert e.left.args[0].pos.col == 10 + 6                  # 'ab'
    assert e.right.pos.col == 10 + 12                        # unary '-'
    assert e.right.operand.pos.col == 10 + 13                # '3'
    assert e.pos.file == "f"


# Arithmetic checked against an independent evaluator: Python's own, on text the test
# generates itself (numbers and + - * / ^ only; ^ becomes **, which has the same
# precedence, right associativity and -2**2 == -4). Never used on file text by the parser.
_NUMBERS = st.sampled_from(["1.0", "2.0", "3.0", "0.5", "1.5", "2.5", "10.0"])


def _combine(children):
    op = st.sampled_from(["+", "-", "*", "/", "^"])
    space = st.sampled_from(["", " "])
    return st.one_of(
        st.tuples(children, space, op, space, children).map("".join),
        children.map(lambda e: f"({e})"),
        children.map(lambda e: f"-{e}"),
    )


@settings(max_examples=300, deadline=None)
@given(st.recursive(_NUMBERS, _combine, max_leaves=8))
def test_arithmetic_agrees_with_python(text):
    python_text = text.replace("^", "**")
    try:
        expected = eval(python_text, {"__builtins__": {}}, {})  # oracle on generated text
    except (ZeroDivisionError, OverflowError):
        expected = None
    assume(not isinstance(expected, complex))
    if expected is None:
        with pytest.raises((InputError, ValueError, OverflowError)):
            value(text)
        return
    try:
        ours = value(text)
    except (ValueError, OverflowError):   # math.pow where Python gave a complex or inf
        assume(False)
    if math.isnan(expected):
        assert math.isnan(ours)
    else:
        assert ours == expected


# --- modules ---------------------------------------------------------------------

def test_modules_with_and_without_spaces():
    a = parse_modules("F(1) [ +(30) F ] A(2,3)")
    b = parse_modules("F(1)[+(30)F]A(2,3)")
    assert a == b == (
        Module("F", (Num(1.0),)), Module("["), Module("+", (Num(30.0),)), Module("F"),
        Module("]"), Module("A", (Num(2.0), Num(3.0))),
    )
    assert [m.pos.col for m in a] == [1, 6, 8, 14, 16, 18]


def test_any_unreserved_character_is_a_module():
    mods = parse_modules("é.*@07$|")
    assert [m.name for m in mods] == list("é.*@07$|")


# --- whole files: valid -------------------------------------------------------------

FULL = """\
# every statement kind
name: full test: tree   # the name runs to the comment
derivation_length: 4
define a = 10
define b = a * 2 + 1          # earlier defines
branching_angle: b + 4

rotation_angle: 90
seed: 12345678901234567890123
force_absorbed: 0.005
force_propagated: 0.7
drag_coefficient: 0.003
leaf_force_scale: 2
ignore: + - / \\ & ^

branch F: length=1 radius=a/1000 bend_strength=20 rotation_strength=30 force_absorbed=0.1
branch G: length=2 radius=0.01 bend_strength=1 rotation_strength=2 force_propagated=0.3 drag_coefficient=0.5
leaf L: area=0.01
axiom: A(1, a) L
productions:
  A(x,y) : x < 3 -> F(x)[+(b)A(x+1, y/2)]A(x+1,y)
    # comment inside a section, and a blank line:

  B < A(x,y) > C : * -> (0.25) G
  B < A(x,y) > C -> (0.75) F
  L ->
interpretation:
  A(x,y) -> L(x*0.001)
overrides:
  0.1.0: length=2 area=0.5
  3: force_propagated=0.49
"""


def test_every_statement_kind():
    s = parse_lsys(FULL, "full.lsys")
    assert s.name == "full test: tree"
    assert s.derivation_length == 4
    assert s.defines == (("a", 10.0), ("b", 21.0))
    assert s.branching_angle == 25.0
    assert s.rotation_angle == 90.0
    assert s.seed == 12345678901234567890123      # exact, not through a float
    assert (s.force_absorbed, s.force_propagated) == (0.005, 0.7)
    assert (s.drag_coefficient, s.leaf_force_scale) == (0.003, 2.0)
    assert s.ignore == ("+", "-", "/", "\\", "&", "^")
    assert s.branches == (
        BranchSymbol("F", 1.0, 0.01, 20.0, 30.0, force_absorbed=0.1),
        BranchSymbol("G", 2.0, 0.01, 1.0, 2.0, force_propagated=0.3, drag_coefficient=0.5),
    )
    assert s.leaves == (LeafSymbol("L", 0.01),)
    assert s.axiom == (Module("A", (Num(1.0), Name("a"))), Module("L"))
    x, y = Name("x"), Name("y")
    p0 = Production(
        pred=Pattern("A", ("x", "y")),
        condition=Binary("<", x, Num(3.0)),
        successor=(
            Module("F", (x,)), Module("["), Module("+", (Name("b"),)),
            Module("A", (Binary("+", x, Num(1.0)), Binary("/", y, Num(2.0)))), Module("]"),
            Module("A", (Binary("+", x, Num(1.0)), y)),
        ),
    )
    p1 = Production(pred=Pattern("A", ("x", "y")), left=(Pattern("B"),), right=(Pattern("C"),),
                    probability=Num(0.25), successor=(Module("G"),))
    assert s.productions[:2] == (p0, p1)
    assert s.productions[2].probability == Num(0.75) and s.productions[2].condition is None
    assert s.productions[3] == Production(pred=Pattern("L"), successor=())
    assert s.interpretation == (Production(
        pred=Pattern("A", ("x", "y")),
        successor=(Module("L", (Binary("*", x, Num(0.001)),)),)),)
    assert s.overrides == (
        Override((0, 1, 0), (("area", 0.5), ("length", 2.0))),
        Override((3,), (("force_propagated", 0.49),)),
    )
    # positions: file, line and column of the first character
    assert (s.productions[0].pos.file, s.productions[0].pos.line, s.productions[0].pos.col) == ("full.lsys", 21, 3)
    assert (s.productions[1].pred.pos.line, s.productions[1].pred.pos.col) == (24, 7)
    assert (s.overrides[1].pos.line, s.overrides[1].pos.col) == (31, 3)
    assert (s.branches[1].pos.line, s.branches[1].pos.col) == (17, 8)


def test_abop_2_6_production():
    text = HEAD + """
define a0 = 45
define d = 137.5
define r1 = 0.9
define r2 = 0.6
define wr = 0.707
axiom: A(1,10)
productions:
  A(l,w) : * -> !(w)F(l)[&(a0)B(l*r2,w*wr)]/(d)A(l*r1,w*wr)
"""
    (p,) = parse_lsys(text).productions
    l, w = Name("l"), Name("w")
    assert p == Production(
        pred=Pattern("A", ("l", "w")),
        condition=None,
        successor=(
            Module("!", (w,)), Module("F", (l,)), Module("["), Module("&", (Name("a0"),)),
            Module("B", (Binary("*", l, Name("r2")), Binary("*", w, Name("wr")))), Module("]"),
            Module("/", (Name("d"),)),
            Module("A", (Binary("*", l, Name("r1")), Binary("*", w, Name("wr")))),
        ),
    )
    # the module B sits at column 3 + len("A(l,w) : * -> !(w)F(l)[&(a0)")
    assert p.successor[4].pos.col == 3 + len("A(l,w) : * -> !(w)F(l)[&(a0)")


def test_context_sequences_and_condition():
    s = parse("axiom: A(1)\nproductions:\n  B C(u) < A(x) > D E(v,z) : u + v > x -> F\n")
    (p,) = s.productions
    assert p.left == (Pattern("B"), Pattern("C", ("u",)))
    assert p.right == (Pattern("D"), Pattern("E", ("v", "z")))
    assert p.condition == Binary(">", Binary("+", Name("u"), Name("v")), Name("x"))


def test_stochastic_group_may_be_interleaved():
    s = parse("define p = 0.3\naxiom: A\nproductions:\n  A -> (p) F\n  B -> F\n  A -> (1 - p) FF\n")
    assert [str(evaluate(p.probability, s.constants())) if p.probability else None
            for p in s.productions] == ["0.3", None, "0.7"]


def test_star_condition_is_no_condition():
    s = parse("axiom: A\nproductions:\n  A : * -> F\n  A:*->G\n")
    assert [p.condition for p in s.productions] == [None, None]


def test_defaults():
    s = parse("axiom: F\n")
    assert s.rotation_angle == s.branching_angle == 30.0
    assert (s.seed, s.drag_coefficient, s.leaf_force_scale, s.name) == (0, 0.0015, 1.0, "")
    assert (s.productions, s.interpretation, s.branches, s.leaves, s.ignore, s.overrides) == ((),) * 6


def test_crlf_tabs_and_integer_expressions():
    s = parse_lsys(HEAD.replace("derivation_length: 2", "derivation_length: 2*3").replace("\n", "\r\n")
                   + "axiom:\tF\r\n\tproductions:\r\n\tF\t->\tFF\r\n")
    assert s.derivation_length == 6 and isinstance(s.derivation_length, int)
    assert s.productions[0].successor == (Module("F"), Module("F"))


def test_lone_carriage_returns_end_lines_as_newlines_do():
    """An old Mac file (lines ended by \\r alone) was one line: a comment at its top hid the
    rest, and the error was a missing header key at 1:1."""
    text = "# a comment\n" + HEAD + "axiom: F\nproductions:\n  F -> FF\n"
    assert parse_lsys(text.replace("\n", "\r")) == parse_lsys(text)
    with pytest.raises(InputError) as info:
        parse_lsys(text.replace("axiom: F", "axiom: F(").replace("\n", "\r"))
    assert info.value.line == text.split("\n").index("axiom: F") + 1


def test_turtle_parameter_counts_that_are_allowed():
    s = parse("branch F: length=1 radius=1 bend_strength=1 rotation_strength=1\nleaf L: area=1\n"
              "axiom: F(2)L(3)+(1)-&^/\\f(2)!(1)|$[F]\nproductions:\n  +(a) -> -(a)\n")
    assert len(s.axiom) == 15


def test_sections_repeat_contexts_without_spaces_and_shadowing():
    s = parse("define x = 5\nignore: +-/\naxiom: A(1)\nproductions:\n  BC<A(x)>DE -> F(x)\n"
              "define y = 2\nproductions:\n  B -> F(y)\n")
    assert s.ignore == ("+", "-", "/")
    first, second = s.productions
    assert [p.name for p in first.left] == ["B", "C"] and [p.name for p in first.right] == ["D", "E"]
    assert first.successor == (Module("F", (Name("x"),)),)    # the parameter, hiding the define
    assert second.successor == (Module("F", (Name("y"),)),)


def test_parser_never_calls_python_eval(monkeypatch):
    import builtins

    def refuse(*args, **kwargs):
        raise AssertionError("eval/compile called on file text")
    monkeypatch.setattr(builtins, "eval", refuse)
    monkeypatch.setattr(builtins, "compile", refuse)
    monkeypatch.setattr(builtins, "exec", refuse)
    assert parse_lsys(FULL).derivation_length == 4


def test_examples_parse(examples_dir):
    for path in sorted(examples_dir.glob("*.lsys")):
        s = parse_lsys(path.read_text(), str(path))
        assert s.axiom and s.source == str(path)


# --- whole files: errors ---------------------------------------------------------------
# HEAD has 4 lines, so the first body line is line 5.

def _check(body: str, line: int, col: int, fragment: str, head: str = HEAD):
    exc = error(head + body)
    assert where(exc) == ("t.lsys", line, col), str(exc)
    assert fragment in exc.message, exc.message
    assert "\n" not in exc.message


@pytest.mark.parametrize("body, line, col, fragment", [
    # header keys
    ("axiom: F\nbrnching_angel: 3\n", 6, 1, "unknown header key 'brnching_angel'"),
    ("axiom: F\n  seed: 1\nseed: 2\n", 7, 1, "duplicate header key 'seed' (first given at 6:3)"),
    ("axiom: F\nseed: 2.5\n", 6, 7, "seed must be a non-negative integer, got 2.5"),
    ("axiom: F\nseed: -1\n", 6, 7, "non-negative integer, got -1"),
    ("axiom: F\nseed: 1 2\n", 6, 9, "unexpected '2' after the value of 'seed'"),
    ("axiom: F\nname:\nname: x\n", 7, 1, "duplicate header key 'name'"),
    ("axiom: F\naxiom: G\n", 6, 1, "duplicate 'axiom:' (first given at 5:1)"),
    ("axiom:\n", 5, 7, "the axiom is empty"),
    ("axiom: F\nignore: + [\n", 6, 11, "'[' cannot be ignored"),
    ("axiom: F\nignore: + - +\n", 6, 13, "'+' is listed twice"),
    # numbers and characters
    ("axiom: F(1.2.3)\n", 5, 10, "bad number '1.2.3'"),
    ("axiom: F\nseed: 2x\n", 6, 7, "bad number '2x'"),
    ("define big = 1e999\naxiom: F\n", 5, 14, "too large"),
    ("axiom: F = G\n", 5, 10, "unexpected character '='; expected a module"),
    ("define x = @\naxiom: F\n", 5, 12, "unexpected character '@'; expected a number, a name or '('"),
    ("axiom: F (1)\n", 5, 10, "arguments follow its character directly"),
    # parentheses
    ("axiom: F(1\n", 5, 11, "expected ')' to close the argument list opened at 5:9"),
    ("axiom: F(1 2)\n", 5, 12, "expected ',' or ')' to close the argument list opened at 5:9"),
    ("define x = (1+2\naxiom: F\n", 5, 16, "expected ')' to close the parenthesis opened at 5:12"),
    ("axiom: A\nproductions:\n  A -> (0.5 F\n", 7, 13, "expected ')' to close the probability opened at 7:8"),
    ("axiom: A(1)\nproductions:\n  A(x -> F\n", 7, 7, "to close the parameter list opened at 7:4"),
    # brackets
    ("axiom: F]F\n", 5, 9, "unmatched ']'"),
    ("axiom: F\nproductions:\n  F -> [F[F]\n", 7, 8, "'[' is never closed"),
    ("axiom: F\ninterpretation:\n  F -> F]\n", 7, 9, "unmatched ']'"),
    ("axiom: F\nproductions:\n  [ -> F\n", 7, 3, "cannot be a predecessor or a context pattern"),
    # declarations
    ("branch +: length=1\naxiom: F\n", 5, 8, "unknown symbol in a declaration: '+' is a turtle symbol"),
    ("leaf FF: area=1\naxiom: F\n", 5, 7, "unknown symbol in a declaration: a symbol is one character"),
    ("leaf (: area=1\naxiom: F\n", 5, 6, "unknown symbol in a declaration: '(' is reserved"),
    ("branch F: length=1 radius=1 bend_strength=1 rotation_strength=1\nleaf F: area=1\naxiom: F\n",
     6, 6, "'F' is already declared at 5:8; expected each symbol declared once"),
    ("leaf L: aera=1\naxiom: F\n", 5, 9, "unknown key 'aera' in a leaf declaration (did you mean 'area'?)"),
    ("leaf L: area=1 area=2\naxiom: F\n", 5, 16, "duplicate key 'area'"),
    ("branch F: length=1 radius=1 bend_strength=1\naxiom: F\n", 5, 8,
     "branch 'F' lacks the required key 'rotation_strength'"),
    ("leaf L: area\naxiom: F\n", 5, 13, "expected '=' after 'area'"),
    ("define x 3\naxiom: F\n", 5, 10, "expected '=' after 'define x'"),
    ("define x = 1\ndefine x = 2\naxiom: F\n", 6, 8, "'x' is already defined at 5:8"),
    # names and functions
    ("axiom: A\nproductions:\n  A(x) -> F(x+y)\n", 7, 15, "unknown name 'y'; expected a parameter of this production (x) or a define"),
    ("axiom: F(q)\n", 5, 10, "unknown name 'q'"),
    ("define x = y + 1\naxiom: F\n", 5, 12, "unknown name 'y'; expected a number or a define given on an earlier line"),
    ("axiom: F\nseed: later\ndefine later = 1\n", 6, 7, "unknown name 'later'"),   # defined after use
    ("axiom: F(foo(1))\n", 5, 10, "unknown function 'foo'"),
    ("axiom: F(sin(1, 2))\n", 5, 10, "sin() takes 1 argument, got 2"),
    ("axiom: F(atan2(1))\n", 5, 10, "atan2() takes 2 arguments, got 1"),
    # patterns
    ("axiom: A(1,2)\nproductions:\n  A(x,x) -> F\n", 7, 7, "duplicate parameter 'x'"),
    ("axiom: A(1)\nproductions:\n  B(x) < A(x) -> F\n", 7, 12, "parameter 'x' is already bound at 7:5"),
    ("axiom: A(1)\nproductions:\n  A(1) -> F\n", 7, 5, "expected a parameter name, found '1'"),
    ("axiom: A\nproductions:\n  A B -> F\n", 7, 5, "a production rewrites one module"),
    ("axiom: A\nproductions:\n  A : -> F\n", 7, 7, "expected a condition or '*' after ':'"),
    ("axiom: A(1)\nproductions:\n  A(x) : x > 1 F\n", 7, 16, "expected '->', found 'F'"),
    ("axiom: A\nproductions:\n  A > -> F\n", 7, 7, "expected a right context after '>'"),
    # stochastic groups
    ("axiom: A\nproductions:\n  A -> (0.5) F\n  A -> (0.4) FF\n", 7, 3, "sum to 0.9; expected 1"),
    ("axiom: A\nproductions:\n  A -> (1) F\n  A -> FF\n", 8, 3, "has no probability but the one with the same left side at 7:3 has one"),
    ("axiom: A\nproductions:\n  A -> F\n  A -> (1) FF\n", 8, 3, "has a probability but the one with the same left side at 7:3 has none"),
    ("axiom: A(1)\nproductions:\n  A(x) -> (x) F\n", 7, 12, "a probability must be constant; 'x' is a parameter"),
    ("axiom: A\nproductions:\n  A -> (1.5) F\n  A -> (-0.5) G\n", 8, 9, "must not be negative"),
    # parameter counts
    ("axiom: A\nproductions:\n  A(x) -> A(x+1)\n", 5, 8, "'A' has 0 parameters here, but the productions for 'A' (first at 7:3) take 1"),
    ("axiom: B(1)\nproductions:\n  B(x) -> B(x, 1)\n", 7, 11, "'B' has 2 parameters here"),
    ("axiom: X\ninterpretation:\n  X(a) -> F\n", 5, 8, "the interpretation rules for 'X' (first at 7:3) take 1"),
    ("axiom: F +(1,2)\n", 5, 10, "'+' takes 0 or 1 parameters, got 2"),
    ("axiom: F |(1)\n", 5, 10, "'|' takes no parameters, got 1"),
    ("branch F: length=1 radius=1 bend_strength=1 rotation_strength=1\naxiom: F(1,2)\n", 6, 8,
     "'F' is a branch symbol and takes 0 or 1 parameters (its length), got 2"),
    ("axiom: L(1,2)\nleaf L: area=1\n", 5, 8, "'L' is a leaf symbol and takes 0 or 1 parameters (its area), got 2"),
    ("axiom: F\nproductions:\n  $(a) -> F\n", 7, 3, "'$' takes no parameters, got 1"),
    # constant expressions
    ("define x = 1 + 2/(3-3)\naxiom: F\n", 5, 17, "division by zero"),
    ("axiom: A(1)\nproductions:\n  A(x) -> F(x/(2-2))\n", 7, 14, "division by zero"),
    ("axiom: A(1)\nproductions:\n  A(x) : x > 1/0 -> F\n", 7, 15, "division by zero"),
    ("define x = sqrt(-1)\naxiom: F\n", 5, 12, "sqrt() of a value outside its domain"),
    ("define x = 1 + 0^(-1)\naxiom: F\n", 5, 17, "not a finite real number"),   # at the '^'
    ("define x = 2 * 10^400\naxiom: F\n", 5, 18, "not a finite real number"),
    # statements and sections
    ("axiom: F\nF -> FF\n", 6, 1, "production outside a section; expected a 'productions:'"),
    ("axiom: F\nproductons:\n", 6, 1, "unknown header key 'productons' (did you mean 'productions'?)"),
    ("defne x = 1\naxiom: F\n", 5, 1, "unknown statement 'defne' (did you mean 'define'?)"),
    ("axiom: F\nproductions:\n  F -> FF\n  defnie x = 1\n", 8, 3, "unknown statement 'defnie'"),
    ("axiom: F\nproductions:\n  FF\n", 7, 4, "a production rewrites one module"),   # not a statement
    ("axiom: F\nproductions:\n  A\n", 7, 4, "expected '>', ':' or '->', found end of line"),
    ("axiom: F\nproductions: F -> FF\n", 6, 14, "after 'productions:'; expected end of line"),
    ("axiom: F\n*\n", 6, 1, "unexpected '*' outside a section"),
    # a keyword without its colon was "unknown ... (did you mean itself?)"; a non-ASCII letter
    # in a keyword was blamed on the word's first letter (session 23, found by fuzzing)
    ("seed 3\naxiom: F\n", 5, 5, "expected ':' after 'seed'"),
    ("axiom: F\nproductions\n  F -> FF\n", 6, 12, "expected ':' after 'productions'"),
    ("define^ x = 1\naxiom: F\n", 5, 7, "unexpected '^' after 'define'"),
    ("séed: 3\naxiom: F\n", 5, 2, "unexpected 'é' in a name; expected ASCII letters"),
    ("s\u200beed: 3\naxiom: F\n", 5, 2, "unexpected '\\u200b' in a name"),
    ("axiom:\n  F [F\n  F\n", 6, 5, "'[' is never closed; expected a matching ']' in the axiom"),
    # ... but an arrow outside a section is still a production outside one (found in review)
    ("axiom: F\nF\u2192FF\n", 6, 1, "production outside a section"),
    ("axiom: F\nproductions:\n  F -> FF\ndefine x = 1\n  F -> F\n", 9, 3, "production outside a section"),
    # overrides
    ("axiom: F\noverrides:\n  0.-1: length=2\n", 7, 3, "override address '0.-1' is not valid; expected dotted non-negative integers"),
    ("axiom: F\noverrides:\n  0..1: length=2\n", 7, 3, "override address '0..1'"),
    ("axiom: F\noverrides:\n  a.b: length=2\n", 7, 3, "override address 'a.b'"),
    ("axiom: F\noverrides:\n  0.1 length=2\n", 7, 3, "expected 'ADDRESS: key=value ...'"),
    ("axiom: F\noverrides:\n  0.1: lenght=2\n", 7, 8, "unknown key 'lenght' in an override (branch keys, area, area_K)"),
    ("axiom: F\noverrides:\n  0.1: length=2\n  0.1: area=1\n", 8, 3, "address 0.1 is overridden twice"),
    ("axiom: F\noverrides:\n  0.1:\n", 7, 7, "expected key=value after '0.1:'"),
])
def test_error(body, line, col, fragment):
    _check(body, line, col, fragment)


@pytest.mark.parametrize("missing", ["derivation_length", "branching_angle", "force_absorbed", "force_propagated"])
def test_missing_required_header_key(missing):
    head = "".join(line + "\n" for line in HEAD.splitlines() if not line.startswith(missing))
    exc = error(head + "axiom: F\n")
    assert where(exc) == ("t.lsys", 1, 1)
    assert f"missing required header key '{missing}'" in exc.message


def test_missing_axiom():
    exc = error(HEAD)
    assert where(exc) == ("t.lsys", 1, 1) and "missing 'axiom:'" in exc.message


def test_whole_file_errors_report_the_earliest_position():
    # two count errors: line 5 (axiom) and line 8; the axiom's comes first even
    # though productions were read later
    body = "axiom: A\nproductions:\n  A(x) -> F\n  B -> A(1)A(1,2)\n"
    _check(body, 5, 8, "'A' has 0 parameters")


def test_error_str_is_one_located_line():
    exc = error(HEAD + "axiom: F(1\n")
    assert str(exc) == "t.lsys:5:11: expected ')' to close the argument list opened at 5:9"


def test_deep_nesting_is_an_input_error():
    exc = error(HEAD + "axiom: F(" + "(" * 2000 + "1" + ")" * 2001 + "\n")
    assert exc.line == 5 and "expression too deep" in exc.message


def test_parse_expr_rejects_trailing_text():
    with pytest.raises(InputError) as info:
        parse_expr("1 + 2 )", line=3, col=5)
    assert (info.value.line, info.value.col) == (3, 11)


# --- key=value lines read without the expression parser (lsys/parse.py, _KEY_NUMBER) -------

_VALUE = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr),
    st.integers(-10**6, 10**6).map(str),
    st.sampled_from(["-0", "-.5", ".5", "1e400", "-1e-400", "2*3", "(1)", "+1", "1.2.3", "1e",
                     "x", "- 1", "1 ", "nan", "inf", "0x10"]))
_KEY = st.sampled_from(["length", "radius", "bend_strength", "g_bx", "g_rz", "area", "area_0",
                        "area_12", "force_absorbed", "swing_roll", "bogus", "area_01"])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(_KEY, _VALUE, st.sampled_from(["=", "=", " = ", "= "]),
                          st.sampled_from([" ", " ", "  ", "\t"])), min_size=1, max_size=6))
def test_plain_key_values_read_as_the_expression_parser_reads_them(pairs):
    """An override line read by the one-regex path and by the expression parser: the same
    values, or the same error (the regex path hands every line it does not fully own over)."""
    from plantlod.lsys import parse as P

    line = "".join(f"{k}{eq}{v}{sp}" for k, v, eq, sp in pairs).rstrip()
    text = ("derivation_length: 0\nbranch F: length=1 radius=0.1 bend_strength=20 "
            "rotation_strength=20\nleaf L: area=1\naxiom: F L\n\noverrides:\n  0: " + line + "\n")

    def read(fast: bool):
        saved = P._FileParser._plain_key_values
        if not fast:
            P._FileParser._plain_key_values = lambda self, cur, keys, pattern: None
        try:
            return P.parse_lsys(text, "t.lsys")
        except InputError as exc:
            return str(exc)
        finally:
            P._FileParser._plain_key_values = saved

    assert read(True) == read(False)


@pytest.mark.parametrize("value", ["1000000000", "1e9"])
def test_a_derivation_length_past_the_limit_is_refused_at_its_value(value):
    """derive refused it naming the file but no line (session 23, found by fuzzing)."""
    text = HEAD.replace("derivation_length: 2", f"derivation_length: {value}") + "axiom: F\n"
    with pytest.raises(InputError, match="derivation length 1,000,000,000 is more than the "
                                         "limit of 10,000 steps") as info:
        parse_lsys(text, "d.lsys")
    assert (info.value.file, info.value.line, info.value.col) == ("d.lsys", 1, 20)
