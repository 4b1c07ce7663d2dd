"""Counts in messages (lsys/words.py), and the commands that print them."""

from __future__ import annotations

from golden_util import run_cli
from plantlod.lsys.words import counted


def test_counted_nouns():
    assert counted(1, "branch") == "1 branch"
    assert counted(0, "tree") == "0 trees"
    assert counted(1234, "leaf") == "1,234 leaves"
    assert counted(2, "group") == "2 groups"


def test_compare_says_the_samples_of_its_window():
    # --window 2,6 of a 6 s run at dt 0.01 holds t = 2.00 ... 6.00: 401 samples (the table
    # says so too), not the run's 601
    run = run_cli("compare", "examples/stalk8.lsys", "examples/stalk8.lsys", "--dt", "0.01",
                  "--duration", "6", "--wind-speed", "5", "--window", "2,6")
    assert "(401 samples)" in run.stdout
    assert "8 groups, 401 samples;" in run.stderr
