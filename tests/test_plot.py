"""`plantlod compare --plot` (compare/plot.py): the PNG, its determinism, and life without matplotlib."""

from __future__ import annotations

import pathlib
import shutil
import sys

import numpy as np
import pytest

from plantlod.cli.main import cli

ROOT = pathlib.Path(__file__).resolve().parent.parent
RUN = ["--dt", "0.01", "--steps", "600", "--wind-speed", "20"]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def stalks(tmp_path, monkeypatch):
    from test_compare_cli import STALK8_LEVEL1

    shutil.copy(ROOT / "examples" / "stalk8.lsys", tmp_path / "stalk8.lsys")
    (tmp_path / "l1.lsys").write_text(STALK8_LEVEL1)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_plot_writes_the_same_png_twice(runner, stalks):
    pytest.importorskip("matplotlib")
    first = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--plot", "a.png",
                                "--plot-at", "4"])
    assert first.exit_code == 0, first.stderr
    assert "wrote a.png" in first.stderr
    data = (stalks / "a.png").read_bytes()
    assert data.startswith(PNG_MAGIC)
    assert b"Software" not in data and b"matplotlib" not in data     # no version stamp
    again = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--plot", "b.png"])
    assert again.exit_code == 0                      # default time: 4 s, the same picture
    assert (stalks / "b.png").read_bytes() == data
    # the table on stdout does not change because a plot was asked for
    plain = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN])
    assert plain.stdout == first.stdout


def test_worst_series_picks_distinct_groups():
    from plantlod.compare.plot import worst_series
    from plantlod.compare.runs import Run, compare_runs
    from treegen import make_tree

    t = np.arange(2001) * 0.01
    original = make_tree([-1, 0, -1, 2], address=["0.0", "0.1", "1.0", "1.1"])
    simplified = make_tree([-1, -1], address=["0", "1"], length=2.0)
    wave = np.sin(np.pi * t)
    # group 0: bend amplitude 0.2 against 0.1 (error 0.5); group 1: bend 0.2 against 0.19
    # (0.05) but period 2 s against 2.5 s. Rotation: none.
    ob = np.column_stack([0.1 * wave, 0.1 * wave, 0.1 * wave, 0.1 * wave])
    sb = np.column_stack([0.1 * wave, 0.19 * np.sin(2 * np.pi * t / 2.5)])
    comp = compare_runs(Run(original, t, ob, 0 * ob, "o"), Run(simplified, t, sb, 0 * sb, "s"))
    series = worst_series(comp)
    assert series[0] == (0, "bend", "amplitude")
    assert series[1] == (1, "bend", "period")
    assert len(series) == len({(j, c) for j, c, _ in series})


def test_plot_without_matplotlib_exits_2(runner, stalks, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)       # `import matplotlib` fails
    result = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--plot", "a.png"])
    assert result.exit_code == 2
    assert "pip install 'plantlod[plot]'" in result.stderr
    assert len(result.stderr.splitlines()) == 1 and result.stdout == ""
    assert not (stalks / "a.png").exists()
