"""Hardening of `plantlod scene` (issue 24): declared caps refused before anything is
allocated (trees, time steps, tree-steps of wind, branch-steps), folders removed on every
way out, and random scene files that may only ever end in exit 0, 1 or 2 with one line."""

from __future__ import annotations

import os
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from golden_util import ROOT, run_cli
from test_hardening_cli import one_line

STALK = str(ROOT / "examples" / "stalk8.lsys")

HEAD = """dt = 0.01
duration = {duration}
[wind]
speed = 5
[camera]
position = [0, -40, 1.7]
target = [0, 0, 1.7]
"""


def scene_file(tmp_path, body: str, duration="1") -> str:
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration=duration) + body)
    return str(path)


def test_a_billion_scattered_trees_are_refused_at_once(tmp_path):
    path = scene_file(tmp_path, f'[scatter]\nfiles = ["{STALK}"]\ncount = 1000000000\n'
                                'area = [0, 0, 10, 10]\n')
    start = time.perf_counter()
    line = one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
                    "more trees than the limit of 100,000")
    assert time.perf_counter() - start < 5
    assert line.startswith(f"{path}:10:1: error:")


def test_scatter_after_tree_entries_counts_them_too(tmp_path, monkeypatch):
    import plantlod.scene.file as scene_file_module

    monkeypatch.setattr(scene_file_module, "MAX_TREES", 3)
    body = (f'[[tree]]\nfile = "{STALK}"\n[[tree]]\nfile = "{STALK}"\n'
            f'[scatter]\nfiles = ["{STALK}"]\ncount = 2\narea = [0, 0, 10, 10]\n')
    one_line(run_cli("scene", scene_file(tmp_path, body), "--no-cache", exit_code=None), 2,
             "count 2 makes more trees than the limit of 3")


@pytest.mark.parametrize("duration", ["1e12", "1e308"])
def test_a_scene_too_long_is_a_usage_error(tmp_path, duration):
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n', duration=duration)
    line = one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
                    "more than the limit of 1,000,000")
    assert line.startswith(f"{path}:2:1: error: duration")


def test_tree_steps_cap(tmp_path, monkeypatch):
    import plantlod.scene.run as scene_run

    monkeypatch.setattr(scene_run, "MAX_SCENE_TREE_STEPS", 150)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
             "2 trees x 100 steps is 200 tree-steps of wind, more than the limit of 150")


def test_branch_steps_cap(tmp_path, monkeypatch):
    import plantlod.scene.run as scene_run

    monkeypatch.setattr(scene_run, "MAX_SCENE_BRANCH_STEPS", 1000)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n[[tree]]\nfile = "{STALK}"\n')
    # stalk8 has 8 branches: 2 x 8 x 100
    one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
             "1,600 branch-steps at full detail", "more than the limit of 1,000")


def test_tree_entries_that_are_not_tables(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("tree = [1, 2]\n" + HEAD.format(duration=1))
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             "trees are [[tree]] entries")
