"""Read the ``.lsys`` language (docs/lsys-format.md) into the dataclasses of lsys.system.

Hand-written throughout: each line is read by a character cursor (`_Cursor`); a small
tokenizer (`_token`) and a precedence-climbing parser (`_expression`) build the nodes
of lsys.expr. Nothing from a file ever reaches Python's ``eval`` or ``compile``;
constant expressions are evaluated with `lsys.expr.evaluate`.

Positions: every node carries ``Pos(file, line, col)``, 1-based, columns counted in
characters (a tab is one column). Num, Name, Unary and Call nodes, modules, patterns
and productions point at their first character; a Binary node points at its
operator, so that an error about the operation itself (division by zero, at run time
too) points at the ``/``.

Public API:
  parse_lsys(text, source) -> LSystem      a whole file
  parse_expr(text, source, line, col)      one expression, syntax only
  parse_modules(text, source, line, col)   a module sequence, syntax and brackets only
"""

from __future__ import annotations

import math
import re
import sys
import unicodedata
from typing import Iterator, NamedTuple

from .checks import did_you_mean, digits_past_limit, steps_past_limit
from .constants import MAX_EXPRESSION_DEPTH, MAX_LINE_CHARS, PROBABILITY_SUM_TOL
from .errors import InputError, PlantlodWarning
from .expr import (
    FUNCTIONS, PRECEDENCE, RIGHT_ASSOCIATIVE, UNARY_OPS, UNARY_PRECEDENCE,
    Binary, Call, Expr, Name, Num, Pos, Unary, evaluate, expression_depth, format_number,
    free_names,
)
from .tree import BRANCH_ADDRESS, LEAF_ADDRESS
from .words import counted
from .system import (
    BRACKETS, BRANCH_KEYS, GAIN_KEYS, LEAF_KEYS, LEAF_ORDINAL_KEY, RESERVED_CHARS, STRUCTURE_SYMBOLS,
    SWING_ROLL_KEY,
    TURTLE_NO_ARG, TURTLE_OPTIONAL_ARG, TURTLE_SYMBOLS, UNSUPPORTED_SYMBOLS, BranchSymbol, LeafSymbol, LSystem, Module, Override, Pattern, Production,
)

# where a line ends: \n, \r\n or a lone \r (an old Mac file was one comment line)
LINE_BREAK = re.compile(r"\r\n?|\n")

# Header keys in the order the writer uses; name and ignore are not numbers.
HEADER_KEYS = (
    "name", "derivation_length", "branching_angle", "rotation_angle", "seed",
    "force_absorbed", "force_propagated", "drag_coefficient", "leaf_force_scale", "ignore",
)
REQUIRED_HEADER_KEYS = ("derivation_length", "branching_angle", "force_absorbed", "force_propagated")
_INTEGER_KEYS = frozenset({"derivation_length", "seed"})
SECTIONS = ("productions", "interpretation", "overrides", "groups")
_DECLARATIONS = ("define", "branch", "leaf")
OVERRIDE_KEYS = {**BRANCH_KEYS, **LEAF_KEYS, **{k: False for k in GAIN_KEYS},
                 SWING_ROLL_KEY: False}

_STATEMENT_WORDS = _DECLARATIONS + SECTIONS + HEADER_KEYS + ("axiom",)
_STATEMENTS_HELP = ("a header key, define, branch, leaf, axiom:, productions:, "
                    "interpretation: or overrides:")

# One expression token after optional white space; no group matches at the end of the
# line or at a character that starts no token. Operators longest first.
_NUMBER = r"(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"    # 2, 0.5, .5, 2e-3
_TOKEN = re.compile(r"""(\s*)(?:
      (?P<num>""" + _NUMBER + r""")
    | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
    | (?P<op>\|\||&&|==|!=|<=|>=|-->|->|→|[<>+\-*/%^!])
    | (?P<punct>[(),])
    )?""", re.VERBOSE)
_NUMBER_TAIL = re.compile(r"[A-Za-z0-9_.]+")       # glued to a number: a bad number
# a whole expression that is one plain number: what follows it can end an expression but not
# continue it (',' ')' the end of the line, or a name after white space, as in key=value lists)
_PLAIN_NUMBER = re.compile(r"\s*(" + _NUMBER + r")(?=\s*[,)]|\s*$|\s+[A-Za-z_])")
# one key=number pair of a key=value list, the number signed or not and nothing glued to it:
# most lines of a written level are only these, and `_key_values` reads them without the
# expression parser (the same floats: -x negates exactly)
_KEY_NUMBER = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)=(-?" + _NUMBER + r")(?=\s|$)")
_HEADER_LINE = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*:")
_DECLARATION_LINE = re.compile(r"\s*(define|branch|leaf)(?=\s|$)")
_FIRST_WORD = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)")
_ADDRESS = re.compile(r"[0-9]+(?:\.[0-9]+)*")
# ABOP's captions: "n = 5, δ = 22.5°, ω: F" and what to write instead.
_ABOP_KEYS = {"n": "derivation_length: N", "δ": "branching_angle: DEGREES", "ω": "axiom: MODULES"}
_ABOP_CAPTION = re.compile(r"\s*(n|δ|ω)\s*[=:]")
# What L-Py and cpfg write where plantlod writes something else (docs/notation.md): a
# line starting with one of these words is refused with the advice.
FOREIGN_WORDS = {
    "endlsystem": "'endlsystem' (L-Py, cpfg) ends an L-system there; delete it: the file "
                  "ends the system",
    "Lsystem": "'Lsystem:' (cpfg) numbers the L-system; delete it",
    "lsystem": "'lsystem:' (cpfg) numbers the L-system; delete it",
    "derivation": "'derivation length: N' (L-Py, cpfg) is 'derivation_length: N' here",
    "Axiom": "'Axiom:' (L-Py, cpfg) is 'axiom:' here",
    "production": "'production:' (L-Py) is 'productions:' here",
    "homomorphism": "'homomorphism:' (L-Py) is 'interpretation:' here",
    "endhomomorphism": "'endhomomorphism' (L-Py) is not needed; delete it",
    "endproduction": "'endproduction' (L-Py) is not needed; delete it",
    "consider": "'consider:' (cpfg) is not supported; list the symbols context skips with "
                "'ignore: ...' instead",
    "module": "'module' (L-Py) declarations: declare branch symbols with 'branch F: length=...' "
              "and leaves with 'leaf L: area=...'",
    "import": "Python code (L-Py) is not read here; constants are 'define NAME = VALUE'",
    "from": "Python code (L-Py) is not read here; constants are 'define NAME = VALUE'",
    "def": "Python code (L-Py) is not read here; constants are 'define NAME = VALUE'",
}
_FOREIGN_LINE = re.compile(r"\s*(" + "|".join(FOREIGN_WORDS) + r")\b")
_ASSIGNMENT = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=(?![=>])")   # L-Py's `c = 1`
# an arrow mistyped as `=>` (or `==>`): not an assignment, a production missing its `->`
_WRONG_ARROW = re.compile(r"[^=<>!]*?(=+>)")
_PREPROCESSOR = re.compile(r"\s*#(define|include|ifdef|ifndef|if|else|endif|undef)\b")
# cpfg's probability after a successor, `A --> B : 0.3`: pointed to plantlod's `A -> (0.3) B`
_CPFG_PROBABILITY = re.compile(r":\s*[0-9.eE+-]+\s*")
# The production arrow as ABOP prints it, as L-Py and cpfg write it, and plantlod's own;
# longest first. docs/notation.md.
ARROWS = ("-->", "->", "→")
# Values that are amounts of something and cannot be negative.
NON_NEGATIVE_KEYS = frozenset({"length", "radius", "area", "force_absorbed", "force_propagated",
                               "drag_coefficient", "leaf_force_scale"})
# Spring strengths: 0 or less never brings a branch back (model.md 4), so no run could use it.
POSITIVE_KEYS = frozenset({"bend_strength", "rotation_strength"})


# --- the cursor and the tokenizer ------------------------------------------------------

class _Cursor:
    """A read position in one line of text (no newline); columns start at ``col0``."""

    __slots__ = ("text", "i", "source", "line", "col0", "tok_at", "tok", "nest")

    def __init__(self, text: str, source: str, line: int, col0: int = 1, start: int = 0):
        self.text, self.i, self.source, self.line, self.col0 = text, start, source, line, col0
        self.tok_at, self.tok = -1, None    # the last token read by _token, and where
        self.nest = 0                       # expressions being parsed inside each other

    def pos(self, i: int | None = None) -> Pos:
        return Pos(self.source, self.line, self.col0 + (self.i if i is None else i))

    def error(self, message: str, i: int | None = None) -> InputError:
        return _error(self.pos(i), message)

    def skip_ws(self) -> None:
        text, i, n = self.text, self.i, len(self.text)
        while i < n and text[i].isspace():
            i += 1
        self.i = i

    def char(self) -> str:
        """The character at the cursor after white space ('' at the end of the line)."""
        self.skip_ws()
        return self.text[self.i] if self.i < len(self.text) else ""

    def at(self, s: str) -> bool:
        self.skip_ws()
        return self.text.startswith(s, self.i)

    def describe(self) -> str:
        c = self.char()
        return f"'{c}'" if c else "end of line"

    def arrow(self) -> int:
        """The length of the production arrow at the cursor (after white space), 0 if none."""
        self.skip_ws()
        for arrow in ARROWS:
            if self.text.startswith(arrow, self.i):
                return len(arrow)
        return 0


def _has_arrow(line: str) -> bool:
    return any(arrow in line for arrow in ARROWS)


class _Tok(NamedTuple):
    kind: str     # num, name, op, ( ) , char (anything else), badnum, end
    text: str
    start: int    # index in the line
    end: int


def _token(cur: _Cursor) -> _Tok:
    """The expression token at the cursor (after white space), without consuming it."""
    if cur.i == cur.tok_at:
        return cur.tok
    m = _TOKEN.match(cur.text, cur.i)
    cur.i = i = m.end(1)
    kind = m.lastgroup
    text = cur.text
    if kind is None:
        if i >= len(text):
            tok = _Tok("end", "", i, i)
        elif text[i] in "0123456789.":
            tail = _NUMBER_TAIL.match(text, i)
            tok = _Tok("badnum", tail.group(), i, tail.end())
        else:
            tok = _Tok("char", text[i], i, i + 1)
    else:
        stop = m.end()
        if m.group(kind) == "*" and text.startswith("*", stop):
            raise cur.error("'**' (L-Py and Python: a power) is '^' here; write x^2", i)
        tok = _Tok(m.group(kind) if kind == "punct" else kind, m.group(kind), i, stop)
        if kind == "num":
            tail = _NUMBER_TAIL.match(text, stop)
            if tail:
                tok = _Tok("badnum", text[i:tail.end()], i, tail.end())
    cur.tok_at, cur.tok = i, tok
    return tok


def _describe(tok: _Tok) -> str:
    if tok.kind == "end":
        return "end of line"
    if tok.kind == "char":
        advice = UNSUPPORTED_SYMBOLS.get(tok.text)
        return f"character '{tok.text}'" + (f" ({advice})" if advice else "")
    return f"'{tok.text}'"


def _error(pos: Pos, message: str) -> InputError:
    return InputError(message, pos.file, pos.line, pos.col)


def _whole_number(cur: _Cursor, digits: str, start: int) -> int:
    """The exact value of a literal of decimal digits found at ``start`` of cur's line. One
    longer than Python converts (`sys.get_int_max_str_digits`, 4300 digits) is an input
    error there: no count, seed or address is that large."""
    past = digits_past_limit(digits)
    if past is not None:
        raise cur.error(f"a whole number of {past} digits; expected at most "
                        f"{sys.get_int_max_str_digits()}", start)
    return int(digits.lstrip("0") or "0")    # (int() counts leading zeros toward its limit)


def _leaf_ordinal(cur: _Cursor, key: str, start: int) -> int:
    """K of an ``area_K`` key found at ``start`` (`LEAF_ORDINAL_KEY`), held to what
    `_whole_number` converts."""
    return _whole_number(cur, key[len("area_"):], start + len("area_"))


def _address_parts(cur: _Cursor, text: str, start: int) -> tuple[int, ...]:
    """The integers of a dotted address ``text`` (already matched) found at ``start``."""
    parts, at = [], start
    for part in text.split("."):
        parts.append(_whole_number(cur, part, at))
        at += len(part) + 1
    return tuple(parts)


def _where(pos: Pos) -> str:
    return f"{pos.line}:{pos.col}"


def continues_axiom(line: str) -> bool:
    """Whether an indented ``line`` under a bare ``axiom:`` is read as more of the axiom: the
    tests `_Parser._statement` makes first, in its order (a foreign word, a header key, a
    declaration, a first word close to a statement word are read as statements). A writer
    splitting a long axiom (`formats.lsys_file.axiom_lines`) keeps to lines this accepts."""
    if _FOREIGN_LINE.match(line) or _DECLARATION_LINE.match(line):
        return False
    m = _HEADER_LINE.match(line)
    if m and len(m.group(1)) > 1:
        return False
    m = _FIRST_WORD.match(line)
    word = m.group(1) if m else ""
    return not (len(word) > 2 and not _has_arrow(line) and did_you_mean(word, _STATEMENT_WORDS))


# --- expressions ---------------------------------------------------------------------

def _expression(cur: _Cursor) -> Expr:
    """A whole expression, no deeper than MAX_EXPRESSION_DEPTH (docs/errors.md, "Limits")."""
    cur.skip_ws()
    start = cur.i
    expr = _subexpression(cur)
    _check_depth(expr, cur, start)
    return expr


def _check_depth(expr: Expr, cur: _Cursor, start: int) -> None:
    if expression_depth(expr) > MAX_EXPRESSION_DEPTH:
        raise _too_deep(cur, start)


def _too_deep(cur: _Cursor, at: int) -> InputError:
    # ("nested" misled where a flat chain is long: 1+1+…+1 of 101 terms is 100 levels deep
    # in its tree; an L-system fuzzing round)
    return cur.error(f"expression too deep (more than {MAX_EXPRESSION_DEPTH} levels of "
                     "operators, parentheses and calls, each operator of a chain such as "
                     "1+1+1 one level); expected a simpler expression, with defines for its "
                     "parts", at)


def _subexpression(cur: _Cursor, min_prec: int = 0) -> Expr:
    """Precedence climbing: an operand, then binary operators binding at least min_prec."""
    plain = _PLAIN_NUMBER.match(cur.text, cur.i)
    if plain:          # most arguments of a written level are plain numbers: the same Num, fast
        value = float(plain.group(1))
        if math.isfinite(value):
            cur.i = plain.end(1)
            return Num(value, cur.pos(plain.start(1)))
    cur.nest += 1
    if cur.nest > MAX_EXPRESSION_DEPTH:
        raise _too_deep(cur, cur.i)
    try:
        left = _unary(cur)
        while True:
            tok = _token(cur)
            prec = PRECEDENCE.get(tok.text) if tok.kind == "op" else None
            if prec is None or prec < min_prec:
                return left
            cur.i = tok.end
            right = _subexpression(cur, prec if tok.text in RIGHT_ASSOCIATIVE else prec + 1)
            left = Binary(tok.text, left, right, cur.pos(tok.start))
    finally:
        cur.nest -= 1


def _unary(cur: _Cursor) -> Expr:
    tok = _token(cur)
    if tok.kind == "op" and tok.text in UNARY_OPS:
        cur.i = tok.end
        return Unary(tok.text, _subexpression(cur, UNARY_PRECEDENCE), cur.pos(tok.start))
    return _primary(cur)


def _parenthesised(cur, opened: int, what: str) -> Expr:
    """The expression after the '(' at offset ``opened``, up to its ')'."""
    cur.i = opened + 1
    inner = _subexpression(cur)
    close = _token(cur)
    if close.kind != ")":
        raise cur.error(f"expected ')' to close the {what} opened at "
                        f"{_where(cur.pos(opened))}, found {_describe(close)}", close.start)
    cur.i = close.end
    return inner



def _primary(cur: _Cursor) -> Expr:
    tok = _token(cur)
    pos = cur.pos(tok.start)
    if tok.kind == "num":
        cur.i = tok.end
        value = float(tok.text)
        if not math.isfinite(value):
            raise _error(pos, f"number '{tok.text}' is too large; expected a finite number")
        return Num(value, pos)
    if tok.kind == "badnum":
        raise _error(pos, f"bad number '{tok.text}'; expected digits with an optional "
                          "decimal point and exponent, like 2, 0.5, .5 or 2e-3")
    if tok.kind == "name":
        cur.i = tok.end
        if _token(cur).kind != "(":
            return Name(tok.text, pos)
        if tok.text not in FUNCTIONS:
            raise _error(pos, f"unknown function '{tok.text}'{did_you_mean(tok.text, FUNCTIONS)}; "
                              f"expected one of {', '.join(FUNCTIONS)}")
        opener = _token(cur)
        cur.i = opener.end
        args = _arguments(cur, opener.start)
        arity = FUNCTIONS[tok.text][1]
        if len(args) != arity:
            raise _error(pos, f"{tok.text}() takes {counted(arity, 'argument', grouped=False)}, "
                              f"got {len(args)}")
        return Call(tok.text, args, pos)
    if tok.kind == "(":
        return _parenthesised(cur, tok.start, "parenthesis")
    if tok.kind == "char" and tok.text in UNSUPPORTED_SYMBOLS:
        raise _error(pos, UNSUPPORTED_SYMBOLS[tok.text])
    raise _error(pos, f"unexpected {_describe(tok)}; expected a number, a name or '('")


def _arguments(cur: _Cursor, open_index: int) -> tuple[Expr, ...]:
    """Comma-separated expressions after an opening '(' (consumed), up to its ')'."""
    args = [_subexpression(cur)]
    while True:
        tok = _token(cur)
        if tok.kind == ",":
            cur.i = tok.end
            args.append(_subexpression(cur))
        elif tok.kind == ")":
            cur.i = tok.end
            return tuple(args)
        else:
            opened = _where(cur.pos(open_index))
            if tok.kind == "end":
                raise cur.error(f"expected ')' to close the argument list opened at {opened}", tok.start)
            raise cur.error(f"expected ',' or ')' to close the argument list opened at {opened}, "
                            f"found {_describe(tok)}", tok.start)


def _name_nodes(expr: Expr) -> Iterator[Name]:
    """Every Name node of an expression, left to right."""
    if isinstance(expr, Name):
        yield expr
    for child in _children(expr):
        yield from _name_nodes(child)


def _children(expr: Expr) -> tuple[Expr, ...]:
    if isinstance(expr, Unary):
        return (expr.operand,)
    if isinstance(expr, Binary):
        return (expr.left, expr.right)
    if isinstance(expr, Call):
        return expr.args
    return ()


def _evaluate_constant(expr: Expr, defines: dict[str, float]) -> float:
    """Evaluate an expression whose names are all defines.

    The expression layer reports division by zero and results outside the real
    numbers (0^-1, (-8)^0.5, 10^400) as InputError at the failing operator.
    """
    value = float(evaluate(expr, defines))
    if not math.isfinite(value):
        raise _error(expr.pos, "this expression is not finite; expected a finite value")
    return value


def _check_constant_parts(expr: Expr, params: frozenset[str], defines: dict[str, float]) -> None:
    """Evaluate every part of a production expression that does not read a parameter,
    so that a division by a constant zero (at its '/') or a domain error is found now."""
    if isinstance(expr, (Num, Name)):
        return                       # a number or a name cannot fail
    if not (free_names(expr) & params):
        _evaluate_constant(expr, defines)
        return
    for child in _children(expr):
        _check_constant_parts(child, params, defines)
    if isinstance(expr, Binary) and expr.op in ("/", "%") and not (free_names(expr.right) & params) \
            and _evaluate_constant(expr.right, defines) == 0:
        raise _error(expr.pos, "division by zero")


def _check_names(expr: Expr, params: frozenset[str], defines: dict[str, float], where: str) -> None:
    """Every name must be a parameter in ``params`` or a define; ``where`` says what is allowed."""
    for node in _name_nodes(expr):
        if node.name not in params and node.name not in defines:
            raise _error(node.pos, f"unknown name '{node.name}'; expected {where}")


def _constant(cur: _Cursor, defines: dict[str, float]) -> tuple[Expr, float]:
    """Parse an expression of numbers and earlier defines and evaluate it."""
    expr = _expression(cur)
    _check_names(expr, frozenset(), defines, "a number or a define given on an earlier line")
    return expr, _evaluate_constant(expr, defines)


def _check_not_negative(cur: _Cursor, key: str, value: float, at: int) -> None:
    """Lengths, radii, areas and force coefficients are amounts: refuse a negative one; a
    bend or rotation strength must be above 0 (a spring of no strength never comes back)."""
    if key in NON_NEGATIVE_KEYS and value < 0:
        raise cur.error(f"{key} must not be negative, got {format_number(value)}; "
                        "expected a number >= 0", at)
    if key in POSITIVE_KEYS and not value > 0:
        raise cur.error(f"{key} must be > 0, got {format_number(value)}; a spring of no "
                        "strength never brings its branch back", at)


# --- modules and patterns ----------------------------------------------------------

def _modules(cur: _Cursor) -> tuple[Module, ...]:
    """Modules up to the end of the line: ``F(l)[&(a0)B(l*r2,w)]A(l*r1,w)``."""
    out = []
    text, n = cur.text, len(cur.text)
    while True:
        c = cur.char()
        if not c:
            return tuple(out)
        start = cur.i
        if c == "(":
            raise cur.error("unexpected '('; a module's arguments follow its character "
                            "directly, as in F(1)")
        if c in UNSUPPORTED_SYMBOLS:
            raise cur.error(UNSUPPORTED_SYMBOLS[c])
        if c == ":" and _CPFG_PROBABILITY.fullmatch(text, cur.i):
            raise cur.error("a probability is written in parentheses after the arrow, as in "
                            "'A -> (0.3) B' (cpfg's ': 0.3' after the successor; "
                            "docs/notation.md)")
        if c in RESERVED_CHARS:
            raise cur.error(f"unexpected character '{c}'; expected a module")
        _refuse_control(cur, c, "a module")
        cur.i += 1
        args: tuple[Expr, ...] = ()
        if cur.i < n and text[cur.i] == "(":
            cur.i += 1
            args = _arguments(cur, start + 1)
            for arg in args:
                _check_depth(arg, cur, start + 2)
        out.append(Module(c, args, cur.pos(start)))


def _refuse_control(cur: "_Cursor", c: str, what: str) -> None:
    """A control character (Unicode category Cc: U+0001, DEL, ...) names no module: the tree
    files refuse it as a branch's symbol (`lsys.tree.is_symbol`), so derive wrote files that
    simulate could not read (a helper's fuzzing, session 32). Nor does an invisible format
    character (Cf: a zero-width space U+200B, a byte-order mark U+FEFF inside the text, a
    soft hyphen, a direction mark), which a copied text carries unseen: as a module it drew
    nothing and shifted every address after it (session 38). Refused here, at its place."""
    category = unicodedata.category(c)
    if category == "Cc":
        raise cur.error(f"a control character (U+{ord(c):04X}) cannot be {what}; expected a "
                        "printable character such as F")
    if category == "Cf":
        name = unicodedata.name(c, "a format character")
        raise cur.error(f"an invisible character (U+{ord(c):04X} {name}) cannot be {what}; "
                        "expected a visible character such as F (delete it: it may have come "
                        "with copied text)")


def _check_brackets(modules: tuple[Module, ...], closing: str = "on this line") -> None:
    """Brackets must balance; points at an unmatched ']' or the last unclosed '['
    (``closing``: where its ']' belongs, for the message)."""
    open_stack: list[Module] = []
    for m in modules:
        if m.name == "[":
            open_stack.append(m)
        elif m.name == "]":
            if not open_stack:
                raise _error(m.pos, "unmatched ']'; expected a '[' before it")
            open_stack.pop()
    if open_stack:
        raise _error(open_stack[-1].pos, f"'[' is never closed; expected a matching ']' {closing}")


def _patterns(cur: _Cursor) -> list[tuple[Pattern, list[tuple[str, Pos]]]]:
    """Module patterns up to '<', '>', ':', '->' or the end of the line.

    Returns each pattern with its parameter names and their positions.
    """
    out = []
    text, n = cur.text, len(cur.text)
    while True:
        c = cur.char()
        if not c or c in "<>:" or cur.arrow():
            return out
        start = cur.i
        if c in UNSUPPORTED_SYMBOLS:
            raise cur.error(UNSUPPORTED_SYMBOLS[c])
        if c in RESERVED_CHARS:
            raise cur.error(f"unexpected character '{c}'; expected a module pattern, "
                            "'<', '>', ':' or '->'")
        _refuse_control(cur, c, "a module pattern")
        if c in STRUCTURE_SYMBOLS:
            raise cur.error(f"'{c}' cannot be a predecessor or a context pattern; "
                            "expected a module such as A or A(x)")
        cur.i += 1
        params: list[tuple[str, Pos]] = []
        if cur.i < n and text[cur.i] == "(":
            opened = cur.pos()
            cur.i += 1
            while True:
                tok = _token(cur)
                if tok.kind != "name":
                    raise cur.error(f"expected a parameter name, found {_describe(tok)} "
                                    "(a pattern binds names, it does not match values)", tok.start)
                cur.i = tok.end
                for seen, _ in params:
                    if seen == tok.text:
                        raise cur.error(f"duplicate parameter '{tok.text}' in the pattern "
                                        f"'{c}'; expected distinct names", tok.start)
                params.append((tok.text, cur.pos(tok.start)))
                tok = _token(cur)
                cur.i = tok.end
                if tok.kind == ")":
                    break
                if tok.kind != ",":
                    what = "found end of line" if tok.kind == "end" else f"found {_describe(tok)}"
                    raise cur.error(f"expected ',' or ')' to close the parameter list opened at "
                                    f"{_where(opened)}, {what}", tok.start)
        out.append((Pattern(c, tuple(p for p, _ in params), cur.pos(start)), params))


def _production(cur: _Cursor, defines: dict[str, float]) -> Production:
    """``[LEFT <] PRED [> RIGHT] [: CONDITION] -> [(PROBABILITY)] SUCCESSOR``."""
    cur.skip_ws()
    start = cur.pos()
    first = _patterns(cur)
    left: list = []
    if cur.char() == "<":
        if not first:
            raise cur.error("expected a left context before '<'")
        left = first
        cur.i += 1
        preds = _patterns(cur)
    else:
        preds = first
    if not preds:
        raise cur.error(f"expected a predecessor module, found {cur.describe()}")
    if len(preds) > 1:
        raise _error(preds[1][0].pos, f"expected '<', '>', ':' or '->' after the predecessor "
                                      f"'{preds[0][0].name}'; a production rewrites one module")
    right: list = []
    if cur.char() == ">":
        cur.i += 1
        right = _patterns(cur)
        if not right:
            raise cur.error(f"expected a right context after '>', found {cur.describe()}")
    bound: dict[str, Pos] = {}
    for _, params in left + preds + right:
        for name, pos in params:
            if name in bound:
                raise _error(pos, f"parameter '{name}' is already bound at {_where(bound[name])}; "
                                  "expected distinct names in one production")
            bound[name] = pos
    params_set = frozenset(bound)
    where = (f"a parameter of this production ({', '.join(bound)}) or a define"
             if bound else "a define (this production has no parameters)")

    condition = None
    if cur.char() == ":":
        cur.i += 1
        if cur.char() == "*":
            cur.i += 1
            if not (cur.arrow() or not cur.char()):
                raise cur.error(f"expected '->' after the condition '*', found {cur.describe()}")
        else:
            if cur.arrow() or not cur.char():
                raise cur.error("expected a condition or '*' after ':'")
            condition = _expression(cur)
            _check_names(condition, params_set, defines, where)
            _check_constant_parts(condition, params_set, defines)
    arrow = cur.arrow()
    if not arrow:
        expected = "'>', ':' or '->'" if not right and condition is None else "'->'"
        raise cur.error(f"expected {expected}, found {cur.describe()}")
    cur.i += arrow

    probability = None
    if cur.char() == "(":
        opened = cur.i
        probability = _parenthesised(cur, opened, "probability")
        _check_depth(probability, cur, opened + 1)
        for node in _name_nodes(probability):
            if node.name in params_set:
                raise _error(node.pos, f"a probability must be constant; '{node.name}' is a "
                                       "parameter, expected numbers and defines")
        _check_names(probability, frozenset(), defines, "a number or a define")
        if _evaluate_constant(probability, defines) < 0:
            raise _error(probability.pos, "a probability must not be negative")
    successor = _modules(cur)
    _check_brackets(successor)
    for module in successor:
        for arg in module.args:
            _check_names(arg, params_set, defines, where)
            _check_constant_parts(arg, params_set, defines)
    return Production(
        pred=preds[0][0], successor=successor,
        left=tuple(p for p, _ in left), right=tuple(p for p, _ in right),
        condition=condition, probability=probability, pos=start,
    )


# --- whole files ---------------------------------------------------------------------

class _FileParser:
    """Reads one file statement by statement, then runs the whole-file checks."""

    def __init__(self, text: str, source: str):
        self.text, self.source = text, source
        self.header: dict[str, tuple[object, Pos]] = {}
        self.defines: dict[str, float] = {}
        self.define_pos: dict[str, Pos] = {}
        self.branches: list[BranchSymbol] = []
        self.leaves: list[LeafSymbol] = []
        self.declared: dict[str, Pos] = {}
        self.axiom: tuple[Module, ...] | None = None
        self.axiom_pos: Pos | None = None
        self.rules: dict[str, list[Production]] = {"productions": [], "interpretation": []}
        self.overrides: list[Override] = []
        self.override_pos: dict[tuple[int, ...], Pos] = {}
        self.groups: list[tuple[tuple[int, ...], str]] = []
        self.group_pos: dict[tuple[int, ...], Pos] = {}
        self.axiom_lines: list[Module] | None = None     # an axiom given on indented lines
        self.section: str | None = None
        self.preprocessor_warned = False

    def run(self) -> LSystem:
        for number, raw in enumerate(LINE_BREAK.split(self.text), start=1):
            if len(raw) > MAX_LINE_CHARS:
                raise _error(Pos(self.source, number, MAX_LINE_CHARS + 1),
                             f"line longer than {MAX_LINE_CHARS:,} characters; expected "
                             "shorter lines (split a long axiom with productions)")
            if "#" in raw:
                self._preprocessor(raw, number)
            line = raw.split("#", 1)[0].rstrip()
            if not line:
                continue
            cur = _Cursor(line, self.source, number)
            try:
                self._statement(cur)
            except RecursionError:
                raise cur.error("expression nested too deeply") from None
        return self._finish()

    def _preprocessor(self, raw: str, number: int) -> None:
        """cpfg's C preprocessor lines (``#define c 1``) are comments here: said once."""
        m = _PREPROCESSOR.match(raw)
        if m and not self.preprocessor_warned:
            self.preprocessor_warned = True
            import warnings

            warnings.warn(f"{self.source}:{number}: '#{m.group(1)}' (cpfg's C preprocessor) is "
                          "read as a comment here; a constant is 'define NAME = VALUE'",
                          PlantlodWarning, stacklevel=4)

    # statements

    def _statement(self, cur: _Cursor) -> None:
        line = cur.text
        if not _has_arrow(line):
            foreign = _FOREIGN_LINE.match(line)
            if foreign:
                cur.i = foreign.start(1)
                raise cur.error(FOREIGN_WORDS[foreign.group(1)])
            wrong = _WRONG_ARROW.match(line)
            if wrong and not _HEADER_LINE.match(line):
                cur.i = wrong.start(1)
                raise cur.error(f"'{wrong.group(1)}' is not a production arrow; expected "
                                f"'{ARROWS[1]}' (or '{ARROWS[0]}', '{ARROWS[2]}')")
            assignment = None if _ABOP_CAPTION.match(line) else _ASSIGNMENT.match(line)
            if assignment and assignment.group(1) in HEADER_KEYS:
                cur.i = assignment.start(1)
                value = line[assignment.end():].strip() or "VALUE"
                raise cur.error(f"a header key takes ':'; expected "
                                f"'{assignment.group(1)}: {value}'")
            if assignment and assignment.group(1) not in _STATEMENT_WORDS:
                cur.i = assignment.start(1)
                name = assignment.group(1)
                value = line[assignment.end():].strip() or "VALUE"
                raise cur.error(f"'{name} = ...' looks like an L-Py or cpfg assignment; a "
                                f"constant is 'define {name} = {value}'")
        m = _HEADER_LINE.match(line)
        if m and len(m.group(1)) > 1:
            word = m.group(1)
            cur.i = m.start(1)
            after = m.end()
            if word == "axiom":
                self.section = None
                if not line[after:].strip() and self.axiom is None and self.axiom_lines is None:
                    # `axiom:` alone: the modules follow on indented lines (long axioms)
                    self.axiom_pos = cur.pos()
                    self.axiom_lines = []
                    self.section = "axiom"
                    return None
                return self._axiom(cur, after)
            if word in SECTIONS:
                return self._section_start(cur, word, after)
            if word in HEADER_KEYS:
                self.section = None
                return self._header(cur, word, after)
            if word in _DECLARATIONS:
                raise cur.error(f"'{word}' is not a header key; expected '{word} ' followed by "
                                f"{'a name' if word == 'define' else 'a symbol'}")
            if _has_arrow(line[after:]):
                raise cur.error(f"'{word}:' before a production looks like ABOP's production "
                                "label; expected the production alone (delete the label)")
            raise cur.error(f"unknown header key '{word}'"
                            f"{did_you_mean(word, HEADER_KEYS + ('axiom',) + SECTIONS)}; "
                            f"expected one of {', '.join(HEADER_KEYS)}")
        m = _DECLARATION_LINE.match(line)
        if m:
            self.section = None
            cur.i = m.end()
            if m.group(1) == "define":
                return self._define(cur)
            return self._declaration(cur, m.group(1))
        m = _FIRST_WORD.match(line)
        word = m.group(1) if m else ""
        hint = did_you_mean(word, _STATEMENT_WORDS) if len(word) > 2 and not _has_arrow(line) else ""
        if self.section is not None and not hint:
            if self.section == "overrides":
                return self._override(cur)
            if self.section == "groups":
                return self._group(cur)
            if self.section == "axiom":
                if not cur.text[:1].isspace():
                    raise cur.error("an axiom continued on the next lines is indented; expected "
                                    "'  MODULES' under 'axiom:'")
                cur.skip_ws()
                self.axiom_lines.extend(_modules(cur))
                return None
            self.rules[self.section].append(_production(cur, self.defines))
            return None
        cur.skip_ws()
        if _has_arrow(line):
            raise cur.error("production outside a section; expected a 'productions:' or "
                            "'interpretation:' line before it")
        after = m.end(1) if m else 0
        nxt = line[after:after + 1]
        if word and nxt and not (nxt.isascii() and nxt.isprintable()):   # 'béranching_angle'
            raise cur.error(f"unexpected {nxt!r} in a name; expected ASCII letters, digits "
                            "and '_'", after)
        if word in _DECLARATIONS:                       # 'define^ x = 1'
            raise cur.error(f"unexpected {nxt!r} after '{word}'; expected '{word} NAME ...' "
                            f"with a space after '{word}'", after)
        if word in _STATEMENT_WORDS:                    # 'force_propagated 0.7'
            raise cur.error(f"expected ':' after '{word}'", after)
        if len(word) > 1:                               # a misspelled statement keyword
            raise cur.error(f"unknown statement '{word}'{hint}; expected {_STATEMENTS_HELP}")
        abop = _ABOP_CAPTION.match(line)
        if abop:
            raise cur.error(f"'{abop.group(1)}' is how ABOP's captions write it; expected "
                            f"'{_ABOP_KEYS[abop.group(1)]}'")
        raise cur.error(f"unexpected {cur.describe()} outside a section; expected {_STATEMENTS_HELP}")

    def _expect_end(self, cur: _Cursor, what: str) -> None:
        if cur.char():
            raise cur.error(f"unexpected {cur.describe()} after {what}; expected end of line")

    def _header(self, cur: _Cursor, key: str, after: int) -> None:
        key_pos = cur.pos()
        if key in self.header:
            raise cur.error(f"duplicate header key '{key}' (first given at "
                            f"{_where(self.header[key][1])}); expected each key at most once")
        cur.i = after
        if key == "name":
            value: object = cur.text[after:].strip()
        elif key == "ignore":
            value = self._ignore_list(cur)
        else:
            cur.skip_ws()
            value_start = cur.i
            if not cur.char():
                raise cur.error(f"expected a value after '{key}:'")
            literal = re.fullmatch(r"[0-9]+", cur.text[value_start:].strip())
            if key in _INTEGER_KEYS and literal:
                value = _whole_number(cur, literal.group(), value_start)   # exact, however large
                cur.i = len(cur.text)
            else:
                _, value = _constant(cur, self.defines)
                self._expect_end(cur, f"the value of '{key}'")
                _check_not_negative(cur, key, value, value_start)
                if key in _INTEGER_KEYS:
                    if not float(value).is_integer() or value < 0:
                        raise cur.error(f"{key} must be a non-negative integer, got "
                                        f"{format_number(value)}", value_start)
                    value = int(value)
        past = steps_past_limit(value) if key == "derivation_length" else None
        if past:                                    # (at its value: derive would say no line)
            raise cur.error(past, value_start)
        self.header[key] = (value, key_pos)

    def _ignore_list(self, cur: _Cursor) -> tuple[str, ...]:
        symbols: list[str] = []
        while c := cur.char():
            if c in RESERVED_CHARS:
                raise cur.error(f"unexpected character '{c}'; expected symbols separated by spaces")
            _refuse_control(cur, c, "a symbol")
            if c in BRACKETS:
                raise cur.error(f"'{c}' cannot be ignored: brackets give context its structure; "
                                "expected other symbols")
            if c in symbols:
                raise cur.error(f"'{c}' is listed twice; expected each symbol once")
            symbols.append(c)
            cur.i += 1
        return tuple(symbols)

    def _define(self, cur: _Cursor) -> None:
        tok = _token(cur)
        if tok.kind != "name":
            raise cur.error(f"expected a name after 'define', found {_describe(tok)}", tok.start)
        name = tok.text
        if name in self.defines:
            raise cur.error(f"'{name}' is already defined at {_where(self.define_pos[name])}; "
                            "expected a new name", tok.start)
        cur.i = tok.end
        eq = _token(cur)
        if eq.text != "=" or eq.kind != "char":
            raise cur.error(f"expected '=' after 'define {name}', found {_describe(eq)}", eq.start)
        cur.i = eq.end
        if not cur.char():
            raise cur.error(f"expected a value after 'define {name} ='")
        _, value = _constant(cur, self.defines)
        self._expect_end(cur, f"the value of '{name}'")
        self.defines[name] = value
        self.define_pos[name] = cur.pos(tok.start)

    def _declaration(self, cur: _Cursor, kind: str) -> None:
        """``branch S: key=EXPR ...`` or ``leaf S: area=EXPR``."""
        c = cur.char()
        example = "branch F: length=1 ..." if kind == "branch" else "leaf L: area=0.01"
        if not c:
            raise cur.error(f"expected a symbol after '{kind}', as in '{example}'")
        sym_i = cur.i
        if c in RESERVED_CHARS:
            raise cur.error(f"unknown symbol in a declaration: '{c}' is reserved; expected one "
                            f"character such as F, as in '{example}'")
        _refuse_control(cur, c, "a symbol")
        if c in TURTLE_SYMBOLS:
            raise cur.error(f"unknown symbol in a declaration: '{c}' is a turtle symbol; "
                            f"expected a symbol of your own, as in '{example}'")
        cur.i += 1
        glued = cur.i < len(cur.text) and not cur.text[cur.i].isspace()   # (FG: two characters)
        nxt = cur.char()
        if nxt != ":":
            if glued and nxt not in RESERVED_CHARS:
                raise cur.error(f"unknown symbol in a declaration: a symbol is one character; "
                                f"expected ':' after '{c}'")
            raise cur.error(f"expected ':' after '{kind} {c}', found {cur.describe()}")
        if c in self.declared:
            raise cur.error(f"'{c}' is already declared at {_where(self.declared[c])}; expected "
                            "each symbol declared once", sym_i)
        cur.i += 1
        keys = BRANCH_KEYS if kind == "branch" else LEAF_KEYS
        values = self._key_values(cur, keys, f"a {kind} declaration")
        for key, required in keys.items():
            if required and key not in values:
                raise cur.error(f"{kind} '{c}' lacks the required key '{key}'; expected "
                                f"{' '.join(k + '=...' for k, r in keys.items() if r)}", sym_i)
        pos = cur.pos(sym_i)
        if kind == "branch":
            self.branches.append(BranchSymbol(c, **values, pos=pos))
        else:
            self.leaves.append(LeafSymbol(c, **values, pos=pos))
        self.declared[c] = pos

    def _key_values(self, cur: _Cursor, keys: dict[str, bool], what: str,
                    pattern: re.Pattern | None = None) -> dict[str, float]:
        """``key=EXPR key=EXPR ...`` to the end of the line; keys from ``keys`` or matching ``pattern``."""
        plain = self._plain_key_values(cur, keys, pattern)
        if plain is not None:
            return plain
        out: dict[str, float] = {}
        while True:
            tok = _token(cur)
            if tok.kind == "end":
                return out
            if tok.kind != "name":
                raise cur.error(f"expected key=value, found {_describe(tok)}", tok.start)
            if tok.text not in keys and not (pattern and pattern.fullmatch(tok.text)):
                raise cur.error(f"unknown key '{tok.text}' in {what}{did_you_mean(tok.text, keys)}; "
                                f"expected one of {', '.join(keys)}"
                                f"{' or area_K (K = 0, 1, ...)' if pattern else ''}", tok.start)
            if pattern and pattern.fullmatch(tok.text):
                _leaf_ordinal(cur, tok.text, tok.start)
            if tok.text in out:
                raise cur.error(f"duplicate key '{tok.text}' in {what}; expected each key once",
                                tok.start)
            cur.i = tok.end
            eq = _token(cur)
            if eq.text != "=" or eq.kind != "char":
                raise cur.error(f"expected '=' after '{tok.text}', found {_describe(eq)}", eq.start)
            cur.i = eq.end
            value = _token(cur)
            if value.kind == "end":
                raise cur.error(f"expected a value after '{tok.text}='")
            if value.text in ('"', "'"):            # (explained as cpfg's length multiplier)
                raise cur.error(f"expected a number after '{tok.text}=', found a quote mark "
                                f"({value.text}): values are numbers or expressions, written "
                                "without quotes",
                                value.start)
            if value.kind == "name" and (value.text in keys or (pattern and pattern.fullmatch(
                    value.text))) and cur.text[value.end:].lstrip().startswith("="):
                raise cur.error(f"expected a value after '{tok.text}=', found the next key "
                                f"'{value.text}'", value.start)   # (not "unknown name")
            value_start = value.start
            out[tok.text] = _constant(cur, self.defines)[1]
            key = "area" if pattern and pattern.fullmatch(tok.text) else tok.text
            _check_not_negative(cur, key, out[tok.text], value_start)

    def _plain_key_values(self, cur: _Cursor, keys: dict[str, bool],
                          pattern: re.Pattern | None) -> dict[str, float] | None:
        """`_key_values` of a line that is only ``key=NUMBER`` pairs (signed numbers, known
        keys, each once, finite), read with one regular expression a pair; None for any other
        line, which the expression parser then reads (and reports, where it is wrong)."""
        text, i = cur.text, cur.i
        out: dict[str, float] = {}
        found = []
        while True:
            m = _KEY_NUMBER.match(text, i)
            if m is None:
                break
            key = m.group(1)
            if key in out or not (key in keys or (pattern and pattern.fullmatch(key))):
                return None
            value = float(m.group(2))
            if not math.isfinite(value):
                return None
            if pattern and pattern.fullmatch(key):
                _leaf_ordinal(cur, key, m.start(1))
            out[key] = value
            found.append((key, value, m.start(2)))
            i = m.end()
        if not found or text[i:].strip():
            return None
        for key, value, at in found:
            _check_not_negative(cur, "area" if pattern and pattern.fullmatch(key) else key,
                                value, at)
        cur.i = i
        _token(cur)                     # at the end of the line, as the expression parser leaves it
        return out

    def _axiom(self, cur: _Cursor, after: int) -> None:
        if self.axiom is not None or self.axiom_lines is not None:
            raise cur.error(f"duplicate 'axiom:' (first given at {_where(self.axiom_pos)}); "
                            "expected one axiom")
        self.axiom_pos = cur.pos()
        cur.i = after
        self._set_axiom(cur, _modules(cur))

    def _set_axiom(self, cur: _Cursor, modules: tuple[Module, ...]) -> None:
        if not modules:
            raise cur.error("the axiom is empty; expected at least one module")
        _check_brackets(modules, "in the axiom")      # (which may run on over indented lines)
        for module in modules:
            for arg in module.args:
                _check_names(arg, frozenset(), self.defines,
                             "a number or a define given on an earlier line (the axiom has no parameters)")
                _evaluate_constant(arg, self.defines)
        self.axiom = modules

    def _section_start(self, cur: _Cursor, word: str, after: int) -> None:
        cur.i = after
        if cur.char():
            raise cur.error(f"unexpected {cur.describe()} after '{word}:'; expected end of line "
                            f"(the {word} go on the following lines)")
        self.section = word

    def _override(self, cur: _Cursor) -> None:
        """``ADDRESS: key=EXPR ...``."""
        cur.skip_ws()
        start = cur.i
        colon = cur.text.find(":", start)
        if colon < 0:
            raise cur.error("expected 'ADDRESS: key=value ...' in the overrides section, "
                            "as in '0.1.0: length=2'")
        text = cur.text[start:colon].rstrip()
        if not _ADDRESS.fullmatch(text):
            raise cur.error(f"override address '{text}' is not valid; expected dotted "
                            "non-negative integers such as 0.1.0")
        address = _address_parts(cur, text, start)
        pos = cur.pos()
        if address in self.override_pos:
            raise cur.error(f"address {text} is overridden twice (first at "
                            f"{_where(self.override_pos[address])}); expected one line per address")
        cur.i = colon + 1
        values = self._key_values(cur, OVERRIDE_KEYS, "an override (branch keys, area, area_K)",
                                  LEAF_ORDINAL_KEY)
        if not values:
            raise cur.error(f"expected key=value after '{text}:'")
        gains = [k for k in GAIN_KEYS if k in values]
        if gains and len(gains) < len(GAIN_KEYS):
            missing = ", ".join(k for k in GAIN_KEYS if k not in values)
            raise cur.error(f"a gain matrix needs all six keys {' '.join(GAIN_KEYS)}; "
                            f"'{text}:' lacks {missing}", start)
        if gains and "force_absorbed" in values:
            raise cur.error(f"'{text}:' sets both a gain matrix and force_absorbed; expected one "
                            "of them (the gain matrix replaces k_FA)", start)
        self.overrides.append(Override(address, tuple(sorted(values.items())), pos))
        self.override_pos[address] = pos

    def _group(self, cur: _Cursor) -> None:
        """``ADDRESS: ORIGINAL_ADDRESS``: the branch drawn at ADDRESS stands for the group
        of the original's branches rooted at ORIGINAL_ADDRESS (model.md 5, explicit form)."""
        cur.skip_ws()
        line = cur.text[cur.i:].split("#", 1)[0]
        left, colon, right = line.partition(":")
        left, right = left.strip(), right.strip()
        # (as derive writes them, `tree.LEAF_ADDRESS` and `tree.BRANCH_ADDRESS`: the root is
        # matched to the original's addresses as text, so "00.1" named no branch, and a key
        # "01" was taken as 1, session 37)
        if not colon or not LEAF_ADDRESS.match(left) or not BRANCH_ADDRESS.match(right):
            raise cur.error("expected 'ADDRESS: ORIGINAL_ADDRESS' in the groups section, as in "
                            "'12: 0.4.0.1' (dotted non-negative integers without leading zeros; "
                            "the original's may end in ':K', the K-th branch drawn at one "
                            "address)")
        address = _address_parts(cur, left, cur.i + len(line) - len(line.lstrip()))
        pos = cur.pos()
        if address in self.group_pos:
            raise cur.error(f"address {left} has two groups (first at "
                            f"{_where(self.group_pos[address])}); expected one line per address")
        self.groups.append((address, right))
        self.group_pos[address] = pos
        cur.i = len(cur.text)

    # whole-file checks

    def _finish(self) -> LSystem:
        start = Pos(self.source, 1, 1)
        if self.axiom_lines is not None:
            pos = self.axiom_pos
            self._set_axiom(_Cursor("axiom:", self.source, pos.line, start=len("axiom:")),
                            tuple(self.axiom_lines))
        for key in REQUIRED_HEADER_KEYS:
            if key not in self.header:
                raise _error(start, f"missing required header key '{key}'; expected a line "
                                    f"'{key}: VALUE'")
        if self.axiom is None:
            raise _error(start, "missing 'axiom:'; expected a line 'axiom: MODULES'")
        values = {key: value for key, (value, _) in self.header.items()}
        values.setdefault("rotation_angle", values["branching_angle"])
        system = LSystem(
            axiom=self.axiom,
            productions=tuple(self.rules["productions"]),
            interpretation=tuple(self.rules["interpretation"]),
            branches=tuple(self.branches), leaves=tuple(self.leaves),
            defines=tuple(self.defines.items()), overrides=tuple(self.overrides),
            groups=tuple(self.groups), source=self.source,
            group_lines=tuple(self.group_pos[a].line or 0 for a, _root in self.groups), **values,
        )
        errors = list(_whole_file_errors(system))
        if errors:
            raise min(errors, key=lambda e: (e.line, e.col))
        _warn_undrawn_modules(system)
        return system


# Modules another L-system dialect draws with, which here draw nothing unless declared (or
# interpreted): what each is there, and what to write here. Said once each, at its first place.
_UNDRAWN = {
    "_": ("(L-Py: set the width) is an ordinary module here that draws nothing; a branch's "
          "radius is its 'radius=' or !(r)"),
    "F": ("(ABOP: draw a segment) is not declared, so here it draws nothing; declare it, "
          "e.g. 'branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20'"),
}


def _warn_undrawn_modules(system: LSystem) -> None:
    """`_UNDRAWN`: L-Py's ``_(w)`` sets the width and ABOP's ``F`` draws a segment; here
    each is an ordinary module that draws nothing unless declared (a branch or a leaf) or
    given an interpretation rule: said once each, at its first place."""
    import warnings

    interpreted = {rule.pred.name for rule in system.interpretation}
    quiet = {name for name in _UNDRAWN
             if system.branch_symbol(name) is not None or name in interpreted
             or any(leaf.name == name for leaf in system.leaves)}
    if not system.branches:
        quiet.add("F")          # (build says no branch symbol is declared at all, and how)
    rules = system.productions + system.interpretation
    for module in system.axiom + tuple(m for rule in rules for m in rule.successor):
        if module.name in _UNDRAWN and module.name not in quiet:
            quiet.add(module.name)
            where = ":".join(str(p) for p in (module.pos.file or system.source, module.pos.line,
                                               module.pos.col) if p is not None)
            warnings.warn(f"{where}: '{module.name}' {_UNDRAWN[module.name]}",
                          PlantlodWarning, stacklevel=4)


def _stochastic_errors(rules: tuple[Production, ...], defines: dict[str, float]) -> Iterator[InputError]:
    """Groups that do not sum to 1, and left sides with and without probabilities."""
    first: dict[tuple, Production] = {}
    groups: dict[tuple, list[Production]] = {}
    for rule in rules:
        key = (rule.pred, rule.left, rule.right, rule.condition)
        earlier = first.setdefault(key, rule)
        if (earlier.probability is None) != (rule.probability is None):
            has, other = (("has no probability", "has one") if rule.probability is None
                          else ("has a probability", "has none"))
            yield _error(rule.pos, f"this production {has} but the one with the same left side at "
                                   f"{_where(earlier.pos)} {other}; expected every alternative "
                                   "of a stochastic group to have a probability")
        elif rule.probability is not None:
            groups.setdefault(key, []).append(rule)
    for members in groups.values():
        total = math.fsum(_evaluate_constant(m.probability, defines) for m in members)
        if abs(total - 1.0) > PROBABILITY_SUM_TOL:
            yield _error(members[0].pos, f"the probabilities of this stochastic group "
                                         f"({len(members)} alternatives) sum to {total!r}; "
                                         f"expected 1 (within {PROBABILITY_SUM_TOL:g})")


def _turtle_count_error(item: Module | Pattern, count: int, branches: set[str],
                        leaves: set[str]) -> InputError | None:
    """The parameter counts the turtle accepts for fixed and declared symbols."""
    name = item.name
    if name in TURTLE_NO_ARG and count:
        return _error(item.pos, f"'{name}' takes no parameters, got {count}")
    if count > 1:
        if name in TURTLE_OPTIONAL_ARG:
            return _error(item.pos, f"'{name}' takes 0 or 1 parameters, got {count}")
        if name in branches:
            return _error(item.pos, f"'{name}' is a branch symbol and takes 0 or 1 parameters "
                                    f"(its length), got {count}")
        if name in leaves:
            return _error(item.pos, f"'{name}' is a leaf symbol and takes 0 or 1 parameters "
                                    f"(its area), got {count}")
    return None


def _rule_counts(rules: tuple[Production, ...]) -> dict[str, tuple[set[int], Production]]:
    """Character -> (parameter counts its rules accept, its first rule)."""
    out: dict[str, tuple[set[int], Production]] = {}
    for rule in rules:
        out.setdefault(rule.pred.name, (set(), rule))[0].add(len(rule.pred.params))
    return out


def _count_error(module: Module, counts: dict[str, tuple[set[int], Production]],
                 what: str) -> InputError | None:
    entry = counts.get(module.name)
    if entry is None or len(module.args) in entry[0]:
        return None
    accepted = " or ".join(str(n) for n in sorted(entry[0]))
    return _error(module.pos, f"'{module.name}' has "
                              f"{counted(len(module.args), 'parameter', grouped=False)} here, "
                              f"but the {what} for '{module.name}' (first at "
                              f"{_where(entry[1].pos)}) take {accepted}; expected {accepted}")


def _whole_file_errors(system: LSystem) -> Iterator[InputError]:
    """Checks that need the whole file: parameter counts and stochastic groups.

    Parameter counts: every module and pattern obeys the turtle's counts; every
    module of the axiom and of a production's successor matches some production
    for its character (if it has any) and some interpretation rule for its
    character (if it has any: these modules make up the final string).
    """
    defines = system.constants()
    branches = {b.name for b in system.branches}
    leaves = {leaf.name for leaf in system.leaves}
    yield from _stochastic_errors(system.productions, defines)
    yield from _stochastic_errors(system.interpretation, defines)
    production_counts = _rule_counts(system.productions)
    interpretation_counts = _rule_counts(system.interpretation)
    final_string_sources = [system.axiom] + [p.successor for p in system.productions]
    for modules in final_string_sources:
        for module in modules:
            yield from filter(None, (
                _count_error(module, production_counts, "productions"),
                _count_error(module, interpretation_counts, "interpretation rules"),
            ))
    everything: list[Module | Pattern] = list(system.axiom)
    for rule in system.productions + system.interpretation:
        everything += [*rule.left, rule.pred, *rule.right, *rule.successor]
    for item in everything:
        count = len(item.args) if isinstance(item, Module) else len(item.params)
        error = _turtle_count_error(item, count, branches, leaves)
        if error is not None:
            yield error


# --- public API -------------------------------------------------------------------

def parse_lsys(text: str, source: str = "<string>") -> LSystem:
    """Parse a whole ``.lsys`` file; every error is an `InputError` at file:line:col."""
    return _FileParser(text, source).run()


def parse_expr(text: str, source: str = "<string>", line: int = 1, col: int = 1) -> Expr:
    """Parse one expression (syntax, function names and argument counts only; names are
    not checked). ``line`` and ``col`` are the position of ``text[0]`` in its file."""
    cur = _Cursor(text, source, line, col)
    try:
        expr = _expression(cur)
    except RecursionError:
        raise cur.error("expression nested too deeply", 0) from None
    tok = _token(cur)
    if tok.kind != "end":
        raise cur.error(f"unexpected {_describe(tok)} after the expression; expected an "
                        "operator or the end", tok.start)
    return expr


def parse_modules(text: str, source: str = "<string>", line: int = 1, col: int = 1) -> tuple[Module, ...]:
    """Parse a module sequence such as ``F(l)[+A(l/2)]`` (syntax and brackets only)."""
    cur = _Cursor(text, source, line, col)
    try:
        modules = _modules(cur)
    except RecursionError:
        raise cur.error("expression nested too deeply", 0) from None
    _check_brackets(modules)
    return modules
