"""Trees and angles as numpy `.npz` archives: lossless, fast to read, chosen by extension.

Tree archive (`format` = "plantlod-tree-npz", `version` = 1): every array field of
`plantlod.lsys.tree.Tree` under its own name (float64/int64 as in memory), the string
lists (`address`, `symbol`, `leaf_address`, `group_root`) as unicode arrays, and
`leaf_force_scale`, `source` as 0-d arrays. Angles archive (`format` =
"plantlod-angles-npz"): `time` (T,) s, `address` (B,), `bend` and `rotation` (T, B) radians.
Read with ``allow_pickle=False``; a missing or misshapen entry is an `InputError`.
"""

from __future__ import annotations

import dataclasses
import io
import zipfile

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree

TREE_FORMAT = "plantlod-tree-npz"
ANGLES_FORMAT = "plantlod-angles-npz"
_STRINGS = ("address", "symbol", "leaf_address", "group_root")


def is_npz(path: str | None) -> bool:
    return bool(path) and str(path).lower().endswith(".npz")


def tree_bytes(tree: Tree) -> bytes:
    fields = {}
    for f in dataclasses.fields(tree):
        value = getattr(tree, f.name)
        if value is None:                  # force_gain of a tree without gain matrices
            continue
        if f.name in _STRINGS:
            fields[f.name] = np.array(list(value), dtype=str)
        elif f.name in ("leaf_force_scale", "source"):
            fields[f.name] = np.array(value)
        else:
            fields[f.name] = np.asarray(value)
    out = io.BytesIO()
    np.savez(out, format=np.array(TREE_FORMAT), version=np.array(1), **fields)
    return out.getvalue()


def _load(data: bytes, source: str, kind: str):
    try:
        archive = np.load(io.BytesIO(data), allow_pickle=False)
        if str(archive["format"]) != kind:
            raise InputError(f"not a {kind} archive (format {str(archive['format'])!r})", source)
        return archive
    except (zipfile.BadZipFile, ValueError, KeyError, OSError) as exc:
        raise InputError(f"not a readable {kind} archive: {exc}", source) from None


def read_tree_bytes(data: bytes, source: str) -> Tree:
    archive = _load(data, source, TREE_FORMAT)
    values = {}
    try:
        for f in dataclasses.fields(Tree):
            if f.name not in archive.files:
                if f.name in ("group_root", "force_gain"):     # optional: levels only
                    values[f.name] = [] if f.name == "group_root" else None
                    continue
                raise InputError(f"the archive has no {f.name!r}", source)
            a = archive[f.name]
            if f.name in _STRINGS:
                values[f.name] = [str(s) for s in a.tolist()]
            elif f.name == "leaf_force_scale":
                values[f.name] = float(a)
            elif f.name == "source":
                values[f.name] = str(a)
            else:
                values[f.name] = a
    except ValueError as exc:
        raise InputError(f"not a readable tree archive: {exc}", source) from None
    tree = Tree(**values)
    try:
        tree.check()
    except (ValueError, InputError) as exc:
        raise InputError(f"the archive's tree is inconsistent: {exc}", source) from None
    return tree


def angles_bytes(times: np.ndarray, addresses: list[str], bend: np.ndarray, rot: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.savez(out, format=np.array(ANGLES_FORMAT), version=np.array(1), time=np.asarray(times),
             address=np.array(list(addresses), dtype=str), bend=np.asarray(bend),
             rotation=np.asarray(rot))
    return out.getvalue()


def read_angles_bytes(data: bytes, source: str) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """(times (T,), addresses [B], bend (T, B), rot (T, B)), as `read_angles_csv` returns them."""
    archive = _load(data, source, ANGLES_FORMAT)
    try:
        t, b, r = archive["time"], archive["bend"], archive["rotation"]
        addresses = [str(s) for s in archive["address"].tolist()]
    except KeyError as exc:
        raise InputError(f"the archive has no {exc}", source) from None
    if t.ndim != 1 or b.shape != (len(t), len(addresses)) or r.shape != b.shape:
        raise InputError(f"the archive's shapes disagree: time {t.shape}, bend {b.shape}, "
                         f"rotation {r.shape}, {len(addresses)} addresses", source)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(b)) and np.all(np.isfinite(r))):
        raise InputError("the archive holds values that are not finite", source)
    return t, addresses, b, r
