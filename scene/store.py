"""A scene's angles as a zarr store (docs/scene.md, "--angles"): one group per batch of trees
that stepped together (one file at one level), so every writer fills whole chunks of its own.

    STORE.zarr/
      levels              (N,) int16    each tree's level (the camera is fixed: one per run)
      batch_<k>/bend      (W, T, B) float32 radians, chunked (BATCH_TREES, TIME_CHUNK, B)
      batch_<k>/rotation  (W, T, B) float32
      batch_<k>/trees     (W,) int32    which scene trees the lanes are
      batch_<k>           attrs: file, level, addresses, dt (s between rows)

Rows are frames 1 .. T (t = k · dt; the rest state at t = 0 is not stored).
"""

from __future__ import annotations

import numpy as np

from .constants import STORE_BATCH_TREES, STORE_TIME_CHUNK


def open_store(path: str, levels: np.ndarray):
    """A new zarr group at ``path`` (replacing nothing: the caller writes to a fresh folder)."""
    import zarr

    group = zarr.open_group(path, mode="w-")
    arr = group.create_array("levels", shape=levels.shape, dtype="int16", chunks=levels.shape)
    arr[:] = levels
    return group


def write_batch(group, index: int, file: str, level: int, members: list[int], tree,
                bend: np.ndarray, rot: np.ndarray, dt: float) -> None:
    """Write one batch: ``bend``/``rot`` (W, T, B) float64, stored as float32."""
    sub = group.create_group(f"batch_{index}")
    sub.attrs.update({"file": file, "level": int(level), "addresses": list(tree.address),
                      "dt": float(dt)})
    w, t, b = bend.shape
    chunks = (min(w, STORE_BATCH_TREES), max(1, min(t, STORE_TIME_CHUNK)), max(b, 1))
    for name, values in (("bend", bend), ("rotation", rot)):
        arr = sub.create_array(name, shape=bend.shape, dtype="float32", chunks=chunks)
        arr[:] = values.astype(np.float32)
    trees = sub.create_array("trees", shape=(w,), dtype="int32", chunks=(max(w, 1),))
    trees[:] = np.asarray(members, dtype=np.int32)
