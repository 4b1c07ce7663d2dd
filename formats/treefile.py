"""The tree file: a `Tree` as JSON Lines (docs/tree-format.md).

Line 1 is a header record, then one record per branch (in index order, parent
before child), then one record per leaf. Every line is one JSON object whose
keys come in a fixed order, written exactly as ``json.dumps(record,
ensure_ascii=False)`` would write it (separators ``", "`` and ``": "``); floats
are written in their shortest round-trip form, so reading a file back gives
the same float64 values bit for bit (except -0.0, always written as 0.0).

`write_tree` / `iter_tree_lines` write; `read_tree` reads and validates,
raising `InputError(message, source, line, col)` at the first problem.
"""

from __future__ import annotations

import contextlib
import gc
import io
import json
import math
import re
import sys
from itertools import chain, islice
from json.encoder import encode_basestring   # json's own string encoder (C), no ASCII escaping
from typing import Iterator, TextIO

import numpy as np

from .constants import MAX_JSON_DEPTH, NORMAL_UNIT_TOL
from plantlod.lsys.checks import digits_past_limit
from plantlod.lsys.errors import InputError, RunFailure
from plantlod.lsys.tree import (ADDRESS_FORM, BRANCH_ADDRESS, BRANCH_FLOAT_FIELDS,  # noqa: F401
                                LEAF_ADDRESS, Tree, chain_depths, is_symbol)

FORMAT_NAME = "plantlod-tree"
# Version 1: plain trees. Version 2: a level's tree, whose header lists in "extras" the
# keys every branch record adds after "offset": "group_root" (the address of the original
# branch rooting its group, explicit form), "gain" (its gain matrix, 6 numbers) and
# "swing_roll" (the roll of its swing frame about its axis, radians: `Tree.swing_roll`).
FORMAT_VERSION = 1
LEVEL_FORMAT_VERSION = 2
EXTRA_BRANCH_KEYS = ("group_root", "gain", "swing_roll")

HEADER_KEYS = ("format", "version", "source", "branches", "leaves", "leaf_force_scale", "depth")
LEVEL_HEADER_KEYS = (*HEADER_KEYS, "extras")
BRANCH_KEYS = ("type", "index", "address", "symbol", "parent", *BRANCH_FLOAT_FIELDS,
               "phi", "alpha", "psi", "offset")
LEAF_KEYS = ("type", "index", "address", "branch", "area", "normal")

# Addresses as derive writes them (lsys/tree.py: BRANCH_ADDRESS, LEAF_ADDRESS, ADDRESS_FORM);
# `first_bad_address` checks a block of them at once.
# the same patterns for many addresses at once, each followed by a line break (`first_bad_address`)
# (possessive and atomic: nothing is tried again, 7x faster over 390,625 addresses than plain
# repeats)
_JOINED_NUMBER = r"(?>0|[1-9][0-9]*+)"
_JOINED = {BRANCH_ADDRESS: re.compile(
               rf"(?:{_JOINED_NUMBER}(?:\.{_JOINED_NUMBER})*+(?::{_JOINED_NUMBER})?+\n)*+\Z"),
           LEAF_ADDRESS: re.compile(rf"(?:{_JOINED_NUMBER}(?:\.{_JOINED_NUMBER})*+\n)*+\Z")}
_LINES_PER_WRITE = 4096


def first_bad_address(strings: list[str], pattern: re.Pattern) -> str | None:
    """The first of ``strings`` that ``pattern`` (BRANCH_ADDRESS or LEAF_ADDRESS) refuses, or
    None: one match over all of them joined by line breaks (a string holding a line break of
    its own is refused: "0\\n5" is no address, though "0" and "5" are), the string-by-string
    loop only to name the one refused (390,625 addresses: 0.08 s against 0.16 s)."""
    joined = "\n".join(strings) + ("\n" if strings else "")
    if joined.count("\n") == len(strings) and _JOINED[pattern].match(joined):
        return None
    return next((s for s in strings if not pattern.match(s)), None)


# Amounts that cannot be negative, and the strengths, which must be > 0 (model.md 4: a
# strength of 0 or less has no period and no stable time step): both refused where the
# file gives them, by line and column (a bend strength of 0 used to be refused only when
# simulating, naming the .lsys the file was derived from).
NON_NEGATIVE_FIELDS = frozenset({"length", "radius", "force_absorbed", "force_propagated",
                                 "drag_coefficient", "area", "leaf_force_scale"})
POSITIVE_FIELDS = frozenset({"bend_strength", "rotation_strength"})


# --- writing ------------------------------------------------------------------------

def _columns(tree: Tree, names: list[str], rows: int) -> list[list[float]]:
    """Float arrays of ``tree`` as Python float lists, -0.0 made 0.0; finite checked."""
    out = []
    for name in names:
        arr = np.asarray(getattr(tree, name), dtype=np.float64)
        if not np.all(np.isfinite(arr)):
            where = int(np.flatnonzero((~np.isfinite(arr.reshape(rows, -1))).any(axis=1))[0])
            raise RunFailure(f"cannot write the tree: {name} of record {where} is not finite")
        out.append((arr + 0.0).tolist())      # x + 0.0 turns -0.0 into 0.0
    return out


def _extras(tree: Tree) -> tuple[str, ...]:
    """The level keys ``tree`` needs in its branch records (`EXTRA_BRANCH_KEYS`)."""
    return tuple(k for k, present in zip(EXTRA_BRANCH_KEYS, (
        bool(tree.group_root), getattr(tree, "force_gain", None) is not None,
        getattr(tree, "swing_roll", None) is not None)) if present)


def iter_tree_lines(tree: Tree) -> Iterator[str]:
    """Yield the lines of the tree file, each ending in ``"\\n"``."""
    b, f = tree.n_branches, tree.n_leaves
    extras = _extras(tree)
    header = {
        "format": FORMAT_NAME,
        "version": LEVEL_FORMAT_VERSION if extras else FORMAT_VERSION,
        "source": str(tree.source),
        "branches": b,
        "leaves": f,
        "leaf_force_scale": float(tree.leaf_force_scale) + 0.0,
        "depth": int(chain_depths(tree.parent).max(initial=0)),
    }
    if extras:
        header["extras"] = list(extras)
    if not math.isfinite(header["leaf_force_scale"]):
        raise RunFailure("cannot write the tree: leaf_force_scale is not finite")
    # Everything is converted (and checked) before the first line goes out.
    (length, radius, k_bs, k_rs, k_fa, k_fp, c_d, euler, offset) = _columns(
        tree, [*BRANCH_FLOAT_FIELDS, "euler", "offset"], b)
    area, normal = _columns(tree, ["leaf_area", "leaf_normal"], f)
    gain = _columns(tree, ["force_gain"], b)[0] if "gain" in extras else None
    roll = _columns(tree, ["swing_roll"], b)[0] if "swing_roll" in extras else None
    parents = np.asarray(tree.parent).tolist()
    branch_of = np.asarray(tree.leaf_branch).tolist()
    yield json.dumps(header, ensure_ascii=False) + "\n"

    enc = encode_basestring
    for i in range(b):
        phi, alpha, psi = euler[i]
        ox, oy, oz = offset[i]
        yield (f'{{"type": "branch", "index": {i}, "address": {enc(tree.address[i])}, '
               f'"symbol": {enc(tree.symbol[i])}, "parent": {parents[i]}, '
               f'"length": {length[i]!r}, "radius": {radius[i]!r}, '
               f'"bend_strength": {k_bs[i]!r}, "rotation_strength": {k_rs[i]!r}, '
               f'"force_absorbed": {k_fa[i]!r}, "force_propagated": {k_fp[i]!r}, '
               f'"drag_coefficient": {c_d[i]!r}, '
               f'"phi": {phi!r}, "alpha": {alpha!r}, "psi": {psi!r}, '
               f'"offset": [{ox!r}, {oy!r}, {oz!r}]'
               + (f', "group_root": {enc(tree.group_root[i])}' if "group_root" in extras else "")
               + (f', "gain": [{", ".join(map(repr, gain[i]))}]' if gain is not None else "")
               + (f', "swing_roll": {roll[i]!r}' if roll is not None else "")
               + '}\n')

    for j in range(f):
        nx, ny, nz = normal[j]
        yield (f'{{"type": "leaf", "index": {j}, "address": {enc(tree.leaf_address[j])}, '
               f'"branch": {branch_of[j]}, "area": {area[j]!r}, '
               f'"normal": [{nx!r}, {ny!r}, {nz!r}]}}\n')


def write_tree(tree: Tree, out: TextIO) -> None:
    """Write ``tree`` to the text stream ``out`` as a tree file."""
    lines = iter_tree_lines(tree)
    while chunk := "".join(islice(lines, _LINES_PER_WRITE)):
        out.write(chunk)


# --- reading ------------------------------------------------------------------------

class _Line:
    """One record being validated: its parsed object, text and line number."""

    def __init__(self, source: str, number: int, text: str, record: dict, kind: str):
        self.source, self.lineno, self.text, self.record, self.kind = (
            source, number, text, record, kind)

    def error(self, message: str, key: str | None = None) -> InputError:
        """InputError at this line; the column is that of ``"key"`` when given."""
        col = 1
        if key is not None:
            found = self.text.find(f'"{key}"')
            col = found + 1 if found >= 0 else 1
        return InputError(message, self.source, self.lineno, col)

    def keys(self, expected: tuple[str, ...]) -> None:
        """Require exactly the keys ``expected`` (any order)."""
        if len(self.record) == len(expected) and all(k in self.record for k in expected):
            return
        for key in self.record:
            if key not in expected:
                raise self.error(f'unknown key "{key}" in a {self.kind} record; expected the keys '
                                 f"{', '.join(expected)}", key)
        missing = next(k for k in expected if k not in self.record)
        raise self.error(f'missing key "{missing}" in a {self.kind} record')

    def integer(self, key: str, low: int | None = None, high: int | None = None,
                what: str = "") -> int:
        """An integer in [low, high] (bounds optional)."""
        v = self.record[key]
        if type(v) is not int:
            raise self.error(f'"{key}" must be an integer, got {_json_type(v)}', key)
        if (low is not None and v < low) or (high is not None and v > high):
            raise self.error(what or f'"{key}" must be between {low} and {high}, got {v}', key)
        return v

    def number(self, key: str) -> float:
        """A finite number (JSON integer or float), as a float; >= 0 for an amount, > 0 for
        a strength."""
        v = _finite(self, key, self.record[key])
        if key in NON_NEGATIVE_FIELDS and v < 0:
            raise self.error(f'"{key}" must not be negative, got {v!r}; expected a number >= 0',
                             key)
        if key in POSITIVE_FIELDS and not v > 0:
            raise self.error(f'"{key}" must be > 0, got {v!r}; expected a strength > 0', key)
        return v

    def vector(self, key: str) -> tuple[float, float, float]:
        """A list of three finite numbers."""
        v = self.record[key]
        if type(v) is not list or len(v) != 3:
            raise self.error(f'"{key}" must be a list of 3 numbers, got {_json_kind(v)}', key)
        return (_finite(self, key, v[0]), _finite(self, key, v[1]), _finite(self, key, v[2]))

    def string(self, key: str) -> str:
        v = self.record[key]
        if type(v) is not str:
            raise self.error(f'"{key}" must be a string, got {_json_type(v)}', key)
        return v

    def address(self, pattern: re.Pattern, example: str) -> str:
        v = self.string("address")
        if not pattern.match(v):
            raise self.error(f'"address" must be an address like {example} '
                             f"({ADDRESS_FORM}), got {json.dumps(v, ensure_ascii=False)}",
                             "address")
        return v


def _finite(line: _Line, key: str, v) -> float:
    if type(v) is float:
        if math.isfinite(v):
            return v
        raise line.error(f'"{key}" must be a finite number, got {v!r}', key)
    if type(v) is int:
        try:
            return float(v)
        except OverflowError:         # beyond the largest double (about 1.8e308)
            raise line.error(f'"{key}" must be a finite number, got an integer of '
                             f"{v.bit_length()} bits", key) from None
    raise line.error(f'"{key}" must be a number, got {_json_type(v)}', key)


def _json_kind(value) -> str:
    """`_json_type`, and a list's length (what a wrong-length list gets wrong)."""
    return _json_type(value) + (f" of length {len(value)}" if type(value) is list else "")


def _json_type(v) -> str:
    """The JSON name of a parsed value's type, for messages."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true/false"
    return {int: "an integer", float: "a float", str: "a string", list: "a list",
            dict: "an object"}.get(type(v), type(v).__name__)


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a number in a tree file")


def _object(pairs):
    """json object hook: refuse duplicate keys."""
    out = dict(pairs)
    if len(out) != len(pairs):
        seen = set()
        for key, _ in pairs:
            if key in seen:
                raise ValueError(f'duplicate key "{key}"')
            seen.add(key)
    return out


def _integer(text: str) -> int:
    """A JSON integer, exactly; one longer than Python converts (4300 digits) is no value
    a tree file holds."""
    past = digits_past_limit(text)
    if past is not None:
        raise ValueError(f"an integer of {past} digits; expected at most "
                         f"{sys.get_int_max_str_digits()}")
    return int(text)


_DECODER = json.JSONDecoder(object_pairs_hook=_object, parse_constant=_reject_constant,
                            parse_int=_integer)


def _parse(source: str, number: int, text: str, kind: str) -> _Line:
    """Parse one line as a JSON object (``kind`` names the record for messages)."""
    stripped = text.rstrip("\r\n")
    body = stripped.lstrip()
    indent = len(stripped) - len(body)
    if not body.strip():
        raise InputError(f"blank line; expected a {kind} record", source, number, 1)
    if body.count("[") + body.count("{") > MAX_JSON_DEPTH:
        _check_depth(source, number, indent, body)
    try:
        record, end = _DECODER.raw_decode(body)    # no whitespace regexes: ~2x faster
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON: {exc.msg}", source, number,
                         indent + exc.colno) from None
    except ValueError as exc:      # duplicate key or NaN/Infinity
        raise InputError(f"not valid here: {exc}", source, number, 1) from None
    rest = body[end:]
    if rest.strip():
        col = indent + end + len(rest) - len(rest.lstrip()) + 1
        raise InputError("not valid JSON: extra data after the record", source, number, col)
    if type(record) is not dict:
        raise InputError(f"expected a JSON object {{...}} ({kind} record), got "
                         f"{_json_type(record)}", source, number, 1)
    return _Line(source, number, stripped, record, kind)


_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')
_JSON_NESTING = re.compile(r"[\[\]{}]")


def _check_depth(source: str, number: int, indent: int, body: str) -> None:
    """Refuse a record nested deeper than MAX_JSON_DEPTH before the decoder recurses into it."""
    depth = 0
    blanked = _JSON_STRING.sub(lambda m: " " * len(m.group()), body)   # brackets in strings
    for m in _JSON_NESTING.finditer(blanked):
        depth += 1 if m.group() in "[{" else -1
        if depth > MAX_JSON_DEPTH:
            raise InputError(f"JSON nested more than {MAX_JSON_DEPTH} deep; expected a "
                             "tree-file record (docs/tree-format.md)", source, number,
                             indent + m.start() + 1)


def _expect_type(line: _Line, kind: str, index: int, counts: str) -> None:
    """Require "type": kind for the record numbered ``index``; counts: the header's."""
    if line.record.get("type") == kind:
        return
    what = f"{kind} record {index} ({counts})"
    if "type" not in line.record:
        raise line.error(f'missing key "type"; expected {what}')
    raise line.error(f'expected {what}, found "type": '
                     f'{json.dumps(line.record["type"], ensure_ascii=False)}', "type")


class _Lines:
    """The numbered lines of a stream; remembers the last line number read."""

    def __init__(self, stream: TextIO, source: str):
        self._items = enumerate(stream, start=1)
        self.source = source
        self.last = 0

    def next(self) -> tuple[int, str] | None:
        item = next(self._items, None)
        if item is not None:
            self.last = item[0]
        return item

    def end_error(self, message: str) -> InputError:
        """InputError at the line after the last one (where a record was expected)."""
        return InputError(message, self.source, self.last + 1, 1)


def read_tree(stream: TextIO, source: str) -> Tree:
    """Read and validate a tree file from ``stream``; ``source`` names it in errors.

    Raises InputError(message, source, line, col) at the first problem in
    file order (the header's depth, which needs every record, is checked
    last): a line that is not a JSON object; a missing, unknown or duplicate
    key; a value of the wrong type or not finite; a wrong format name or
    version; records out of order or misnumbered; a parent that is not an
    earlier branch; a leaf on a branch that does not exist; a non-unit leaf
    normal; a repeated branch address; counts or depth that differ from the
    header.

    Records are checked a block at a time with vectorised checks; if any
    fails, the block is checked record by record, which finds and reports the
    problem (the record-by-record checks are the definition; the fast ones
    accept only what those accept).
    """
    with _gc_paused():
        return _read(_Lines(stream, source))


def read_tree_text(text: str, source: str) -> Tree:
    """`read_tree` of a file's whole ``text``; a file of another kind (an L-system, a glTF, a
    report) is named by what it is (`formats.kinds`)."""
    from .kinds import named_by_kind

    with named_by_kind(text, source, "tree"):
        return read_tree(io.StringIO(text), source)


@contextlib.contextmanager
def _gc_paused():
    """Pause the cyclic garbage collector (parsing makes a dict per record; the
    collector would scan them all again and again, doubling the reading time)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _read(lines: _Lines) -> Tree:
    """`read_tree` on numbered lines."""
    source = lines.source
    first = lines.next()
    if first is None:
        raise InputError("empty file; expected a tree file header "
                         f'{{"format": "{FORMAT_NAME}", ...}}', source, 1, 1)
    head = _parse(source, 1, first[1], "header")
    if head.record.get("format") != FORMAT_NAME:
        raise head.error(f'not a plantlod tree file: expected "format": "{FORMAT_NAME}" '
                         "in the first record", "format" if "format" in head.record else None)
    version = head.record.get("version")
    if type(version) is not int or version not in (FORMAT_VERSION, LEVEL_FORMAT_VERSION):
        raise head.error(f"tree file version {json.dumps(version)} is not supported; "
                         f"expected {FORMAT_VERSION} or {LEVEL_FORMAT_VERSION}",
                         "version" if "version" in head.record else None)
    if version == FORMAT_VERSION and "extras" in head.record:
        raise head.error(f'"extras" belongs to a version {LEVEL_FORMAT_VERSION} tree file (a '
                         f'level\'s tree); expected "version": {LEVEL_FORMAT_VERSION} with it, '
                         'or no "extras"', "extras")
    head.keys(LEVEL_HEADER_KEYS if version == LEVEL_FORMAT_VERSION else HEADER_KEYS)
    extras = _read_extras(head) if version == LEVEL_FORMAT_VERSION else ()
    n_branches = head.integer("branches", 0, None, '"branches" must be a non-negative integer')
    n_leaves = head.integer("leaves", 0, None, '"leaves" must be a non-negative integer')
    depth = head.integer("depth", 0, None, '"depth" must be a non-negative integer')
    origin = head.string("source")
    leaf_force_scale = head.number("leaf_force_scale")

    counts = f"the header says {n_branches} branches, then {n_leaves} leaves"
    seen: dict[str, int] = {}                  # branch address -> index
    branches = _read_section(lines, n_branches, "branch", counts, _Branches(seen, extras))
    leaves = _read_section(lines, n_leaves, "leaf", counts, _Leaves(n_branches))
    extra = lines.next()
    if extra is not None:
        raise InputError(f"unexpected line after the last record ({counts})",
                         source, extra[0], 1)

    real_depth = int(chain_depths(branches["parent"]).max(initial=0))
    if real_depth != depth:
        raise head.error(f'"depth" is {depth}, but the branches form chains of at most '
                         f"{real_depth}", "depth")
    if "gain" in extras:
        branches["force_gain"] = branches.pop("gain").reshape(n_branches, 6)
    # (one record a line after the header: branch i's is the header's line + 1 + i)
    tree = Tree(**branches, **leaves, leaf_force_scale=leaf_force_scale, source=origin,
                first_record_line=head.lineno + 1 if n_branches else 0)
    tree.check()
    return tree


def _read_extras(head: "_Line") -> tuple[str, ...]:
    """The header's "extras": a list of distinct keys of EXTRA_BRANCH_KEYS, in that order."""
    v = head.record["extras"]
    if (type(v) is not list or not all(type(k) is str for k in v)
            or list(v) != [k for k in EXTRA_BRANCH_KEYS if k in v] or not v):
        raise head.error(f'"extras" must be a non-empty list of {", ".join(EXTRA_BRANCH_KEYS)} '
                         f"(in that order, each once), got {json.dumps(v)}", "extras")
    return tuple(v)


def _read_section(lines: _Lines, count: int, kind: str, counts: str, section) -> dict:
    """The next ``count`` records of one kind, as the Tree's arrays (a dict).

    Reads and converts blocks of _RECORDS_PER_BLOCK records, so that only one
    block of parsed JSON objects is held at a time. ``section`` converts a
    block (`_Branches` or `_Leaves`): ``section(block, start)`` with fast checks,
    ``section.checked(block, start)`` record by record.
    """
    parts = []
    for start in range(0, count, _RECORDS_PER_BLOCK):
        block = []
        for i in range(start, min(count, start + _RECORDS_PER_BLOCK)):
            item = lines.next()
            try:
                if item is None:
                    raise lines.end_error(f"the file ends after {i} {kind} record"
                                          f"{'' if i == 1 else 's'}; {counts}")
                line = _parse(lines.source, item[0], item[1], kind)
                _expect_type(line, kind, i, counts)
            except InputError:
                section.checked(block, start)    # an earlier record's problem comes first
                raise
            block.append(line)
        try:
            parts.append(section(block, start))
        except _Reject:
            parts.append(section.checked(block, start))
    if not parts:
        return section([], 0)
    return {key: (np.concatenate([p[key] for p in parts]) if isinstance(parts[0][key], np.ndarray)
                  else list(chain.from_iterable(p[key] for p in parts)))
            for key in parts[0]}


_RECORDS_PER_BLOCK = 16384


# Fast, vectorised checks of a block of records. Each raises _Reject when a
# record might be invalid; the record-by-record checks then find and report it.

class _Reject(Exception):
    """A fast check failed: check the block record by record instead."""




def _transpose(block: list[_Line], keys: tuple[str, ...]) -> dict[str, list]:
    """The columns of records whose keys are exactly ``keys``, in that order."""
    records = [line.record for line in block]
    if not set(map(tuple, records)) <= {keys}:
        raise _Reject
    if not records:
        return {key: [] for key in keys}
    return dict(zip(keys, map(list, zip(*map(dict.values, records)))))


def _typed(values: list, types: set) -> list:
    """``values`` if every one has a type in ``types``."""
    if not set(map(type, values)) <= types:
        raise _Reject
    return values


def _array(values: list, dtype) -> np.ndarray:
    try:
        arr = np.array(values, dtype=dtype)
    except (OverflowError, ValueError):
        raise _Reject from None
    if dtype is np.float64 and not np.isfinite(arr).all():
        raise _Reject
    return arr


def _floats(values: list, non_negative: bool = False, positive: bool = False) -> np.ndarray:
    """(n,) float64 from JSON numbers, all finite (and >= 0 if ``non_negative``, > 0 if
    ``positive``)."""
    arr = _array(_typed(values, {float, int}), np.float64)
    if (non_negative and np.any(arr < 0)) or (positive and not np.all(arr > 0)):
        raise _Reject
    return arr


def _integers(values: list) -> np.ndarray:
    """(n,) int64 from JSON integers (not true/false)."""
    return _array(_typed(values, {int}), np.int64)


def _vectors(values: list) -> np.ndarray:
    """(n, 3) float64 from lists of 3 finite JSON numbers."""
    if not set(map(len, _typed(values, {list}))) <= {3}:
        raise _Reject
    return _floats(list(chain.from_iterable(values))).reshape(len(values), 3)


def _common(cols: dict[str, list], start: int, addresses: re.Pattern) -> list[str]:
    """Checks shared by branches and leaves: index, address ("type": `_read_section`)."""
    n = len(cols["index"])
    if not np.array_equal(_integers(cols["index"]), np.arange(start, start + n)):
        raise _Reject
    address = _typed(cols["address"], {str})
    if first_bad_address(address, addresses) is not None:
        raise _Reject
    return address


class _Branches:
    """Converts blocks of branch records; remembers the addresses seen."""

    def __init__(self, seen: dict[str, int], extras: tuple[str, ...] = ()):
        self.seen = seen
        self.extras = extras
        self.keys = (*BRANCH_KEYS, *extras)

    def _extra_columns(self, cols: dict[str, list], n: int) -> dict:
        out = {}
        if "group_root" in self.extras:
            roots = _typed(cols["group_root"], {str})
            # (a group root is an original branch's address: "0.0.0:1" where one module drew
            # several branches, as a level's `groups:` section may say)
            if first_bad_address(roots, BRANCH_ADDRESS) is not None:
                raise _Reject
            out["group_root"] = roots
        if "gain" in self.extras:
            if not set(map(len, _typed(cols["gain"], {list}))) <= {6}:
                raise _Reject
            out["gain"] = _floats(list(chain.from_iterable(cols["gain"]))).reshape(n, 6)
        if "swing_roll" in self.extras:
            out["swing_roll"] = _floats(cols["swing_roll"])
        return out

    def __call__(self, block: list[_Line], start: int) -> dict:
        cols = _transpose(block, self.keys)
        address = _common(cols, start, BRANCH_ADDRESS)
        if len(set(address)) != len(address) or not self.seen.keys().isdisjoint(address):
            raise _Reject
        symbol = _typed(cols["symbol"], {str})
        if not all(map(is_symbol, symbol)):
            raise _Reject
        parent = _integers(cols["parent"])
        if np.any((parent < -1) | (parent >= np.arange(start, start + len(parent)))):
            raise _Reject
        out = {name: _floats(cols[name], name in NON_NEGATIVE_FIELDS, name in POSITIVE_FIELDS)
               for name in BRANCH_FLOAT_FIELDS}
        angles = [_floats(cols[name]) for name in ("phi", "alpha", "psi")]
        out.update(address=address, symbol=symbol, parent=parent,
                   euler=np.stack(angles, axis=1).reshape(len(parent), 3),
                   offset=_vectors(cols["offset"]))
        out.update(self._extra_columns(cols, len(parent)))
        self.seen.update(zip(address, range(start, start + len(address))))
        return out

    def checked(self, block: list[_Line], start: int) -> dict:
        """Record by record: the definition of a valid branch record, with messages."""
        rows = []
        for i, line in enumerate(block, start):
            line.keys(self.keys)
            line.integer("index", i, i, f'"index" is {line.record["index"]}, expected {i} '
                                        "(branches are numbered in order from 0)")
            earlier = (f"or an earlier branch (0..{i - 1})" if i
                       else "(the first branch is a root)")
            parent = line.integer("parent", -1, i - 1,
                                  f'"parent" is {line.record["parent"]}; expected -1 {earlier}: '
                                  "parents come before children")
            address = line.address(BRANCH_ADDRESS, '"0.2.1" or "0.2.1:1"')
            if address in self.seen:
                raise line.error(f'branch address "{address}" repeats branch '
                                 f"{self.seen[address]}; branch addresses are unique", "address")
            self.seen[address] = i
            symbol = line.string("symbol")
            # ("\ud800", half a surrogate pair, was read, and refused by the API)
            if not is_symbol(symbol):
                raise line.error(f'"symbol" must be one character (not a control character '
                                 f'nor half a surrogate pair), got '
                                 f"{json.dumps(symbol, ensure_ascii=not symbol.isprintable())}",
                                 "symbol")
            values = [line.number(k) for k in (*BRANCH_FLOAT_FIELDS, "phi", "alpha", "psi")]
            extra = {}
            if "group_root" in self.extras:
                root = line.string("group_root")
                if not BRANCH_ADDRESS.match(root):
                    raise line.error(f'"group_root" must be an address like "0.2.1" or "0.2.1:1" '
                                     f"({ADDRESS_FORM}), got "
                                     f"{json.dumps(root, ensure_ascii=False)}", "group_root")
                extra["group_root"] = root
            if "gain" in self.extras:
                g = line.record["gain"]
                if type(g) is not list or len(g) != 6:
                    raise line.error(f'"gain" must be a list of 6 numbers, got {_json_kind(g)}',
                                     "gain")
                extra["gain"] = [_finite(line, "gain", x) for x in g]
            if "swing_roll" in self.extras:
                extra["swing_roll"] = line.number("swing_roll")
            rows.append((address, symbol, parent, [*values, *line.vector("offset")], extra))
        floats = np.array([r[3] for r in rows], dtype=np.float64).reshape(len(rows), 13)
        out = {name: floats[:, k].copy() for k, name in enumerate(BRANCH_FLOAT_FIELDS)}
        out.update(address=[r[0] for r in rows], symbol=[r[1] for r in rows],
                   parent=np.array([r[2] for r in rows], dtype=np.int64),
                   euler=floats[:, 7:10].copy(), offset=floats[:, 10:13].copy())
        if "group_root" in self.extras:
            out["group_root"] = [r[4]["group_root"] for r in rows]
        if "gain" in self.extras:
            out["gain"] = np.array([r[4]["gain"] for r in rows], dtype=np.float64).reshape(-1, 6)
        if "swing_roll" in self.extras:
            out["swing_roll"] = np.array([r[4]["swing_roll"] for r in rows], dtype=np.float64)
        return out


class _Leaves:
    """Converts blocks of leaf records of a tree with ``n_branches`` branches."""

    def __init__(self, n_branches: int):
        self.n_branches = n_branches

    def __call__(self, block: list[_Line], start: int) -> dict:
        cols = _transpose(block, LEAF_KEYS)
        address = _common(cols, start, LEAF_ADDRESS)
        branch = _integers(cols["branch"])
        if np.any((branch < 0) | (branch >= self.n_branches)):
            raise _Reject
        normal = _vectors(cols["normal"])
        if np.any(np.abs(np.sqrt((normal * normal).sum(axis=1)) - 1.0) > NORMAL_UNIT_TOL):
            raise _Reject
        return dict(leaf_address=address, leaf_branch=branch, leaf_area=_floats(cols["area"], True),
                    leaf_normal=normal)

    def checked(self, block: list[_Line], start: int) -> dict:
        """Record by record: the definition of a valid leaf record, with messages."""
        rows = []
        last = self.n_branches - 1
        for j, line in enumerate(block, start):
            line.keys(LEAF_KEYS)
            line.integer("index", j, j, f'"index" is {line.record["index"]}, expected {j} '
                                        "(leaves are numbered in order from 0)")
            branch = line.integer("branch", 0, last,
                                  f'"branch" is {line.record["branch"]}, which is not a branch '
                                  f"of this file (0..{last})")
            address = line.address(LEAF_ADDRESS, '"0.2.1"')
            area = line.number("area")
            normal = line.vector("normal")
            if abs(math.sqrt(sum(c * c for c in normal)) - 1.0) > NORMAL_UNIT_TOL:
                raise line.error(f'"normal" must be a unit vector (length within '
                                 f"{NORMAL_UNIT_TOL:g} of 1)", "normal")
            rows.append((address, branch, area, normal))
        return dict(leaf_address=[r[0] for r in rows],
                    leaf_branch=np.array([r[1] for r in rows], dtype=np.int64),
                    leaf_area=np.array([r[2] for r in rows], dtype=np.float64),
                    leaf_normal=np.array([r[3] for r in rows],
                                         dtype=np.float64).reshape(len(rows), 3))
