"""What kind of plantlod file a text is, so that a file handed to the wrong reader is named by
what it is ("an angle CSV, not an L-system") instead of by its first character that the
reader could not read.

Each reader asks only once its own parse has failed (`other_kind`), so a valid file of its
own kind is never judged by these signatures; each signature is one no valid file of another
kind has at its start:

- an angle CSV: its first non-blank line is the header ``t,b:ADDR,r:ADDR,…`` (`angles_csv`);
- a tree file: JSON Lines whose first record names ``"format": "plantlod-tree"``;
- a glTF (.gltf): other JSON with one of glTF's top-level keys (``"asset": {``,
  ``"accessors": [``, …; `plantlod export` writes them sorted, pretty-printed);
- OpenUSD text (.usda): its first line starts ``#usda`` and a version (a binary .usdc starts with
  USDC_MAGIC, which `text_input.BINARY_KINDS` and `plantlod view` name);
- a report: other JSON with a key of a scene's or compare's report (``"speedup":``,
  ``"comparisons":``);
- a scene: a line that is one of a scene's table headers (``[camera]``, ``[[tree]]``, …);
- an L-system: a line ``derivation_length:``, ``axiom:`` or ``productions:``.
"""

from __future__ import annotations

import contextlib
import os
import re
from typing import Iterator

from plantlod.lsys.errors import InputError

_SCENE_HEADER = re.compile(r"(?m)^[ \t]*\[\[?[ \t]*(camera|camera\.key|tree|scatter|wind)[ \t]*\]\]?"
                           r"[ \t]*(#.*)?\r?$")
_GLTF_KEY = re.compile(r'"(asset|accessors|bufferViews|buffers|meshes|nodes|scenes)"\s*:\s*[\[{]')
_REPORT_KEY = re.compile(r'"(speedup|branch_steps_full|comparisons)"\s*:')
_LSYS_KEY = re.compile(r"(?m)^[ \t]*(derivation_length|axiom|productions)[ \t]*:")
SNIFF_CHARS = 65536       # only the start of a text is looked at
USDC_MAGIC = b"PXR-USDC"  # the first bytes of a binary OpenUSD file (.usdc, .usd)

# kind -> (what it is, which commands read it)
def looks_like_tree_file(text: str) -> bool:
    """Tree files are JSON Lines: their first non-blank character is ``{`` (a stray
    byte-order mark, U+FEFF, left after the one the readers drop, counted as blank: the
    tree reader then places it; a file of two read as an .lsys said it was a tree file).
    Other JSON (a glTF, a report) starts so too: `text_kind` tells them apart."""
    return text.lstrip().lstrip("\ufeff").lstrip().startswith("{")


KINDS = {
    "csv": ("an angle CSV", "`plantlod simulate` writes it; compare (--angles) and export read it"),
    "tree": ("a tree file (JSON Lines)", "simulate, compare and export read it"),
    "gltf": ("a glTF (.glb, .gltf)", "`plantlod view` plays it"),
    "usd": ("an OpenUSD file (.usda)", "`plantlod export` writes it for other programs; "
                                       "plantlod reads none"),
    "scene": ("a scene file (TOML)", "`plantlod scene` reads it"),
    "report": ("a report (JSON)", "`plantlod scene` or `plantlod compare --json` wrote it; no "
                                  "command reads it"),
    "lsys": ("an L-system (.lsys)", "derive, simulate, simplify, compare and export read it"),
    "html": ("a web page (HTML)", "`plantlod view` writes it; a browser opens it"),
}


def text_kinds(text: str) -> list[str]:
    """Every kind (keys of KINDS) whose signature the start of ``text`` shows, in the order
    the kinds are told apart: JSON is one kind only (a tree file's header first, so a tree
    file with a stray glTF-like key is a tree file); other text may show several (an
    L-system with a `[tree]` line under its productions shows a scene's header too)."""
    head = text[:SNIFF_CHARS].lstrip("\ufeff")
    stripped = head.lstrip()
    first = stripped.split("\n", 1)[0].rstrip("\r")
    if stripped.startswith("{"):
        if re.search(r'"format"\s*:\s*"plantlod-tree', first):
            return ["tree"]
        if _GLTF_KEY.search(head):
            return ["gltf"]
        if _REPORT_KEY.search(head):
            return ["report"]
        return []
    if re.match(r"<(!doctype\s+html|html)\b", stripped[:20], re.IGNORECASE):
        return ["html"]
    kinds = []
    if re.match(r"t,b:[^,]+,r:", first) or first == "t":
        kinds.append("csv")
    if re.match(r"#usda [0-9]", first):
        kinds.append("usd")
    if _SCENE_HEADER.search(head):
        kinds.append("scene")
    if _LSYS_KEY.search(head):
        kinds.append("lsys")
    return kinds


def text_kind(text: str) -> str | None:
    """The kind (a key of KINDS) that the start of ``text`` shows first, None where none does."""
    kinds = text_kinds(text)
    return kinds[0] if kinds else None


@contextlib.contextmanager
def named_by_kind(text: str, name: str | None, own: str) -> Iterator[None]:
    """A reader of kind ``own`` parsing ``text`` inside: its InputError, where the text is a
    file of another kind (`other_kind`), becomes the one that says so."""
    try:
        yield
    except InputError as exc:
        raise other_kind(text, name, own) or exc from None


def other_kind_of_text(text: str, own: str) -> tuple[str, str] | None:
    """(what it is, which commands read it) of the kind the start of ``text`` shows, where that
    is another than ``own``; None where it shows none, or its own kind too."""
    kinds = text_kinds(text)
    if not kinds or own in kinds:
        return None
    return KINDS[kinds[0]]


def other_kind(text: str, name: str | None, own: str) -> InputError | None:
    """The error for ``text`` (named ``name``) that its reader of kind ``own`` could not parse,
    where its start shows it is a file of another kind; None where it does not, or where it
    shows its own kind too (a broken file of the reader's kind keeps the reader's error)."""
    other = other_kind_of_text(text, own)
    if other is None:
        return None
    what, who = other
    return InputError(f"{what}, not {KINDS[own][0]} ({who})", name)


# What a file of each extension holds, for refusing an output named for another kind
# (`simplify -o out.glb` wrote L-system text into a .glb; the API's `write_tree(tree,
# "t.npz")` wrote JSON Lines that `read_tree` then refused); other extensions are not judged
EXTENSION_KINDS = {
    ".lsys": "an L-system", ".jsonl": "a tree file (JSON Lines)", ".npz": "an .npz archive",
    ".csv": "an angle CSV", ".json": "JSON", ".txt": "text", ".toml": "a scene (TOML)",
    ".glb": "a glTF", ".gltf": "a glTF", ".usd": "OpenUSD", ".usda": "OpenUSD",
    ".usdc": "OpenUSD", ".html": "a web page", ".htm": "a web page", ".png": "a PNG picture",
    ".jpg": "a JPEG picture", ".jpeg": "a JPEG picture", ".svg": "an SVG picture",
    ".pdf": "a PDF", ".obj": "an OBJ mesh", ".zarr": "a Zarr store",
}


# What the commands' -o and the API's write_* functions write, and the extensions that hold it
OUTPUT_KINDS = {
    "lsystem": ("an L-system", (".lsys", ".txt")),
    "tree": ("a tree file (JSON Lines, or an .npz archive)", (".jsonl", ".json", ".npz", ".txt")),
    "angles": ("angles (a CSV, or an .npz archive)", (".csv", ".npz", ".txt")),
    "page": ("a web page", (".html", ".htm")),
}


def output_kind_problem(path: str, writes: str, accepted: tuple[str, ...]) -> str | None:
    """Why an output named ``path`` cannot take what is written there (``writes``: what it
    is; ``accepted``: the extensions that hold it), or None: a name whose extension names
    another kind of file (`EXTENSION_KINDS`) is refused; names without a known extension
    (``out``, ``/dev/null``) pass."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in EXTENSION_KINDS or ext in accepted:
        return None
    names = ", ".join(accepted[:-1]) + (" or " if len(accepted) > 1 else "") + accepted[-1]
    return (f"this writes {writes}, not {EXTENSION_KINDS[ext]} ({ext}); expected a name "
            f"ending in {names}")
