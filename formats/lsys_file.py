"""Read and write ``.lsys`` files (docs/lsys-format.md).

`write_lsys` gives one canonical text for a system: header keys in a fixed order
(`HEADER_KEYS`), then defines, branch and leaf declarations, the axiom, the
productions, the interpretation rules and the overrides, with numbers written by
`format_number` (shortest text that reads back exactly) and expressions by
`format_expr`. ``parse_lsys(write_lsys(s)) == s`` for every system the parser
builds, and writing is deterministic.
"""

from __future__ import annotations

from .constants import AXIOM_LINE_CHARS

from plantlod.lsys.errors import InputError
from plantlod.lsys.expr import format_expr, format_number
from plantlod.lsys.constants import MAX_LINE_CHARS
from plantlod.lsys.parse import HEADER_KEYS, LINE_BREAK, continues_axiom, parse_lsys
from plantlod.lsys.system import (
    BRANCH_KEYS, BranchSymbol, LeafSymbol, LSystem, Module, Override, Pattern, Production,
)

from .kinds import looks_like_tree_file, named_by_kind, other_kind, text_kind
from .text_input import read_text, refuse_empty, source_name

_INDENT = "  "


def format_modules(modules: tuple[Module, ...]) -> str:
    """``F(l)[&(a0)B(l*r2,w)]A(l*r1,w)``: modules written side by side."""
    return "".join(
        m.name + (f"({','.join(format_expr(a) for a in m.args)})" if m.args else "")
        for m in modules
    )


def format_pattern(pattern: Pattern) -> str:
    """``A(l,w)``."""
    return pattern.name + (f"({','.join(pattern.params)})" if pattern.params else "")


def format_production(rule: Production) -> str:
    """One production or interpretation rule on one line (without indentation).

    Context patterns are separated by spaces, so that a left context never reads
    as a statement keyword (``leaf < A`` would).
    """
    parts = []
    if rule.left:
        parts += [format_pattern(p) for p in rule.left] + ["<"]
    parts.append(format_pattern(rule.pred))
    if rule.right:
        parts += [">"] + [format_pattern(p) for p in rule.right]
    if rule.condition is not None:
        parts += [":", format_expr(rule.condition)]
    parts.append("->")
    if rule.probability is not None:
        parts.append(f"({format_expr(rule.probability)})")
    if rule.successor:
        parts.append(format_modules(rule.successor))
    return " ".join(parts)


def _format_key_values(pairs) -> str:
    return " ".join(f"{key}={format_number(value)}" for key, value in pairs)


def _format_branch(b: BranchSymbol) -> str:
    pairs = [(key, getattr(b, key)) for key in BRANCH_KEYS if getattr(b, key) is not None]
    return f"branch {b.name}: {_format_key_values(pairs)}"


def _format_leaf(leaf: LeafSymbol) -> str:
    return f"leaf {leaf.name}: area={format_number(leaf.area)}"


def _format_override(o: Override) -> str:
    return f"{'.'.join(str(a) for a in o.address)}: {_format_key_values(o.values)}"


def _header_lines(system: LSystem) -> list[str]:
    lines = []
    for key in HEADER_KEYS:
        value = getattr(system, key)
        if key == "name":
            # (what the reader reads back: lines end at "\n", "\r\n" or a lone "\r" since
            # session 29, so no file gives a name holding either)
            if value != value.strip() or any(c in value for c in "#\n\r"):
                raise InputError(f"name {value[:80]!r} cannot be written: it would not read "
                                 "back (no '#', line breaks or surrounding spaces)")
            if value:
                lines.append(f"name: {value}")
        elif key == "ignore":
            if value:
                lines.append(f"ignore: {' '.join(value)}")
        elif key in ("derivation_length", "seed"):
            lines.append(f"{key}: {int(value)}")
        else:
            lines.append(f"{key}: {format_number(value)}")
    return lines


def axiom_lines(modules: list[str]) -> list[str]:
    """``axiom: MODULES`` on one line, or, when longer than AXIOM_LINE_CHARS, ``axiom:`` and
    the modules on indented lines of about that length (split between modules). A line whose
    first module the reader would take for a statement (a module ``seed``, ``leafs``:
    `lsys.parse.continues_axiom`) starts one module later; where the first line would, the
    axiom is written on one line (up to the reader's line limit)."""
    text = "".join(modules)
    if len(text) <= AXIOM_LINE_CHARS:
        return [f"axiom: {text}"]
    chunks, current, size = [], [], 0
    for m in modules:
        if current and size + len(m) > AXIOM_LINE_CHARS:
            chunks.append(current)
            current, size = [], 0
        current.append(m)
        size += len(m)
    chunks.append(current)
    for k in range(1, len(chunks)):           # (a module moved back: the line before grows)
        while chunks[k] and not continues_axiom(_INDENT + "".join(chunks[k])):
            chunks[k - 1].append(chunks[k].pop(0))
    if not continues_axiom(_INDENT + "".join(chunks[0])):
        if len(text) + len("axiom: ") > MAX_LINE_CHARS:
            raise InputError("the axiom cannot be written so that it reads back: it starts with "
                             f"a module read as a statement ({text.split()[0][:40]!r}) and is "
                             f"longer than one line may be ({MAX_LINE_CHARS:,} characters)")
        return [f"axiom: {text}"]
    return ["axiom:"] + [_INDENT + "".join(c) for c in chunks if c]


def _comment_lines(comment: str) -> list[str]:
    """``comment`` as '# ' lines, broken where the reader breaks lines (a "\r" in a file
    name it quotes would otherwise start a line that is no comment)."""
    return [f"# {line}".rstrip() for line in LINE_BREAK.split(comment)]


def with_header_comment(text: str, header_comment: str) -> str:
    """``text`` (canonical, as `write_lsys` writes a system without a comment) with
    ``header_comment`` written first: ``write_lsys(system, header_comment)`` without
    formatting the system again."""
    return "\n".join(_comment_lines(header_comment)) + "\n\n" + text


def write_lsys(system: LSystem, header_comment: str | None = None) -> str:
    """The canonical text of ``system``, ending in a newline.

    ``header_comment`` (may span lines) is written first as ``# `` comment lines.
    Raises ValueError for a name that cannot be read back (it holds '#' or a line
    break, or starts or ends with white space).
    """
    blocks: list[list[str]] = []
    if header_comment is not None:
        blocks.append(_comment_lines(header_comment))
    blocks.append(_header_lines(system))
    blocks.append([f"define {name} = {format_number(value)}" for name, value in system.defines])
    blocks.append([_format_branch(b) for b in system.branches]
                  + [_format_leaf(leaf) for leaf in system.leaves])
    blocks.append(axiom_lines([format_modules((m,)) for m in system.axiom]))
    for title, rules in (("productions", system.productions),
                         ("interpretation", system.interpretation)):
        if rules:
            blocks.append([f"{title}:"] + [_INDENT + format_production(r) for r in rules])
    if system.overrides:
        blocks.append(["overrides:"] + [_INDENT + _format_override(o) for o in system.overrides])
    if system.groups:
        blocks.append(["groups:"] + [_INDENT + ".".join(map(str, a)) + ": " + root
                                     for a, root in system.groups])
    return "\n\n".join("\n".join(block) for block in blocks if block) + "\n"


def read_lsys(path: str) -> LSystem:
    """Read and parse an ``.lsys`` file; ``-`` reads stdin.

    A missing or unreadable file, or one that is not UTF-8, is an `InputError`
    naming the file (at the line and column of the first bad byte for UTF-8).
    """
    return parse_lsys_text(read_text(path), source_name(path))


def parse_lsys_text(text: str, name: str) -> LSystem:
    """`parse_lsys` of a file's ``text``; a tree file (JSON Lines, first non-blank character
    ``{``) is refused by what it is, not as an L-system's first bad character."""
    refuse_empty(text, name, "an L-system (docs/lsys-format.md)")
    if looks_like_tree_file(text):              # JSON: a tree file, a glTF, a report
        if text_kind(text) in ("gltf", "report"):
            raise other_kind(text, name, "lsys")
        raise InputError("a tree file (JSON Lines), not an L-system; expected an .lsys file "
                         "(simulate, compare and export also read tree files)", name, 1, 1)
    with named_by_kind(text, name, "lsys"):   # an angle CSV, a scene given for an L-system
        return parse_lsys(text, name)
