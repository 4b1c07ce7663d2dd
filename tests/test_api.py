"""The public API (plantlod/__init__.py, docs/api.md): the same bytes as the commands,
lanes for a list of winds, lazy loading."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

import plantlod
from golden_util import ROOT, run_cli

RUN = ["--dt", "0.01", "--steps", "300", "--wind-speed", "5"]


@pytest.fixture
def stalk(tmp_path, monkeypatch):
    """A folder holding stalk8.lsys, made the working directory (file names match the CLI's)."""
    shutil.copy(ROOT / "examples" / "stalk8.lsys", tmp_path / "stalk8.lsys")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_derive_and_simulate_give_the_commands_bytes(stalk):
    system = plantlod.read_lsystem("stalk8.lsys")
    tree = plantlod.derive(system)
    assert plantlod.write_tree(tree) == run_cli("derive", "stalk8.lsys", cwd=stalk).stdout
    angles = plantlod.simulate(tree, wind=(5.0, 0.0, 0.0), dt=0.01, steps=300)
    assert angles.bend.shape == (301, tree.n_branches) and angles.time[0] == 0.0
    assert plantlod.write_angles(angles) == run_cli("simulate", "stalk8.lsys", *RUN, cwd=stalk).stdout


@pytest.mark.parametrize("form", ["grammar", "explicit"])
def test_simplify_gives_the_commands_bytes(stalk, form):
    """The system the API returns (the explicit form reads it from its text when asked for)
    writes as the command's output, header comment included."""
    level = plantlod.simplify(plantlod.read_lsystem("stalk8.lsys"), level=1, form=form)
    cli_text = run_cli("simplify", "stalk8.lsys", "--level", "1", "--form", form,
                       "--no-progress", cwd=stalk).stdout
    assert level.comment and plantlod.write_lsystem(level) == cli_text



def test_simplify_reads_a_path_a_text_and_a_system_alike(stalk):
    """plantlod.simplify (the callable package) read any string as a path, so the text of an
    L-system, which read_lsystem and derive take, ended in 'File name too long' (session 23)."""
    text = (stalk / "stalk8.lsys").read_text()
    by_path, by_text = plantlod.simplify("stalk8.lsys"), plantlod.simplify(text)
    by_system = plantlod.simplify(plantlod.read_lsystem(text))
    body = [plantlod.write_lsystem(s).split("\nname:", 1)[1] for s in (by_path, by_text, by_system)]
    assert body[0] == body[1] == body[2]
    with pytest.raises(plantlod.InputError, match="expected an LSystem, the path"):
        plantlod.simplify(3)


def test_simulate_and_compare_read_a_text_as_derive_does(stalk):
    """simulate and compare read any string as a path, so the text of an L-system (which
    derive takes) or of a tree file became a many-line 'no such file' (session 23, found by
    fuzzing); a file name with a line break is quoted, so a message stays one line."""
    text = (stalk / "stalk8.lsys").read_text()
    by_path = plantlod.simulate("stalk8.lsys", wind=(5.0, 0.0, 0.0), dt=0.01, steps=50)
    for item in (text, plantlod.write_tree(plantlod.derive(text))):
        by_text = plantlod.simulate(item, wind=(5.0, 0.0, 0.0), dt=0.01, steps=50)
        assert by_text.bend.tobytes() == by_path.bend.tobytes()
    doc = plantlod.compare(text, text, wind=(5.0, 0.0, 0.0), dt=0.01, duration=3.0)
    assert doc["original"]["file"] == "<text>" and doc["passed"]
    assert doc["comparisons"][0]["simplified"]["file"] == "<text> (simplified 1)"
    with pytest.raises(plantlod.InputError) as info:
        plantlod.read_lsystem("axiom: Q(\n", name="a\nb")
    assert str(info.value).startswith("'a\\nb':1:10: ") and "\n" not in str(info.value)
    assert plantlod.read_angles(plantlod.write_angles(by_path)).bend.shape == by_path.bend.shape
    with pytest.raises(plantlod.InputError) as info:          # (read as a path: a name cut short)
        plantlod.read_lsystem("x" * 5000)
    assert len(str(info.value)) < 300

def test_simplify_and_compare_give_the_commands_bytes(stalk):
    from plantlod.compare.report import dumps

    system = plantlod.read_lsystem("stalk8.lsys")
    level = plantlod.simplify(system, level=1)
    cli_text = run_cli("simplify", "stalk8.lsys", "--level", "1", "--no-progress", cwd=stalk).stdout
    assert plantlod.write_lsystem(level) == cli_text
    plantlod.write_lsystem(level, stalk / "stalk8_l1.lsys")
    assert (stalk / "stalk8_l1.lsys").read_text() == cli_text
    doc = plantlod.compare(system, plantlod.read_lsystem("stalk8_l1.lsys"),
                           wind=(5.0, 0.0, 0.0), dt=0.01, duration=3.0)
    cli_json = run_cli("compare", "stalk8.lsys", "stalk8_l1.lsys", "--dt", "0.01",
                       "--duration", "3", "--wind-speed", "5", "--json", cwd=stalk).stdout
    assert dumps(doc) == cli_json
    assert json.loads(cli_json)["comparisons"][0]["motion_error"] is not None


def test_a_list_of_winds_adds_a_lane_axis_equal_to_single_runs():
    tree = plantlod.derive(plantlod.read_lsystem(ROOT / "examples" / "abop_1_24a.lsys"), 3)
    winds = [(2.0, 0.0, 0.0), (0.0, 7.0, 1.0), (0.5, 0.5, 0.0)]
    many = plantlod.simulate(tree, wind=winds, dt=0.01, steps=120, every=4)
    assert many.bend.shape == (3, 31, tree.n_branches)
    for w, vector in enumerate(winds):
        one = plantlod.simulate(tree, wind=vector, dt=0.01, steps=120, every=4)
        assert np.array_equal(one.bend, many.bend[w]) and np.array_equal(one.rotation, many.rotation[w])


def test_round_trips_and_text_input():
    system = plantlod.read_lsystem((ROOT / "examples" / "stalk8.lsys").read_text())
    tree = plantlod.derive(system)
    again = plantlod.read_tree(io.StringIO(plantlod.write_tree(tree)))
    assert again.address == tree.address and np.array_equal(again.length, tree.length)
    angles = plantlod.simulate(system, wind=(1.0, 2.0, 0.0), dt=0.01, duration=0.5)
    back = plantlod.read_angles(io.StringIO(plantlod.write_angles(angles)))
    np.testing.assert_allclose(back.bend, angles.bend, rtol=1e-9, atol=1e-15)


def test_bad_input_raises_input_error():
    with pytest.raises(plantlod.InputError):
        plantlod.read_lsystem("axiom: F(\n")
    tree = plantlod.derive(plantlod.read_lsystem(ROOT / "examples" / "stalk8.lsys"))
    with pytest.raises(plantlod.InputError):
        plantlod.simulate(tree, wind=(1.0, 0.0), dt=0.01, steps=10)
    with pytest.raises(plantlod.InputError):
        plantlod.simulate(tree, wind=(1.0, 0.0, 0.0), dt=0.01)        # neither steps nor duration
    # steps from a dt below the documented 1e-9 s, or a duration of 1e300 s: OverflowError
    # from round() before session 22 (found by fuzzing)
    for dt, duration in ((5e-324, 1.0), (1e-10, 1.0), (0.01, 1e300)):
        with pytest.raises(plantlod.InputError):
            plantlod.simulate(tree, wind=(1.0, 0.0, 0.0), dt=dt, duration=duration)
        with pytest.raises(plantlod.InputError):
            plantlod.compare(tree, tree, wind=(5.0, 0.0, 0.0), dt=dt, duration=duration)


def test_import_is_lazy_and_public_names_are_listed():
    code = ("import sys, plantlod; print(sorted(m for m in ('numba', 'scipy', 'numpy', 'rich', "
            "'trimesh', 'matplotlib', 'plantlod.api') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    assert set(plantlod.__all__) <= set(dir(plantlod))
    for name in plantlod.__all__:
        assert getattr(plantlod, name) is not None
    assert plantlod.__version__
    assert callable(plantlod.simplify) and plantlod.simplify.pipeline is not None


@pytest.mark.parametrize("wind", [[], "x", (1.0, float("nan"), 0.0), [(1, 0, 0), (2, 0)]])
def test_bad_winds_are_input_errors(wind):
    tree = plantlod.derive(plantlod.read_lsystem(ROOT / "examples" / "stalk8.lsys"))
    with pytest.raises(plantlod.InputError):
        plantlod.simulate(tree, wind=wind, dt=0.01, steps=5)
