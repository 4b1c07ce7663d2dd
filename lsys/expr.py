"""Arithmetic expressions of the .lsys language: the syntax tree and a safe compiler.

Expressions never reach Python's ``eval``: the parser (``lsys.parse``) builds the
node classes below, and `compile_expr` turns a tree of nodes into a closure made
only of the operator and function tables defined here. A compiled expression
accepts floats or numpy arrays for its variables, so the derivation engine can
evaluate one production for many modules at once.

Semantics: every value is a float; comparisons and boolean operators give 1.0
or 0.0, and any non-zero value is true. ``^`` is power. Trigonometric
functions take radians. Division by zero raises `InputError` at the
expression's position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping, Union

import numpy as np

from .errors import InputError


@dataclass(frozen=True)
class Pos:
    """A source position: file name, 1-based line and column."""

    file: str | None = None
    line: int | None = None
    col: int | None = None


_NOPOS = Pos()


@dataclass(frozen=True)
class Num:
    value: float
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Name:
    name: str
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Unary:
    op: str            # one of UNARY_OPS
    operand: "Expr"
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Binary:
    op: str            # one of BINARY_OPS
    left: "Expr"
    right: "Expr"
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


@dataclass(frozen=True)
class Call:
    func: str          # one of FUNCTIONS
    args: tuple["Expr", ...]
    pos: Pos = field(default=_NOPOS, compare=False, repr=False)


Expr = Union[Num, Name, Unary, Binary, Call]

# Binding strength, loosest first; the parser and the writer both use it.
PRECEDENCE = {
    "||": 1,
    "&&": 2,
    "==": 3, "!=": 3,
    "<": 4, "<=": 4, ">": 4, ">=": 4,
    "+": 5, "-": 5,
    "*": 6, "/": 6, "%": 6,
    # unary minus / not bind at 7
    "^": 8,   # right-associative, binds tighter than unary minus: -2^2 = -4
}
UNARY_PRECEDENCE = 7
RIGHT_ASSOCIATIVE = {"^"}


def _truth(x):
    return np.where(x != 0, 1.0, 0.0) if isinstance(x, np.ndarray) else (1.0 if x != 0 else 0.0)


def _as_float(x):
    return x.astype(float) if isinstance(x, np.ndarray) else float(x)


BINARY_OPS: dict[str, Callable] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": lambda a, b: a / b,          # zero divisors are checked before the call
    "%": lambda a, b: np.fmod(a, b) if isinstance(a, np.ndarray) or isinstance(b, np.ndarray) else math.fmod(a, b),
    "^": lambda a, b: np.power(a, b) if isinstance(a, np.ndarray) or isinstance(b, np.ndarray) else math.pow(a, b),
    "<": lambda a, b: _as_float(a < b),
    "<=": lambda a, b: _as_float(a <= b),
    ">": lambda a, b: _as_float(a > b),
    ">=": lambda a, b: _as_float(a >= b),
    "==": lambda a, b: _as_float(a == b),
    "!=": lambda a, b: _as_float(a != b),
    "&&": lambda a, b: _truth(a) * _truth(b),
    "||": lambda a, b: _truth(_truth(a) + _truth(b)),
}

UNARY_OPS: dict[str, Callable] = {
    "-": lambda a: -a,
    "+": lambda a: a,
    "!": lambda a: 1.0 - _truth(a),
}

# name -> (numpy function, number of arguments)
FUNCTIONS: dict[str, tuple[Callable, int]] = {
    "abs": (np.abs, 1), "sqrt": (np.sqrt, 1), "exp": (np.exp, 1), "log": (np.log, 1),
    "sin": (np.sin, 1), "cos": (np.cos, 1), "tan": (np.tan, 1),
    "asin": (np.arcsin, 1), "acos": (np.arccos, 1), "atan": (np.arctan, 1),
    "atan2": (np.arctan2, 2), "floor": (np.floor, 1), "ceil": (np.ceil, 1),
    "min": (np.minimum, 2), "max": (np.maximum, 2), "pow": (np.power, 2),
}

Compiled = Callable[[Mapping[str, object]], object]


def _err(pos: Pos, message: str) -> InputError:
    return InputError(message, pos.file, pos.line, pos.col)


def _scalarise(value):
    """Return a plain float for 0-d results, arrays unchanged."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return float(value)
    if isinstance(value, np.generic):
        return float(value)
    return value


def _checked(fn, pos: Pos, op: str, a, b):
    """Apply a binary operator whose result may leave the real numbers or overflow."""
    try:
        with np.errstate(all="ignore"):
            out = fn(a, b)
    except (ValueError, OverflowError, ZeroDivisionError):
        out = float("nan")
    if not np.all(np.isfinite(out)):
        raise _err(pos, f"'{op}' gives a result that is not a finite real number")
    return out


def compile_expr(expr: Expr) -> Compiled:
    """Compile an expression tree into ``f(env) -> float | ndarray``.

    ``env`` maps every free name to a float or to a numpy array (all arrays of
    one shape). Unknown names raise `InputError` at the name's position;
    callers check names statically with `free_names` first where they can.
    """
    if isinstance(expr, Num):
        v = float(expr.value)
        return lambda env: v
    if isinstance(expr, Name):
        name, pos = expr.name, expr.pos

        def load(env):
            try:
                return env[name]
            except KeyError:
                raise _err(pos, f"unknown name '{name}'") from None
        return load
    if isinstance(expr, Unary):
        fn, inner = UNARY_OPS[expr.op], compile_expr(expr.operand)
        return lambda env: fn(inner(env))
    if isinstance(expr, Binary):
        left, right = compile_expr(expr.left), compile_expr(expr.right)
        fn, op, pos = BINARY_OPS[expr.op], expr.op, expr.pos
        if op in ("/", "%"):
            def divide(env):
                a, b = left(env), right(env)
                if np.any(np.asarray(b) == 0):
                    raise _err(pos, "division by zero")
                return _checked(fn, pos, op, a, b)
            return divide
        if op in ("^", "*", "+", "-"):    # may overflow to inf (1e308 + 1e308)
            return lambda env: _checked(fn, pos, op, left(env), right(env))
        return lambda env: fn(left(env), right(env))
    if isinstance(expr, Call):
        fn, arity = FUNCTIONS[expr.func]
        args = [compile_expr(a) for a in expr.args]
        if len(args) != arity:
            raise _err(expr.pos, f"{expr.func}() takes {arity} argument(s), got {len(args)}")
        pos, fname = expr.pos, expr.func

        def call(env):
            with np.errstate(all="ignore"):
                out = fn(*[a(env) for a in args])
            if not np.all(np.isfinite(out)):
                raise _err(pos, f"{fname}() of a value outside its domain, or a result too "
                                "large (not a finite real number)")
            return _scalarise(out)
        return call
    raise TypeError(f"not an expression node: {expr!r}")


def evaluate(expr: Expr, env: Mapping[str, object] | None = None):
    """Evaluate an expression once (see `compile_expr`)."""
    return _scalarise(compile_expr(expr)(env or {}))


def expression_depth(expr: Expr) -> int:
    """The number of nodes on the longest path from the root to a leaf (a number: 1).

    Iterative, so that a tree too deep for Python's recursion can still be measured.
    """
    deepest, stack = 0, [(expr, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        if isinstance(node, Unary):
            stack.append((node.operand, depth + 1))
        elif isinstance(node, Binary):
            stack += [(node.left, depth + 1), (node.right, depth + 1)]
        elif isinstance(node, Call):
            stack += [(a, depth + 1) for a in node.args]
    return deepest


def free_names(expr: Expr) -> set[str]:
    """Every variable name an expression reads."""
    if isinstance(expr, Name):
        return {expr.name}
    if isinstance(expr, Unary):
        return free_names(expr.operand)
    if isinstance(expr, Binary):
        return free_names(expr.left) | free_names(expr.right)
    if isinstance(expr, Call):
        out: set[str] = set()
        for a in expr.args:
            out |= free_names(a)
        return out
    return set()


def format_expr(expr: Expr, parent_prec: int = 0) -> str:
    """Write an expression back as text that parses to the same tree."""
    if isinstance(expr, Num):
        # The parser reads "-2" as Unary("-", Num(2)); a negative literal built by
        # code is written in parentheses so that it binds as one operand.
        text = format_number(expr.value)
        return f"({text})" if expr.value < 0 else text
    if isinstance(expr, Name):
        return expr.name
    if isinstance(expr, Unary):
        text = expr.op + format_expr(expr.operand, UNARY_PRECEDENCE)
        return f"({text})" if parent_prec > UNARY_PRECEDENCE else text
    if isinstance(expr, Binary):
        p = PRECEDENCE[expr.op]
        right_assoc = expr.op in RIGHT_ASSOCIATIVE
        left = format_expr(expr.left, p + 1 if right_assoc else p)
        right = format_expr(expr.right, p if right_assoc else p + 1)
        text = f"{left}{expr.op}{right}"
        return f"({text})" if p < parent_prec else text
    if isinstance(expr, Call):
        return f"{expr.func}({','.join(format_expr(a) for a in expr.args)})"
    raise TypeError(f"not an expression node: {expr!r}")


def format_number(value: float) -> str:
    """Shortest text that reads back as exactly ``value`` ("1" for 1.0)."""
    value = float(value)
    if value.is_integer() and abs(value) < 1e16:
        return str(int(value))
    return repr(value)
