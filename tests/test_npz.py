"""`.npz` trees and angles (formats/npz.py): lossless against the in-memory values, chosen by
the extension in derive, simulate, tree loading and export; a bad archive is exit 2."""

from __future__ import annotations

import dataclasses

import numpy as np

import plantlod
from golden_util import ROOT, run_cli
from plantlod.formats.npz import read_angles_bytes, read_tree_bytes


def test_tree_and_angles_round_trip_exactly(tmp_path):
    lsys = str(ROOT / "examples" / "eval" / "twin_draw.lsys")
    run_cli("derive", lsys, "-o", str(tmp_path / "t.npz"))
    tree = plantlod.derive(plantlod.read_lsystem(lsys))
    back = read_tree_bytes((tmp_path / "t.npz").read_bytes(), "t.npz")
    for f in dataclasses.fields(tree):
        a, b = getattr(tree, f.name), getattr(back, f.name)
        assert (np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b), f.name
    run_cli("simulate", str(tmp_path / "t.npz"), "--dt", "0.01", "--steps", "60", "--wind-speed",
            "4", "-o", str(tmp_path / "a.npz"))
    times, addresses, bend, rot = read_angles_bytes((tmp_path / "a.npz").read_bytes(), "a.npz")
    direct = plantlod.simulate(tree, wind=(4.0, 0.0, 0.0), dt=0.01, steps=60)
    assert addresses == list(tree.address)
    assert np.array_equal(times, direct.time) and np.array_equal(bend, direct.bend)
    assert np.array_equal(rot, direct.rotation)


def test_a_bad_archive_is_exit_2(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    result = run_cli("simulate", str(bad), "--dt", "0.01", "--steps", "5", "--wind-speed", "1",
                     exit_code=2)
    assert "bad.npz" in result.stderr and "archive" in result.stderr
    np.savez(tmp_path / "other.npz", format=np.array("something-else"))
    result = run_cli("simulate", str(tmp_path / "other.npz"), "--dt", "0.01", "--steps", "5",
                     "--wind-speed", "1", exit_code=2)
    assert "not a plantlod-tree-npz archive" in result.stderr
