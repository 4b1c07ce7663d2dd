"""Trees and angles as numpy `.npz` archives: lossless, fast to read, chosen by extension.

Tree archive (`format` = "plantlod-tree-npz", `version` = 1): every array field of
`plantlod.lsys.tree.Tree` under its own name (float64/int64 as in memory), the string
lists (`address`, `symbol`, `leaf_address`, `group_root`) as unicode arrays, and
`leaf_force_scale`, `source` as 0-d arrays. Angles archive (`format` =
"plantlod-angles-npz"): `time` (T,) s, `address` (B,), `bend` and `rotation` (T, B) radians.
Read with ``allow_pickle=False``, after every member's declared shape, type and uncompressed
size are checked against the limits (formats/constants.py) from the zip directory and the
.npy headers alone; a missing, misshapen or mistyped entry is an `InputError` naming the file.
"""

from __future__ import annotations

import dataclasses
import io
import lzma
import math
import os
import re
import stat
import tokenize
import zipfile
import zlib

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import BRANCH_FLOAT_FIELDS, Tree, is_symbol

from .constants import MAX_NPZ_BYTES, MAX_NPZ_MEMBERS, NORMAL_UNIT_TOL, ZIP_SIGNATURES
from .text_input import reading, source_name, stdin_bytes
from .treefile import ADDRESS_FORM, first_bad_address

TREE_FORMAT = "plantlod-tree-npz"
ANGLES_FORMAT = "plantlod-angles-npz"
ARCHIVE_VERSION = 1          # `version` of both archives (read: exactly this)
_STRINGS = ("address", "symbol", "leaf_address", "group_root")
# where an .lsys wrote each group, where a tree file held each branch (messages), not the tree
_NOT_STORED = ("group_line", "first_record_line")
ALLOWED_KINDS = "biufU"     # booleans, integers, floats, unicode text: nothing that needs pickle
# What a damaged member raises while it is decompressed or laid out (zlib's and lzma's own
# errors escaped as internal errors; bz2 raises OSError), besides zipfile's and numpy's
DAMAGED_ARCHIVE_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, EOFError,
                          OSError, ValueError, RuntimeError, KeyError, zlib.error, lzma.LZMAError,
                          OverflowError)


def is_npz(path: str | None) -> bool:
    return bool(path) and str(path).lower().endswith(".npz")


def tree_bytes(tree: Tree) -> bytes:
    fields = {}
    for f in dataclasses.fields(tree):
        value = getattr(tree, f.name)
        if value is None or f.name in _NOT_STORED:   # force_gain, swing_roll of a tree without them
            continue
        if f.name in _STRINGS:
            fields[f.name] = np.array(list(value), dtype=str)
        elif f.name in ("leaf_force_scale", "source"):
            fields[f.name] = np.array(value)
        else:
            fields[f.name] = np.asarray(value)
    out = io.BytesIO()
    np.savez(out, format=np.array(TREE_FORMAT), version=np.array(ARCHIVE_VERSION), **fields)
    return out.getvalue()


def read_npz_file(path: str) -> bytes:
    """The bytes of the archive ``path`` (``-``: stdin), refused beyond MAX_NPZ_BYTES; a file
    that cannot be read is an `InputError` naming it, as for text inputs.

    Refused before it is read: a regular file larger than the limit (its size), and any
    input whose first bytes are not a zip file's (`ZIP_SIGNATURES`), so that /dev/zero or a
    large file of something else is not read whole (2 GiB) only to be refused."""
    name = source_name(path)
    with reading(name):
        if path == "-":
            data = _read_archive(stdin_bytes(name), name)
        else:
            with open(path, "rb") as handle:
                size = os.fstat(handle.fileno())
                if stat.S_ISREG(size.st_mode) and size.st_size > MAX_NPZ_BYTES:
                    raise _too_large(name)
                data = _read_archive(handle, name)
    return data


def _too_large(name: str) -> InputError:
    return InputError(f"the archive is larger than the limit of {MAX_NPZ_BYTES:,} bytes", name)


def _read_archive(handle, name: str) -> bytes:
    """At most MAX_NPZ_BYTES from ``handle``, the zip signature checked on its first bytes."""
    head = handle.read(len(ZIP_SIGNATURES[0]))
    if not any(head == sig for sig in ZIP_SIGNATURES):
        raise InputError("not a readable archive: File is not a zip file (an .npz starts with "
                         "the bytes 'PK')", name)
    data = head + handle.read(MAX_NPZ_BYTES + 1 - len(head))
    if len(data) > MAX_NPZ_BYTES:
        raise _too_large(name)
    return data


def _header(member, name: str, source: str) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and dtype an .npy member declares, read from its header alone."""
    from numpy.lib import format as npy

    try:
        version = npy.read_magic(member)
        if version == (1, 0):
            shape, _, dtype = npy.read_array_header_1_0(member)
        elif version == (2, 0):
            shape, _, dtype = npy.read_array_header_2_0(member)
        else:
            raise ValueError(f"unsupported .npy version {version}")
    except (ValueError, SyntaxError, TypeError, EOFError, tokenize.TokenError) as exc:
        # (a header cut short inside its dict: numpy's tokenizer raises TokenError)
        reason = "its header is cut short" if isinstance(exc, tokenize.TokenError) else _reason(exc)
        raise InputError(f"{name!r} in the archive is not a readable array: {reason}",
                         source) from None
    return tuple(int(n) for n in shape), dtype


def _checked_members(data: bytes, source: str) -> None:
    """Refuse, before anything is decompressed, an archive whose members would not fit the
    limits: more than MAX_NPZ_MEMBERS, an uncompressed total beyond MAX_NPZ_BYTES, a
    declared shape larger than the member's data, or a type that is not numbers or text
    (object arrays, which would need pickle, included)."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            infos = archive.infolist()
            if len(infos) > MAX_NPZ_MEMBERS:
                raise InputError(f"the archive holds {len(infos):,} members, more than the "
                                 f"limit of {MAX_NPZ_MEMBERS}", source)
            total = sum(info.file_size for info in infos)
            if total > MAX_NPZ_BYTES:
                raise InputError(f"the archive expands to {total:,} bytes, more than the limit "
                                 f"of {MAX_NPZ_BYTES:,}", source)
            for info in infos:
                name = info.filename.removesuffix(".npy")
                with archive.open(info) as member:
                    shape, dtype = _header(member, name, source)
                if dtype.hasobject or dtype.kind not in ALLOWED_KINDS:
                    raise InputError(f"{name!r} in the archive is an array of {dtype}; expected "
                                     "numbers or text", source)
                if any(n > np.iinfo(np.intp).max for n in shape):   # (0, 10**30) holds 0 bytes
                    raise InputError(f"{name!r} in the archive declares shape {shape}, past "
                                     "what an array can hold", source)
                size = math.prod(shape) * dtype.itemsize
                if size > info.file_size:
                    raise InputError(f"{name!r} in the archive declares shape {shape} of {dtype} "
                                     f"({size:,} bytes) but holds {info.file_size:,} bytes",
                                     source)
    except DAMAGED_ARCHIVE_ERRORS as exc:
        raise InputError(f"not a readable archive: {_reason(exc)}", source) from None


def _reason(exc: BaseException) -> str:
    """What went wrong, in words: ast.literal_eval names the node it refused by its repr
    (`<ast.Call object at 0x7f…>`, an address that changes from run to run); its kind is said."""
    text = str(exc) or type(exc).__name__
    return re.sub(r"<ast\.(\w+) object at 0x[0-9a-fA-F]+>",
                  lambda m: f"a {m.group(1)} where a literal belongs", text)


def _load(data: bytes, source: str, kind: str) -> dict[str, np.ndarray]:
    """Every array of the archive (checked first by `_checked_members`), by name."""
    _checked_members(data, source)
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            arrays = {name: archive[name] for name in archive.files}
    except DAMAGED_ARCHIVE_ERRORS as exc:
        raise InputError(f"not a readable {kind} archive: {_reason(exc)}", source) from None
    label = arrays.get("format")
    if label is None or label.shape != () or label.dtype.kind != "U" or str(label) != kind:
        found = f" (format {str(label)!r})" if label is not None and label.size == 1 else ""
        raise InputError(f"not a {kind} archive{found}", source)
    version = arrays.get("version")
    if (version is None or version.shape != () or version.dtype.kind not in "iu"
            or int(version) != ARCHIVE_VERSION):
        shown = version.tolist() if version is not None and version.size < 8 else "missing"
        raise InputError(f"{kind} archive version {shown!r} is not supported; expected "
                         f"{ARCHIVE_VERSION} (written by this plantlod)", source)
    return arrays


def _refuse_unknown(arrays: dict, known: set[str], kind: str, source: str) -> None:
    """InputError for a member the archive's kind has no place for (as a tree file refuses an
    unknown key; such members were dropped without a word, session 36)."""
    unknown = sorted(set(arrays) - known)
    if unknown:
        raise InputError(f"the archive holds {unknown[0][:60]!r}, which a {kind} archive has no "
                         f"place for; expected only {', '.join(sorted(known))}", source)


def _need(arrays: dict, name: str, source: str) -> np.ndarray:
    if name not in arrays:
        raise InputError(f"the archive has no {name!r}", source)
    return arrays[name]


def _numbers(arrays: dict, name: str, source: str, shape: tuple, integer: bool = False,
             non_negative: bool = False, positive: bool = False) -> np.ndarray:
    """Array ``name``: of ``shape`` (None: any length there), real numbers (whole numbers for
    ``integer``), all finite (and >= 0 for ``non_negative``, > 0 for ``positive``), as
    float64 or int64."""
    a = _need(arrays, name, source)
    if a.ndim != len(shape) or any(want is not None and got != want
                                   for got, want in zip(a.shape, shape)):
        want = "(" + ", ".join("N" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
        raise InputError(f"{name!r} in the archive has shape {a.shape}; expected {want}", source)
    kinds = "iu" if integer else "biuf"
    if a.dtype.kind not in kinds:
        raise InputError(f"{name!r} in the archive holds {a.dtype}; expected "
                         f"{'whole numbers' if integer else 'numbers'}", source)
    out = a.astype(np.int64 if integer else np.float64)
    if integer and a.dtype.kind == "u" and a.size and int(a.max()) > np.iinfo(np.int64).max:
        raise InputError(f"{name!r} in the archive holds values beyond int64", source)
    if not integer and not np.all(np.isfinite(out)):
        raise InputError(f"{name!r} in the archive holds values that are not finite", source)
    if non_negative and np.any(out < 0):
        raise InputError(f"{name!r} in the archive holds negative values; expected amounts >= 0",
                         source)
    if positive and not np.all(out > 0):
        i = int(np.flatnonzero(~(out > 0))[0])
        raise InputError(f"{name!r} in the archive is {out[i]:g} at index {i}; expected "
                         "strengths > 0", source)
    return out


def _strings(arrays: dict, name: str, source: str, pattern=None) -> list[str]:
    a = _need(arrays, name, source)
    if a.ndim != 1 or a.dtype.kind != "U":
        raise InputError(f"{name!r} in the archive must be a list of text (1-D unicode), got "
                         f"{a.dtype} of shape {a.shape}", source)
    out = a.tolist()                              # (Python str, from a unicode array)
    if pattern is not None:
        bad = first_bad_address(out, pattern)
        if bad is not None:
            raise InputError(f"{name!r} in the archive holds {bad[:60]!r}, not an address "
                             f"({ADDRESS_FORM}, like '0.2.1')", source)
    return out


def read_tree_bytes(data: bytes, source: str) -> Tree:
    """The tree of an archive written by `tree_bytes`; every field checked (types, shapes,
    finite amounts, addresses, parents before children) as the tree-file reader checks."""
    from .treefile import BRANCH_ADDRESS, LEAF_ADDRESS, NON_NEGATIVE_FIELDS, POSITIVE_FIELDS

    arrays = _load(data, source, TREE_FORMAT)
    _refuse_unknown(arrays, {"format", "version"} | {f.name for f in dataclasses.fields(Tree)
                                                     if f.name not in _NOT_STORED},
                    TREE_FORMAT, source)
    values: dict = {}
    values["parent"] = _numbers(arrays, "parent", source, (None,), integer=True)
    b = len(values["parent"])
    for name in BRANCH_FLOAT_FIELDS:
        values[name] = _numbers(arrays, name, source, (b,), non_negative=name in NON_NEGATIVE_FIELDS,
                                positive=name in POSITIVE_FIELDS)
    values["euler"] = _numbers(arrays, "euler", source, (b, 3))
    values["offset"] = _numbers(arrays, "offset", source, (b, 3))
    values["leaf_branch"] = _numbers(arrays, "leaf_branch", source, (None,), integer=True)
    f = len(values["leaf_branch"])
    values["leaf_area"] = _numbers(arrays, "leaf_area", source, (f,), non_negative=True)
    values["leaf_normal"] = _numbers(arrays, "leaf_normal", source, (f, 3))
    values["address"] = _strings(arrays, "address", source, BRANCH_ADDRESS)
    values["symbol"] = _strings(arrays, "symbol", source)
    long = next((s for s in values["symbol"] if not is_symbol(s)), None)
    if long is not None:
        raise InputError(f"'symbol' in the archive holds {long[:60]!r}; expected one character "
                         "a branch (not a control character nor half a surrogate pair)", source)
    values["leaf_address"] = _strings(arrays, "leaf_address", source, LEAF_ADDRESS)
    values["group_root"] = (_strings(arrays, "group_root", source, BRANCH_ADDRESS)
                            if "group_root" in arrays else [])
    if values["group_root"] and len(values["group_root"]) != b:
        raise InputError(f"'group_root' in the archive holds {len(values['group_root'])} "
                         f"addresses for {b} branches; expected one a branch (or none)", source)
    # a level's gain matrices (model.md 5): optional, (B, 6)
    values["force_gain"] = (_numbers(arrays, "force_gain", source, (b, 6))
                            if "force_gain" in arrays else None)
    # a level's swing rolls (radians, `Tree.swing_roll`): optional, (B,)
    values["swing_roll"] = (_numbers(arrays, "swing_roll", source, (b,))
                            if "swing_roll" in arrays else None)
    scale = _numbers(arrays, "leaf_force_scale", source, (), non_negative=True)
    values["leaf_force_scale"] = float(scale)
    label = _need(arrays, "source", source)
    if label.shape != () or label.dtype.kind != "U":
        raise InputError(f"'source' in the archive must be one text, got {label.dtype} of shape "
                         f"{label.shape}", source)
    values["source"] = str(label)
    norms = np.sqrt((values["leaf_normal"] ** 2).sum(axis=1))
    if np.any(np.abs(norms - 1.0) > NORMAL_UNIT_TOL):
        raise InputError(f"'leaf_normal' in the archive holds vectors that are not unit "
                         f"(length within {NORMAL_UNIT_TOL:g} of 1)", source)
    tree = Tree(**values)
    try:
        tree.check()
    except (ValueError, InputError) as exc:
        raise InputError(f"the archive's tree is inconsistent: {exc}", source) from None
    if len(set(tree.address)) != b:
        raise InputError("the archive's tree repeats a branch address; branch addresses are "
                         "unique", source)
    return tree


def angles_bytes(times: np.ndarray, addresses: list[str], bend: np.ndarray, rot: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.savez(out, format=np.array(ANGLES_FORMAT), version=np.array(ARCHIVE_VERSION), time=np.asarray(times),
             address=np.array(list(addresses), dtype=str), bend=np.asarray(bend),
             rotation=np.asarray(rot))
    return out.getvalue()


def read_angles_bytes(data: bytes, source: str) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """(times (T,), addresses [B], bend (T, B), rot (T, B)), as `read_angles_csv` returns them."""
    from .treefile import BRANCH_ADDRESS

    arrays = _load(data, source, ANGLES_FORMAT)
    _refuse_unknown(arrays, {"format", "version", "time", "address", "bend", "rotation"},
                    ANGLES_FORMAT, source)
    addresses = _strings(arrays, "address", source, BRANCH_ADDRESS)
    t = _numbers(arrays, "time", source, (None,))
    b = _numbers(arrays, "bend", source, (len(t), len(addresses)))
    r = _numbers(arrays, "rotation", source, (len(t), len(addresses)))
    if len(t) == 0:
        raise InputError("the archive holds no time samples", source)
    if np.any(np.diff(t) <= 0):
        raise InputError("'time' in the archive must increase", source)
    if len(set(addresses)) != len(addresses):
        raise InputError("the archive repeats a branch address; expected one column per branch",
                         source)
    return t, addresses, b, r
