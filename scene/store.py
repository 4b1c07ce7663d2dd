"""A scene's angles as a zarr store (docs/scene.md, "--angles").

    STORE.zarr/
      levels                    (N, F) int16  each tree's level during each frame
      file_<i>/trees            (n,) int32    the scene trees of chain i (a file, and a seed
                                              where given), in row order
      file_<i>/level_<l>/bend   (n, R, B_l) float32 rad, NaN where the tree ran at another level
      file_<i>/level_<l>/rotation
      file_<i>                  attrs: file (and seed, where the trees are grown from one
                                of their own); level_<l> attrs: addresses
      (root attrs: dt, the seconds between rows)

Row r (0-based) is time (r + 1) · every · dt, the end of frame r; the rest state at t = 0
is not stored. A tree's angles at row r are in the level group ``levels[k, r]`` names.
Chunks are (STORE_BATCH_TREES, STORE_TIME_CHUNK, B_l): the trees of one batch fill their
own chunks, so workers of a cluster never write the same chunk.
"""

from __future__ import annotations

import os

import numpy as np

from plantlod.formats.atomic import uninterrupted
from plantlod.lsys.errors import RunFailure

from .constants import STORE_BATCH_TREES, STORE_TIME_CHUNK


def open_store(path: str, levels: np.ndarray, files: list[tuple[str, list[int], list, int | None]],
               rows: int, dt: float):
    """Create the store at ``path`` (a new folder): every array, filled with NaN.

    levels : (N, F) int16; files: per source (a file and its seed, `scene.file.Source`) its
    file name, its scene trees (row order), its level trees (for the branch counts and
    addresses) and its seed (None: the file's own); rows: R; dt: seconds between rows.
    """
    import zarr

    from .rooted_store import RootedStore

    # each write held against a signal until its chunks have landed (`uninterrupted`), one
    # tree level at a time, so that a signal waits milliseconds, not the whole store; the
    # store never makes its folder again once it is removed (`rooted_store`: a full disk
    # failed one chunk, the temporary store was removed, and zarr's other chunk writes, still
    # running, made its folders again: session 42's fuzzing)
    with uninterrupted():
        if not os.path.isdir(path):       # (a new folder: its parent there, as zarr's "w-")
            os.mkdir(path)
        group = zarr.open_group(RootedStore(path), mode="w-")
        group.attrs["dt"] = float(dt)
        arr = group.create_array("levels", shape=levels.shape, dtype="int16",
                                 chunks=(min(max(len(levels), 1), STORE_BATCH_TREES),
                                         max(1, min(levels.shape[1], STORE_TIME_CHUNK))))
        arr[:] = levels
    for i, (name, members, trees, seed) in enumerate(files):
        with uninterrupted():
            sub = group.create_group(f"file_{i}")
            sub.attrs["file"] = name
            if seed is not None:              # the tree grown from another seed than the file's
                sub.attrs["seed"] = int(seed)
            t = sub.create_array("trees", shape=(len(members),), dtype="int32",
                                 chunks=(max(len(members), 1),))
            t[:] = np.asarray(members, dtype=np.int32)
        for level, tree in enumerate(trees):
            shape = (len(members), rows, tree.n_branches)
            chunks = (min(max(len(members), 1), STORE_BATCH_TREES),
                      max(1, min(rows, STORE_TIME_CHUNK)), max(tree.n_branches, 1))
            with uninterrupted():
                lv = sub.create_group(f"level_{level}")
                lv.attrs["addresses"] = list(tree.address)
                for name_ in ("bend", "rotation"):
                    lv.create_array(name_, shape=shape, dtype="float32", chunks=chunks,
                                    fill_value=np.nan)
    return group


def write_block(group, file_index: int, level: int, first: int, row0: int,
                bend: np.ndarray, rot: np.ndarray) -> None:
    """Rows row0 .. row0+K-1 of a batch's trees (rows first .. first+n-1 of file
    ``file_index``'s arrays) at ``level``: ``bend``/``rot`` (n, K, B) float64, NaN for the
    trees that ran at another level then. One write per array, within the batch's chunks."""
    if bend.shape[1] == 0:
        return
    try:
        lv = group[f"file_{file_index}/level_{level}"]
    except KeyError:                      # (its metadata gone: zarr says KeyError)
        # (not named: the store is a temporary folder beside --angles until the scene ends)
        raise RunFailure("cannot write the --angles store: its arrays are gone (its folder "
                         "removed while the scene ran?)") from None
    n, k = bend.shape[:2]

    with uninterrupted():                 # (chunks in flight land before a signal ends it)
        lv["bend"][first:first + n, row0:row0 + k, :] = bend.astype(np.float32)
        lv["rotation"][first:first + n, row0:row0 + k, :] = rot.astype(np.float32)


def settle_writes() -> None:
    """Wait for the chunk writes still in flight on zarr's event loop, their failures
    retrieved. A write that fails (a full disk) raises at once, while zarr's other chunk
    writes run on (of the same assignment, of other engine threads, of the store's own
    arrays as it is made): whoever removes the store after a failure calls this first
    (`scene --angles`), else they ran on under the removed folder and at exit asyncio
    printed their tasks destroyed pending (session 42's fuzzing)."""
    import asyncio

    from zarr.core.sync import sync

    async def pending() -> None:
        while True:                       # (a write in flight may start others)
            others = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
            if not others:
                return
            await asyncio.gather(*others, return_exceptions=True)

    try:
        sync(pending())
    except Exception:                     # (the loop gone: nothing is left in flight)
        pass
