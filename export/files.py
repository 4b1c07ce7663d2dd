"""One table of exporters, chosen by the output's extension (as trimesh's exchange does)."""

from __future__ import annotations

import contextlib
import os

import numpy as np

from plantlod.lsys.checks import shown_value
from plantlod.lsys.errors import InputError, RunFailure, warn_caller
from plantlod.lsys.tree import Tree

from .constants import GLTF_MAX_TIME, MAX_EXPORT_SAMPLES, MAX_USD_DEPTH

FORMATS = (".glb", ".gltf", ".usda", ".usdc", ".usd")


def export_animation(path: str, tree: Tree, times: np.ndarray, bend: np.ndarray, rot: np.ndarray,
                     fps: float = 30.0, frames: tuple[int, int] | None = None,
                     angles_name: str | None = None, tree_name: str | None = None) -> None:
    """Write ``tree`` moving by ``bend``/``rot`` (K, B) at ``times`` (K,) to ``path``, atomically.
    ``angles_name``, ``tree_name``: the files the angles and the tree came from, named by
    errors about them. A tree reaching past MAX_EXTENT_M is refused, as compare and scene
    refuse it: its positions (float32 in glTF) were written as infinities (session 36)."""
    import math

    from plantlod.compare.runs import check_extent

    check_extent(tree, tree_name)

    span = float(times[-1]) * fps
    if not math.isfinite(span) or span + 1 > MAX_EXPORT_SAMPLES / max(tree.n_branches, 1):
        raise InputError(f"the angles run {float(times[-1]):g} s: at {fps:g} fps that is more "
                         f"frames than the limit of {MAX_EXPORT_SAMPLES:,} frames x branches "
                         f"({tree.n_branches:,} branches); expected a shorter run or a lower --fps",
                         angles_name)
    if not span >= 0:
        raise InputError(f"the angles end at {float(times[-1]):g} s, before 0 s: frames are at "
                         f"k / fps from 0 s; expected times that reach 0", angles_name)
    if not (np.isfinite(bend).all() and np.isfinite(rot).all()):
        raise InputError("the angles hold values that are not finite numbers", angles_name)
    if float(times[-1]) > GLTF_MAX_TIME:           # glTF keeps times as float32
        raise InputError(f"the angles run to {float(times[-1]):g} s, past the {GLTF_MAX_TIME:g} s "
                         "a glTF or OpenUSD time can hold; expected a shorter run", angles_name)
    count = int(math.floor(span + 1e-9)) + 1
    if frames is not None:
        if not 0 <= frames[0] < frames[1] <= count:
            raise InputError(f"frames {shown_value(frames[0])}:{shown_value(frames[1])} are "
                             f"outside the run's {count} frames (0:{count} at {fps:g} fps)")
    ext = os.path.splitext(path)[1].lower()
    if ext not in FORMATS:
        obj = " (OBJ frames of a tree: `plantlod compare --obj`)" if ext == ".obj" else ""
        raise InputError(f"cannot tell the format from {ext or 'no extension'!r}; expected one of "
                         f"{', '.join(FORMATS)}{obj}", path)
    if ext.startswith(".usd") and tree.depth() > MAX_USD_DEPTH:
        raise InputError(f"the tree is {tree.depth():,} branches deep, more than the "
                         f"{MAX_USD_DEPTH:,} an OpenUSD export nests (a prim per branch inside "
                         f"its parent's: the file grows with the square of the depth); expected "
                         f"a .glb or .gltf for this tree", path)
    if (count if frames is None else frames[1] - frames[0]) == 1:
        # (a glTF with no animation and its time accessor unused, said to run "0.01 s at 30
        # fps": a scene fuzzing round)
        what = (f"the run, {float(times[-1]):g} s, is shorter than one frame" if frames is None
                else f"frames {frames[0]}:{frames[1]}")
        warn_caller(f"one frame: {what} at {fps:g} fps, so the file holds one pose and no "
                    "animation; expected a longer run, a higher fps or more frames")
    from plantlod.formats.atomic import atomic_path, write_whole

    with atomic_path(path, suffix=ext) as tmp, _angles_named(angles_name):
        if ext in (".glb", ".gltf"):
            from .gltf import gltf_bytes, gltf_document

            data = gltf_bytes(gltf_document(tree, times, bend, rot, fps, frames), ext == ".glb")
            write_whole(tmp, data)
        else:
            if tmp == path:                       # a device or a pipe (`atomic_path`)
                raise InputError("OpenUSD writes a file of its own; expected the path of a "
                                 "regular file", path)
            os.unlink(tmp)                        # USD creates its own file
            from .usd import UsdWriteError, write_usd

            try:
                write_usd(tmp, tree, times, bend, rot, fps, frames)
            except UsdWriteError as exc:     # (its reason names the temporary, not the path)
                raise RunFailure(f"cannot write {path}: {str(exc).replace(tmp, path)}") from None


@contextlib.contextmanager
def _angles_named(name: str | None):
    """An InputError naming no file, raised while the poses are built (`gltf.local_transforms`:
    angles whose frames are not finite), names the angles' file."""
    try:
        yield
    except InputError as exc:
        if exc.file is not None or name is None:
            raise
        raise InputError(exc.message, name) from None
