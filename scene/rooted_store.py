"""A zarr store that writes only into a folder that still exists (`scene --scheduler`).

A Dask worker writes its batch's chunks of the scene's store (docs/scene.md, "--angles")
while the command that made the store may already be gone: a signal ends it, and its
handler removes the temporary store at once (`formats.atomic.remove_folder`). The worker's
task runs on; zarr's `LocalStore` makes every missing folder on a chunk's path
(``mkdir(parents=True)``), so its next chunk would make the removed store again, partly
filled, beside the output the command never wrote.

`RootedStore` makes the missing folders below its root one at a time (``os.mkdir``) and
opens the chunk's file without making any: where the root is gone (renamed away by the
handler), the write fails with FileNotFoundError and nothing is made.
"""

from __future__ import annotations

import asyncio
import os
from pathlib import Path

from zarr.abc.store import Store
from zarr.storage import LocalStore


def put_below(root: Path, path: Path, data, exclusive: bool = False) -> int:
    """Write ``data`` (bytes-like) to the file ``path`` under the folder ``root``, making the
    folders between them but never ``root`` or anything above it. FileNotFoundError where
    ``root`` does not exist; FileExistsError with ``exclusive`` where the file does."""
    folder = root
    for part in path.parent.relative_to(root).parts:
        folder = folder / part
        try:
            os.mkdir(folder)
        except FileExistsError:
            pass
    with open(path, "xb" if exclusive else "wb") as f:
        return f.write(data)


class RootedStore(LocalStore):
    """`LocalStore` whose writes make no folder above its root (module docstring)."""

    async def _open(self, *, mode=None) -> None:
        if not self.root.is_dir():
            raise FileNotFoundError(f"the store {self.root} is gone")
        await Store._open(self)                  # (LocalStore's would make the root)

    async def _set(self, key: str, value, exclusive: bool = False) -> None:
        if not self._is_open:
            await self._open()
        self._check_writable()
        await asyncio.to_thread(put_below, self.root, self.root / key, value.as_buffer_like(),
                                exclusive)
