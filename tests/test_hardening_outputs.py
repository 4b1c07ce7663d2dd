"""Outputs that land together or not at all, named as the user named them (session 42: a
fuzzing round over output paths, option combinations and signals; docs/errors.md).

Each test fails on the code before it: a scene's report wrote over its first tree file (only
the last was checked), a cache inside a new --angles store failed after the whole scene,
compare's frames and picture landed before its table failed on a full device, a folder
filled beside a folder that is a mount point could not be moved into it, and a full disk
named the hidden temporary, "the stream", or nothing.
"""

from __future__ import annotations

import errno
import os
import subprocess

import pytest

from golden_util import ROOT, run_cli
from test_hardening_cli import one_line
from test_hardening_scene import HEAD

STALK = str(ROOT / "examples" / "stalk8.lsys")
SCENE = HEAD.format(duration="0.2") + """[[tree]]
file = "a.txt"
[[tree]]
file = "b.json"
position = [3, 0, 0]
"""


@pytest.fixture
def two_trees(tmp_path):
    text = open(STALK, encoding="utf-8").read()
    for name in ("a.txt", "b.json"):     # (L-systems under names a report may take)
        (tmp_path / name).write_text(text, encoding="utf-8")
    (tmp_path / "s.toml").write_text(SCENE, encoding="utf-8")
    return tmp_path


@pytest.mark.parametrize("victim", ["a.txt", "b.json"])
def test_a_scene_report_never_replaces_any_of_its_tree_files(two_trees, victim):
    before = (two_trees / victim).read_bytes()
    result = run_cli("scene", "s.toml", "--no-cache", "--report", victim, exit_code=None,
                     cwd=two_trees)
    one_line(result, 2, f"--report would write over the input", f"of s.toml")
    assert (two_trees / victim).read_bytes() == before


@pytest.mark.parametrize("cache, angles", [("a.zarr", "a.zarr"), ("a.zarr/c", "a.zarr"),
                                           ("a.zarr/c/d", "a.zarr")])
def test_a_cache_and_a_new_store_at_one_path_are_refused_before_the_run(two_trees, cache,
                                                                        angles):
    result = run_cli("scene", "s.toml", "--cache", cache, "--angles", angles, "--report",
                     "r.json", exit_code=None, cwd=two_trees)
    one_line(result, 2, "share a path")
    assert not (two_trees / "r.json").exists() and not (two_trees / "a.zarr").exists()


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full on this system")
def test_compares_frames_and_picture_do_not_land_when_its_table_cannot(tmp_path):
    result = run_cli("compare", STALK, STALK, "--dt", "0.01", "--duration", "3",
                     "--wind-speed", "5", "--obj", "o", "--at", "1", "--plot", "p.png",
                     "-o", "/dev/full", exit_code=None, cwd=tmp_path)
    one_line(result, 1, "cannot write /dev/full")
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full on this system")
def test_a_page_on_a_full_device_is_named(tmp_path):
    glb = tmp_path / "s.glb"
    import plantlod

    tree = plantlod.derive(STALK)
    plantlod.export_animation(tree, plantlod.simulate(tree, wind=(5, 0, 0), steps=10), glb)
    one_line(run_cli("view", str(glb), "-o", "/dev/full", exit_code=None), 1,
             "cannot write /dev/full: No space left on device")


def test_a_folder_filled_into_an_existing_one_is_filled_inside_it(tmp_path):
    """Moves within one file system: the temporary folder is made inside the folder it fills
    (beside it, a folder that is a mount point failed every move)."""
    from plantlod.cli.io import output_folder

    target = tmp_path / "out"
    target.mkdir()
    with output_folder(str(target), merge=True) as tmp:
        assert os.path.dirname(tmp) == str(target)
        (open(os.path.join(tmp, "x.txt"), "w")).close()
    assert sorted(os.listdir(target)) == ["x.txt"]


def test_a_full_disk_while_a_folder_fills_names_the_folder(tmp_path):
    """The error names the folder given, not the hidden temporary (or no file at all)."""
    from plantlod.cli.io import output_folder
    from plantlod.lsys.errors import RunFailure

    for error in (OSError(errno.ENOSPC, "No space left on device"),
                  OSError(errno.ENOSPC, "No space left on device", "PLACEHOLDER")):
        with pytest.raises(RunFailure, match=r"^cannot write .*lv: No space left on device$"):
            with output_folder(str(tmp_path / "lv")) as tmp:
                if error.filename:
                    error.filename = os.path.join(tmp, "level1.lsys")
                raise error
        assert os.listdir(tmp_path) == []


def _mount_small_tmpfs(path) -> bool:
    """A 64 kB tmpfs at ``path`` where this process may mount one (root); else False."""
    if os.geteuid() != 0:
        return False
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(path)],
                          capture_output=True)
    return done.returncode == 0


def test_a_store_that_fills_the_disk_leaves_nothing_and_says_one_line(tmp_path):
    """zarr's other chunk writes ran on after the first failed and made the removed
    temporary store again (and asyncio printed their tasks at exit); they are waited for
    now (`scene.store.settle_writes`), and the store never makes its folder again."""
    small = tmp_path / "small"
    small.mkdir()
    if not _mount_small_tmpfs(small):
        pytest.skip("needs root to mount a small tmpfs (a full disk)")
    try:
        for _ in range(3):
            result = subprocess.run(
                [str(ROOT / ".venv" / "bin" / "plantlod"), "scene",
                 str(ROOT / "examples" / "forest.toml"), "--angles", str(small / "b.zarr"),
                 "--report", str(tmp_path / "r.json")], capture_output=True, text=True,
                timeout=600)
            assert result.returncode == 1
            assert result.stderr.splitlines() == [
                f"plantlod scene: error: cannot write {small / 'b.zarr'}: No space left on "
                "device"], result.stderr[:500]
            assert os.listdir(small) == [] and not (tmp_path / "r.json").exists()
    finally:
        subprocess.run(["umount", str(small)], capture_output=True)
