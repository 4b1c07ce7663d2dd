"""`evaluate.Runs` reads the original's runs a piece of time at a time, every wind at once
(`simulate_pieces`), where no caller gives it the runs: its combined angles, tips and figures
must be the bits it reads from the whole runs of `simulate_runs`, one wind at a time, for
any piece size (gusts, a sample kept every few steps and a run that is not a whole number of
them, a wind count that is no multiple of a lane block, damping included)."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import plantlod.simplify.evaluate as evaluate
from plantlod.lsys.build import build
from plantlod.lsys.parse import parse_lsys
from plantlod.simplify.evaluate import Runs, WindCase, simulate_runs
from plantlod.simplify.grouping import merge_levels
from plantlod.simplify.targets import GroupMap
from plantlod.compare.groups import main_paths

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _level_one(name: str):
    """The original of examples/NAME and the group map of its first merged level."""
    system = parse_lsys((ROOT / "examples" / name).read_text(), name)
    tree = build(system).tree
    grouping = merge_levels(tree, up_to=1)[1]
    return tree, GroupMap(grouping.group, main_paths(tree, grouping.group, grouping.count))


@pytest.mark.parametrize("name, piece_bytes, damping", [
    ("eval/sympodial.lsys", 10**9, 0.0),         # one piece
    ("eval/sympodial.lsys", 20_000, 0.0),        # a few samples a piece
    ("eval/bush3d.lsys", 1, 0.01),               # one sample a piece
])
def test_runs_read_in_pieces_are_the_runs_read_whole(monkeypatch, name, piece_bytes, damping):
    tree, gmap = _level_one(name)
    winds = [WindCase(2.0, 0.0), WindCase(5.0, 90.0), WindCase(1.0, 45.0, 0.4, 7),
             WindCase(8.0, 200.0), WindCase(3.0, 300.0, 0.2, 3)]
    dt, steps, every = 0.01, 301, 4
    whole = Runs(tree, gmap, winds, dt, steps, every, damping=damping,
                 simulated=list(simulate_runs(tree, winds, dt, steps, every, damping)))
    monkeypatch.setattr(evaluate, "RUNS_PIECE_BYTES", piece_bytes)
    pieces = Runs(tree, gmap, winds, dt, steps, every, damping=damping)
    assert len(pieces.runs) == len(whole.runs) == len(winds)
    for a, b in zip(whole.runs, pieces.runs):
        assert a.wind == b.wind
        for field in ("times", "combined_b", "combined_r", "rest_tips", "tip_moves"):
            x, y = getattr(a, field), getattr(b, field)
            assert x.shape == y.shape and x.dtype == y.dtype
            assert x.tobytes() == y.tobytes(), field
        assert np.abs(a.combined_b).max() > 0 and np.abs(a.tip_moves).max() > 0

