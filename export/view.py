"""A self-contained HTML page that plays glTF trees side by side (`plantlod view`).

The page (export/viewer/page.html) inlines everything it needs, so it opens from disk
with no network: three.js (bundled from its npm release by export/viewer/vendor.sh,
MIT, export/viewer/LICENSE-three.txt), the viewer script (export/viewer/viewer.js) and
every tree as a base64 GLB. docs/export.md, "Watching", describes the page.
"""

from __future__ import annotations

import base64
import json
import os
import re
import stat
import warnings
from importlib import resources
from typing import Sequence

from plantlod.formats.kinds import SNIFF_CHARS, USDC_MAGIC, other_kind, text_kind
from plantlod.formats.constants import ZIP_MAGIC
from plantlod.formats.text_input import not_utf8
from plantlod.lsys.errors import InputError

from .constants import VIEW_MAX_FILE_BYTES, VIEW_TITLE
from .gltf_check import (GLB_MAGIC, buffer_files, check_animation_data, check_buffer_uris,
                         check_document, check_glb_buffer, check_glb_container,
                         check_raw_json)

GLTF_BUFFER_DATA_URI = "data:application/gltf-buffer;base64,"     # glTF 2.0, 3.9.2
OCTET_STREAM_DATA_URI = "data:application/octet-stream;base64,"


def files_read(path: str) -> list[str]:
    """``path`` and the buffer files beside it that its glTF names (`gltf_check.buffer_files`):
    what `view` reads of one input, so that no page is written over any of them."""
    return [path, *buffer_files(path, VIEW_MAX_FILE_BYTES)]


def glb_from_file(path: str) -> tuple[bytes, int | None]:
    """The GLB bytes of a .glb or .gltf file (external buffers folded in) and its branch count.

    The count is what `plantlod export` records in the asset's extras (``plantlod.branches``);
    None for a glTF written by another program. A file that is not glTF is an InputError.
    """
    import pygltflib as g

    start = _read_bytes(path, SNIFF_CHARS)     # (its kind from its start: not a 1 GiB read)
    head = start.decode("utf-8", errors="replace")
    if start.startswith(USDC_MAGIC) or text_kind(head) == "usd":
        raise InputError("an OpenUSD file, not a glTF; `plantlod view` plays glTF only: export "
                         "the tree to .glb or .gltf", path)
    if start.startswith(ZIP_MAGIC):
        raise InputError("a zip archive (a tree or angles .npz?), not a glTF; `plantlod view` "
                         "plays the .glb or .gltf that `plantlod export` writes", path)
    glb = start[:4] == GLB_MAGIC or (path.lower().endswith(".glb")
                                     and not start.lstrip()[:1] == b"{")  # JSON named .glb: below
    if glb and start[:4] != GLB_MAGIC:
        check_glb_container(start, path)       # (refuses it by its magic)
    data = _read_bytes(path)
    binary_chunk = check_glb_container(data, path) if glb else False
    if not glb:                                # a .gltf's bytes that are not UTF-8, placed
        try:                                   # as every text reader places them
            data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise not_utf8(data, exc.start, path, "a .gltf file (JSON text)") from None
    check_raw_json(data, path)                 # (what the reader would cast or choke on)
    try:
        with warnings.catch_warnings():        # pygltflib warns on stderr; the checks below say it
            warnings.simplefilter("ignore")
            doc = g.GLTF2.load(path)
    except Exception as exc:                   # pygltflib raises what its parsers raise
        other = other_kind(head, path, "gltf")
        if other is None and isinstance(exc, json.JSONDecodeError) and data[:4] != GLB_MAGIC:
            # a .gltf's JSON: placed in the file as every reader places its errors (a GLB's
            # JSON chunk has lines of its own, not the file's)
            other = InputError(f"not a glTF file: its JSON is not valid ({exc.msg})", path,
                               exc.lineno, exc.colno)
        raise (other or InputError(f"not a glTF file ({_why(exc)})", path)) from None
    if doc is None or not isinstance(doc.nodes, list) or not doc.nodes:
        raise InputError("not a glTF file with nodes (expected `plantlod export` output)", path)
    if binary_chunk:
        check_glb_buffer(doc, path)
    check_buffer_uris(doc, path, VIEW_MAX_FILE_BYTES)
    _plain_buffer_uris(doc)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            doc.convert_buffers(g.BufferFormat.BINARYBLOB)
        blob = doc.binary_blob() or b""
    except Exception as exc:
        raise InputError(f"cannot read the glTF's buffers ({_why(exc)})",
                         path) from None
    check_document(doc, len(blob), path)
    check_animation_data(doc, blob, path)
    try:
        glb = b"".join(doc.save_to_bytes())
    except Exception as exc:
        raise InputError(f"not a glTF file plantlod can carry ({_why(exc)})",
                         path) from None
    asset = doc.asset
    extras = asset.extras if asset is not None and isinstance(asset.extras, dict) else {}
    mine = extras.get("plantlod")
    branches = mine.get("branches") if isinstance(mine, dict) else None
    ok = isinstance(branches, int) and not isinstance(branches, bool) and branches >= 0
    return glb, (branches if ok else None)


def _plain_buffer_uris(doc) -> None:
    """Buffer URIs as pygltflib reads them: glTF 2.0's own data-URI type
    (``data:application/gltf-buffer;base64,``) as ``application/octet-stream``, and a
    percent-encoded file name (``buf%2Ebin``) decoded (`check_buffer_uris` checked it)."""
    import urllib.parse

    for buffer in doc.buffers if isinstance(doc.buffers, list) else []:
        uri = getattr(buffer, "uri", None)
        if not isinstance(uri, str):
            continue
        if uri.startswith(GLTF_BUFFER_DATA_URI):
            buffer.uri = OCTET_STREAM_DATA_URI + uri[len(GLTF_BUFFER_DATA_URI):]
        elif not uri.startswith("data:"):
            buffer.uri = urllib.parse.unquote(uri)


def _why(exc: BaseException) -> str:
    """What pygltflib's parsers raised, said for a reader of the message, not as a Python
    exception's name (`RecursionError: maximum recursion depth exceeded …`)."""
    if isinstance(exc, RecursionError):
        return "its JSON is nested too deeply"
    if isinstance(exc, UnicodeError):
        return "its JSON is not UTF-8 text"
    if isinstance(exc, (AttributeError, TypeError, KeyError, IndexError)):
        return "a member is not of the kind glTF 2.0 gives it"
    if isinstance(exc, ValueError) and "int_max_str_digits" in str(exc):
        return "its JSON holds a whole number of more digits than Python reads (4,300)"
    return str(exc) or "unreadable"


def _read_bytes(path: str, count: int | None = None) -> bytes:
    """The file's bytes (its first ``count`` where given), refused beyond VIEW_MAX_FILE_BYTES
    before it is read."""
    from plantlod.formats.text_input import reading

    # /dev/zero or a pipe has no size to check (and opening a pipe waits for a writer), and
    # the glTF reader reads the path again: only regular files (a folder: open says so)
    with reading(path):
        mode = os.stat(path).st_mode
        if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
            raise InputError("not a regular file; expected a .glb or .gltf file "
                             "(`plantlod export` output)", path)
    with reading(path), open(path, "rb") as handle:
        info = os.fstat(handle.fileno())
        if info.st_size > VIEW_MAX_FILE_BYTES:
            raise InputError(f"the file has {info.st_size:,} bytes, more than the limit of "
                             f"{VIEW_MAX_FILE_BYTES:,}", path)
        data = handle.read(VIEW_MAX_FILE_BYTES + 1 if count is None else count)
    if len(data) > VIEW_MAX_FILE_BYTES:              # (grew while it was read)
        raise InputError(f"the file has more than {VIEW_MAX_FILE_BYTES:,} bytes, the limit", path)
    return data


def view_page(trees: Sequence[tuple[str, bytes, int | None]], wind_direction_deg: float = 0.0,
              title: str = VIEW_TITLE) -> str:
    """The page's HTML text for ``trees``, each (name, GLB bytes, branch count or None),
    drawn left to right; the wind arrow points toward ``wind_direction_deg`` (0 = +x,
    90 = +y, as simulate's --wind-direction)."""
    folder = resources.files("plantlod.export") / "viewer"
    data = {
        "title": title,
        "wind_direction_deg": float(wind_direction_deg),
        "trees": [{"name": name, "branches": branches,
                   "glb": base64.b64encode(glb).decode("ascii")} for name, glb, branches in trees],
    }
    parts = {
        # the data block's text must not open or close an element or a comment ("</script",
        # "<!--<script" kept the page's scripts as data: a helper's fuzzing, session 34):
        # every <, > and & is written as a JSON \u escape, which only strings can hold
        "DATA": json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
                .replace(">", "\\u003e").replace("&", "\\u0026"),
        "THREE": (folder / "three-bundle.js").read_text(encoding="utf-8"),
        "VIEWER": (folder / "viewer.js").read_text(encoding="utf-8"),
        "TITLE": _html_text(title),
    }
    # one pass over the template: odd pieces are the names between {{ }}, and text once
    # inserted is never searched again
    pieces = re.split(r"\{\{(" + "|".join(parts) + r")\}\}",
                      (folder / "page.html").read_text(encoding="utf-8"))
    return "".join(parts[p] if k % 2 else p for k, p in enumerate(pieces))


def view_page_from_files(paths: Sequence[str | os.PathLike], wind_direction_deg: float = 0.0,
                         title: str = VIEW_TITLE) -> str:
    """`view_page` of .glb / .gltf files, labelled by their file names."""
    trees = []
    for path in map(os.fspath, paths):
        glb, branches = glb_from_file(path)
        trees.append((os.path.basename(path), glb, branches))
    if not trees:
        raise InputError("no trees to show; give at least one .glb or .gltf file")
    return view_page(trees, wind_direction_deg, title)


def _html_text(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
