"""Reading a 390,625-branch tree (ABOP 1.24a, n = 8) as JSON lines and as .npz.

    .venv/bin/python bench/run.py npz
"""

from __future__ import annotations

import io
import pathlib
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def run(report) -> None:
    import plantlod
    from plantlod.formats.npz import read_tree_bytes, tree_bytes
    from plantlod.formats.treefile import read_tree

    tree = plantlod.derive(plantlod.read_lsystem(ROOT / "examples" / "abop_1_24a.lsys"), 8)
    text = plantlod.write_tree(tree)
    data = tree_bytes(tree)
    begin = time.perf_counter()
    read_tree(io.StringIO(text), "json")
    json_s = time.perf_counter() - begin
    best = float("inf")
    for _ in range(3):
        begin = time.perf_counter()
        read_tree_bytes(data, "npz")
        best = min(best, time.perf_counter() - begin)
    cmd = "python bench/run.py npz"
    report(f"tree file read, {tree.n_branches:,} branches: JSON lines", json_s, "s", "", cmd)
    report(f"tree file read, {tree.n_branches:,} branches: .npz", best, "s", "", cmd)
    report("tree read: JSON lines / .npz", json_s / best, "x", ">= 20", cmd)
