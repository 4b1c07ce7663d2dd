"""The library as a Python user first meets it (session 25, from a user's first hour with the
API): winds written as lists and arrays, archives the commands write, files of the wrong
kind, a Tree edited by hand, and the messages that answer mistakes. Each check compares
against a second route (the tuple form of a wind, the CSV form of an archive, the CLI's
message), not against a reprint of the output.
"""

from __future__ import annotations

import dataclasses
import json
import inspect
import io
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import plantlod
from golden_util import ROOT, run_cli
from plantlod import InputError, RunFailure
from plantlod.lsys.system import BranchSymbol, Module

STALK = "examples/stalk8.lsys"


@pytest.fixture(autouse=True)
def _at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


def test_one_wind_as_a_list_or_array_is_the_tuple_wind():
    """`wind=[2.0, 0.0, 0.0]` was refused ("got 2.0"): a list of three numbers is one wind."""
    want = plantlod.simulate(STALK, wind=(2.0, 0.0, 0.0), dt=0.01, steps=20)
    for wind in ([2.0, 0.0, 0.0], np.array([2.0, 0.0, 0.0]), [2, 0, 0]):
        got = plantlod.simulate(STALK, wind=wind, dt=0.01, steps=20)
        assert got.bend.shape == want.bend.shape and np.array_equal(got.bend, want.bend)


def test_several_winds_as_an_array_or_tuple_are_the_list_of_winds():
    """An array (W, 3) or a tuple of vectors gave the one-wind error (in two lines)."""
    want = plantlod.simulate(STALK, wind=[(2, 0, 0), (0, 5, 0)], dt=0.01, steps=20)
    for wind in (np.array([[2, 0, 0], [0, 5, 0]]), ((2, 0, 0), (0, 5, 0))):
        got = plantlod.simulate(STALK, wind=wind, dt=0.01, steps=20)
        assert got.bend.shape == (2, 21, 8) and np.array_equal(got.bend, want.bend)


@pytest.mark.parametrize("wind", [[1, 2], np.zeros((2, 2)), [(1, 2)], "x", [True, 0, 0]])
def test_a_wind_that_is_none_of_those_is_one_line(wind):
    with pytest.raises(InputError) as err:
        plantlod.simulate(STALK, wind=wind, dt=0.01, steps=5)
    assert "\n" not in str(err.value) and "a wind is (vx, vy, vz)" in str(err.value)


def test_compare_takes_one_wind_and_says_so():
    with pytest.raises(InputError, match="compare runs one wind; got a list of 2"):
        plantlod.compare(STALK, STALK, wind=[(5, 0, 0), (0, 5, 0)], dt=0.01, duration=1)


def test_archives_the_commands_write_are_read(tmp_path):
    """read_tree and read_angles refused the .npz files `derive` and `simulate` write."""
    run_cli("derive", STALK, "-o", str(tmp_path / "t.npz"))
    run_cli("derive", STALK, "-o", str(tmp_path / "t.jsonl"))
    for ext in ("npz", "csv"):
        run_cli("simulate", STALK, "--dt", "0.01", "--steps", "10", "--wind-speed", "3", "-o",
                str(tmp_path / f"a.{ext}"))
    tree, text_tree = plantlod.read_tree(tmp_path / "t.npz"), plantlod.read_tree(tmp_path / "t.jsonl")
    assert tree.address == text_tree.address and np.array_equal(tree.length, text_tree.length)
    archive, csv = plantlod.read_angles(tmp_path / "a.npz"), plantlod.read_angles(tmp_path / "a.csv")
    assert archive.bend.shape == (11, 8)
    assert np.allclose(archive.bend, csv.bend, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("call, given, read_as", [
    (lambda p: plantlod.simulate(p["csv"], wind=(1, 0, 0), dt=0.01, steps=3),
     "an angle CSV", "an L-system"),
    (lambda p: plantlod.read_tree(STALK), "an L-system", "a tree file"),
    (lambda p: plantlod.read_tree(p["csv"]), "an angle CSV", "a tree file"),
    (lambda p: plantlod.read_angles(p["tree"]), "a tree file", "an angle CSV"),
    (lambda p: plantlod.read_lsystem(p["csv"]), "an angle CSV", "an L-system"),
])
def test_a_file_of_another_kind_is_named_by_what_it_is(tmp_path, call, given, read_as):
    paths = {"csv": str(tmp_path / "a.csv"), "tree": str(tmp_path / "t.jsonl")}
    run_cli("simulate", STALK, "--dt", "0.01", "--steps", "5", "-o", paths["csv"])
    run_cli("derive", STALK, "-o", paths["tree"])
    with pytest.raises(InputError) as err:
        call(paths)
    assert f"{given}" in str(err.value) and f"not {read_as}" in str(err.value)


def test_an_lsystem_from_a_stream_or_with_a_byte_order_mark():
    text = open(STALK, encoding="utf-8").read()
    want = plantlod.derive(plantlod.read_lsystem(STALK))
    for given in (io.StringIO(text), "\ufeff" + text):
        assert plantlod.derive(plantlod.read_lsystem(given)).address == want.address
    with open(STALK, encoding="utf-8") as handle:
        assert plantlod.read_lsystem(handle, name="mine").name == "stalk8"


@pytest.mark.parametrize("edit, fragment", [
    (dict(parent=np.array([1, 0, 1, 2, 3, 4, 5, 6])), "parent-before-child"),   # a cycle
    (dict(length=np.ones(3)), "length must have shape (8,)"),
    (dict(leaf_branch=np.array([42])), "leaf on a branch that does not exist"),
    (dict(offset=np.full((8, 3), np.nan)), "must be finite"),
    (dict(address=["0"] * 8), "addresses must be distinct"),
])
def test_a_tree_edited_by_hand_is_checked_before_use(tmp_path, edit, fragment):
    """A parent cycle made write_tree loop forever; a short array leaked numpy's errors; NaN
    offsets reached the glTF writer; duplicate addresses wrote a file read_tree refuses."""
    tree = dataclasses.replace(plantlod.derive(STALK), **edit)
    angles = plantlod.simulate(STALK, wind=(1, 0, 0), dt=0.01, steps=3)
    for call in (lambda: plantlod.write_tree(tree),
                 lambda: plantlod.simulate(tree, wind=(1, 0, 0), dt=0.01, steps=3),
                 lambda: plantlod.export_animation(tree, angles, tmp_path / "x.glb")):
        with pytest.raises(InputError, match="the Tree breaks its invariants") as err:
            call()
        assert fragment in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_messages_say_what_a_value_must_be(tmp_path):
    with pytest.raises(InputError, match=r"must be a finite number, got nan$"):
        plantlod.simulate(STALK, wind=(1, 0, 0), dt=0.01, steps=3, damping=float("nan"))
    angles = plantlod.simulate(STALK, wind=(1, 0, 0), dt=0.01, steps=100)
    with pytest.raises(InputError, match=r"keeps no frame; expected \(A, B\) with A < B"):
        plantlod.export_animation(STALK, angles, tmp_path / "x.glb", frames=(10, 5))
    other = plantlod.simulate("examples/abop_1_24a.lsys", wind=(1, 0, 0), dt=0.01, steps=3)
    with pytest.raises(InputError, match="the angle set \\(an Angles\\) does not belong") as err:
        plantlod.export_animation(STALK, other, tmp_path / "x.glb")
    assert err.value.file is None
    assert list(tmp_path.iterdir()) == []


def test_a_bound_named_twice_is_refused():
    with pytest.raises(InputError, match="bounds name 'motion_error' twice"):
        plantlod.compare(STALK, STALK, wind=(5, 0, 0), dt=0.01, duration=1,
                         bounds={"motion_error": 0.01, "max_motion_error": 0.02})


def test_bounds_take_the_reports_own_names():
    """A report's bounds are named max_motion_error, ...; compare(bounds=...) refused them."""
    by_figure = plantlod.compare(STALK, STALK, wind=(5, 0, 0), dt=0.01, duration=1,
                                 bounds={"motion_error": 0.01})
    by_report = plantlod.compare(STALK, STALK, wind=(5, 0, 0), dt=0.01, duration=1,
                                 bounds={"max_motion_error": 0.01})
    assert by_report["bounds"] == by_figure["bounds"]
    assert by_report["bounds"]["max_motion_error"] == 0.01


def test_the_callable_packages_show_the_functions_signatures():
    assert "wind" in inspect.signature(plantlod.compare).parameters
    assert "level" in inspect.signature(plantlod.simplify).parameters
    with pytest.raises(TypeError, match=r"^simplify\(\)"):
        plantlod.simplify(STALK, 1, "explicit")


def test_a_thread_count_of_zero_in_the_environment_is_named(monkeypatch):
    monkeypatch.setenv("PLANTLOD_THREADS", "0")
    with pytest.raises(InputError, match="PLANTLOD_THREADS='0'"):
        plantlod.simulate(STALK, wind=[(1, 0, 0), (0, 1, 0)], dt=0.01, steps=3)


def test_a_full_disk_under_an_open_stream_is_a_run_failure():
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    angles = plantlod.simulate(STALK, wind=(1, 0, 0), dt=0.01, steps=300)
    with open("/dev/full", "w", encoding="utf-8") as full:
        with pytest.raises(RunFailure, match="cannot write /dev/full"):
            plantlod.write_angles(angles, full)


@pytest.mark.parametrize("ext", ["usda", "usdc"])
def test_a_usd_file_too_large_to_write_is_one_line_and_leaves_nothing(tmp_path, ext):
    """OpenUSD's own exception (about 15 lines) was an internal error in `export`."""
    csv = tmp_path / "a.csv"
    run_cli("simulate", STALK, "--dt", "0.01", "--duration", "60", "--wind-speed", "5", "-o",
            str(csv))
    out = tmp_path / "out" / f"x.{ext}"
    out.parent.mkdir()

    # files of at most 20 KiB (bash's ulimit -f counts 1024-byte blocks), set by the shell
    # that execs the command (not a preexec_fn in this process, whose threads make that unsafe)
    plantlod_cmd = os.path.join(os.path.dirname(sys.executable), "plantlod")
    done = subprocess.run(["bash", "-c", 'ulimit -f 20 && exec "$@"', "bash", plantlod_cmd,
                           "export", STALK, str(csv), "-o", str(out)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    # (a .usda is written by plantlod from OpenUSD's text: OpenUSD's own text writer looped
    # on a full disk with abop_1_24a, its memory growing without end)
    said = (f"{out}: File too large" if ext == "usda"
            else f"cannot write {out}: OpenUSD could not save it")
    assert said in done.stderr
    assert list(out.parent.iterdir()) == []


def test_a_comparison_of_no_step_says_so():
    """`duration=0` said "window [-, -] s holds 1 sample(s)", though no window was given."""
    with pytest.raises(InputError, match=r"needs a run of at least one step .*duration 0 s"):
        plantlod.compare(STALK, STALK, wind=(5, 0, 0), dt=0.01, duration=0)


@pytest.mark.parametrize("edit, fragment", [
    (dict(leaf_force_scale=float("nan")), "must be finite"),
    (dict(address=list(range(8))), "addresses must be strings"),
    (dict(symbol=[1] * 8), "symbols must be single characters"),
    (dict(group_root=["q"] * 3), "addresses must be strings"),
    (dict(parent=np.array([-1, 0.5, 1, 2, 3, 4, 5, 6])), "parent must be a flat array of whole numbers"),
    (dict(leaf_normal=np.zeros((1, 3))), "unit normals"),
    (dict(leaf_normal=np.array([[0.0, 0.0, 5.0]])), "unit normals"),      # (5 times the force)
    (dict(leaf_area=np.array([-1.0])), "areas >= 0"),
    (dict(leaf_force_scale=2 ** 1100), "past a float's range"),            # (OverflowError)
    (dict(length=np.full(8, np.timedelta64(1, "s"))), "length must be a numpy array of numbers"),
    (dict(force_gain=[[0.0] * 6] * 8), "force_gain must be a numpy array of numbers"),
    (dict(swing_roll=np.array(["0"] * 8)), "swing_roll must be a numpy array of numbers"),
    (dict(swing_roll=np.zeros(8, dtype=object)), "swing_roll must be a numpy array of numbers"),
])
def test_more_hand_edits_are_caught_before_use(edit, fragment):
    """Edits `_checked` let through (a regression fuzz of session 25): raw TypeErrors and
    IndexErrors from the writers, a diverging run blamed on force_absorbed, files that
    read_tree then refused."""
    tree = dataclasses.replace(plantlod.derive(STALK), **edit)
    with pytest.raises(InputError, match="the Tree breaks its invariants") as err:
        plantlod.write_tree(tree)
    assert fragment in str(err.value)


def test_a_complex_wind_is_refused():
    """np.array([1+5j, 0, 0]) ran as (1, 0, 0): float64 dropped the imaginary part."""
    with pytest.raises(InputError, match="a wind is"):
        plantlod.simulate(STALK, wind=np.array([1 + 5j, 0, 0]), dt=0.01, steps=3)


def test_a_script_beside_the_clone_imports_the_installed_package(tmp_path):
    # A clone at ~/plantlod and a script at ~/t.py: the clone's folder (no __init__.py)
    # would be found first as an empty namespace package `plantlod` and the API's names
    # would be missing; the Makefile's plantlod-first.pth asks the editable finder first.
    (tmp_path / "plantlod").symlink_to(ROOT, target_is_directory=True)
    script = tmp_path / "t.py"
    script.write_text("import plantlod\nprint(plantlod.read_lsystem.__name__, plantlod.__file__)\n")
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    name, where = run.stdout.split()
    assert name == "read_lsystem"
    assert pathlib.Path(where).resolve() == (ROOT / "plantlod" / "__init__.py").resolve()


def test_gusts_as_the_cli_gives_them(tmp_path):
    # simulate(gust_strength=, gust_seed=) is the CLI's --gust-strength/--gust-seed: the
    # same angles as the command's CSV (10 digits), and as the wind object written out
    from plantlod.sim.wind import GustyWind, wind_from_speed

    out = tmp_path / "g.csv"
    run_cli("simulate", STALK, "--dt", "0.01", "--steps", "300", "--wind-speed", "6",
            "--gust-strength", "0.4", "--gust-seed", "3", "-o", str(out))
    got = plantlod.simulate(STALK, dt=0.01, steps=300, wind_speed=6, gust_strength=0.4,
                            gust_seed=3)
    cli = plantlod.read_angles(str(out))
    np.testing.assert_allclose(got.bend, cli.bend, rtol=1e-8, atol=1e-15)
    by_hand = plantlod.simulate(STALK, GustyWind(wind_from_speed(6, 0), seed=3, strength=0.4),
                                dt=0.01, steps=300)
    np.testing.assert_array_equal(got.bend, by_hand.bend)
    calm = plantlod.simulate(STALK, dt=0.01, steps=300, wind_speed=6)
    assert np.abs(got.bend - calm.bend).max() > 1e-4      # the gusts do something
    with pytest.raises(InputError, match="gust_seed applies to gusts"):
        plantlod.simulate(STALK, dt=0.01, steps=10, wind_speed=6, gust_seed=3)
    with pytest.raises(InputError, match="gust_strength must be a finite number in"):
        plantlod.simulate(STALK, dt=0.01, steps=10, wind_speed=6, gust_strength=-1)
    # compare's gusts are the CLI's too: a level compared in them gives the command's figures
    level = plantlod.simplify(STALK, level=1, form="grammar", duration=2.0)
    path = tmp_path / "l1.lsys"
    plantlod.write_lsystem(level, str(path))
    report = plantlod.compare(STALK, str(path), dt=0.01, steps=300, wind_speed=6,
                              gust_strength=0.4, gust_seed=3)["comparisons"][0]
    command = json.loads(run_cli("compare", STALK, str(path), "--dt", "0.01", "--steps", "300",
                                 "--wind-speed", "6", "--gust-strength", "0.4", "--gust-seed",
                                 "3", "--json").stdout)["comparisons"][0]
    calm = plantlod.compare(STALK, str(path), dt=0.01, steps=300,
                            wind_speed=6)["comparisons"][0]
    for figure in ("amplitude_error", "tip_error", "motion_error"):
        assert report[figure] == pytest.approx(command[figure], rel=1e-9), figure
    assert report["tip_error"] != pytest.approx(calm["tip_error"], rel=1e-3)


def test_a_zero_wind_is_warned_of_as_the_cli_does():
    from plantlod.lsys.errors import PlantlodWarning

    with pytest.warns(PlantlodWarning, match="the wind is zero"):
        plantlod.simulate(STALK, dt=0.01, steps=10)
    with pytest.warns(PlantlodWarning, match="the wind is zero"):
        plantlod.simulate(STALK, (0, 0, 0), dt=0.01, steps=10, gust_strength=0.3)
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlantlodWarning)
        plantlod.simulate(STALK, [(0, 0, 0), (1, 0, 0)], dt=0.01, steps=10)   # one blows
    cli = run_cli("simulate", STALK, "--dt", "0.01", "--steps", "10", "-o", "-")
    assert "the wind is zero" in cli.stderr
    from plantlod.sim.wind import KeyframeWind

    with pytest.warns(PlantlodWarning, match="the wind is zero"):
        plantlod.simulate(STALK, KeyframeWind([0, 1], [[0, 0, 0], [0, 0, 0]]), dt=0.01, steps=10)
    with warnings.catch_warnings(record=True) as caught:       # once, not once per tree
        warnings.simplefilter("always")
        plantlod.compare(STALK, STALK, STALK, wind=(0, 0, 0), dt=0.01, steps=3)
    assert sum("the wind is zero" in str(w.message) for w in caught) == 1


HUGE = 10**5000          # past what Python prints as digits (4,300) and what a float holds


@pytest.mark.parametrize("call", [
    lambda: plantlod.simulate(STALK, wind=(1, 0, 0), dt=HUGE, steps=5),
    lambda: plantlod.simulate(STALK, wind=(1, 0, 0), dt=0.01, steps=HUGE),
    lambda: plantlod.simulate(STALK, wind=(1, 0, 0), dt=0.01, steps=5, every=HUGE),
    lambda: plantlod.simulate(STALK, wind_speed=HUGE, dt=0.01, steps=5),
    lambda: plantlod.simulate(STALK, wind_speed=1, wind_direction=HUGE, dt=0.01, steps=5),
    lambda: plantlod.simulate(STALK, wind=HUGE, dt=0.01, steps=5),
    lambda: plantlod.derive(STALK, n=HUGE),
    lambda: plantlod.simplify(STALK, level=HUGE),
    lambda: plantlod.compare(STALK, STALK, wind=(1, 0, 0), dt=0.01, steps=HUGE),
    lambda: plantlod.compare(STALK, STALK, wind=(1, 0, 0), dt=0.01, steps=3,
                             bounds={"motion_error": HUGE}),
])
def test_an_integer_of_thousands_of_digits_is_bad_input(call):
    # it escaped as ValueError ("Exceeds the limit (4300 digits) ...") or OverflowError
    with pytest.raises(InputError) as info:
        call()
    assert "set_int_max_str_digits" not in str(info.value) and len(str(info.value)) < 400


@pytest.mark.parametrize("read", [plantlod.read_lsystem, plantlod.read_tree, plantlod.read_angles])
def test_a_stream_not_open_for_reading_or_not_utf8_is_bad_input(tmp_path, read):
    # io.UnsupportedOperation and UnicodeDecodeError escaped from the readers' streams
    (tmp_path / "bad.txt").write_bytes(b"name: \xff\n")
    with open(tmp_path / "w.txt", "w") as out:
        with pytest.raises(InputError, match="not open for reading"):
            read(out)
    with open(tmp_path / "bad.txt") as text:
        with pytest.raises(InputError, match="not UTF-8 text"):
            read(text)


@pytest.mark.parametrize("direction", [0, 30, 45, 137])
def test_the_largest_wind_speed_is_taken_in_any_direction(direction):
    # |(1000 cos 30°, 1000 sin 30°)| rounds to 1000.0000000000001, which was refused as
    # "a wind of 1000 m/s; expected at most 1000 m/s" (so simplify's wind_range=(1, 1000)
    # always failed: its measurement winds include 15°)
    angles = plantlod.simulate(STALK, wind_speed=1000, wind_direction=direction, dt=0.001,
                               steps=2)
    assert angles.bend.shape == (3, 8)
    with pytest.raises(InputError, match="1000.001"):
        plantlod.simulate(STALK, wind_speed=1000.001, wind_direction=direction, dt=0.001, steps=2)


@pytest.mark.parametrize("edit, said", [
    (lambda t: {"leaf_branch": t.leaf_branch[:, None]}, "leaf_branch must be a flat array"),
    (lambda t: {"leaf_force_scale": np.ones(3)}, "leaf_force_scale must be one number"),
    (lambda t: {"leaf_normal": t.leaf_normal * 0 + 1e300}, "unit normals"),
    (lambda t: {"length": t.length.astype(complex)}, "its numbers must be real"),
    (lambda t: {"length": -t.length}, "length must not be negative"),
    (lambda t: {"drag_coefficient": -t.drag_coefficient}, "drag_coefficient must not be negative"),
    (lambda t: {"leaf_force_scale": -1.0}, "leaf_force_scale must not be negative"),
    (lambda t: {"bend_strength": t.bend_strength * 0}, "bend_strength must be > 0"),
    (lambda t: {"rotation_strength": -t.rotation_strength}, "rotation_strength must be > 0"),
])
def test_more_hand_edited_trees_are_caught(edit, said):
    # each escaped as a numpy error or a TypeError, or (negative amounts; session 28: strengths
    # of 0 or less) was written by write_tree into a file that read_tree refuses (the fuzzer
    # of session 26)
    import warnings

    tree = plantlod.derive(STALK)
    bad = dataclasses.replace(tree, **edit(tree))
    with warnings.catch_warnings():
        warnings.simplefilter("error")                # (no ComplexWarning, no overflow)
        for call in (lambda: plantlod.simulate(bad, wind=(1, 0, 0), dt=0.01, steps=3),
                     lambda: plantlod.write_tree(bad)):
            with pytest.raises(InputError, match=said):
                call()


@pytest.mark.parametrize("wind_range, bad", [((1, 2000), "2000"), ((0, 5), "0"),
                                             ((1, 1e6), "1000000")])
def test_a_wind_range_is_checked_at_its_own_ends(wind_range, bad):
    # (1, 2000) said "got 1500" (its 0.75-high measurement wind) and (1, 1e6) "a wind of
    # 1000 m/s", values nobody gave
    with pytest.raises(InputError, match=rf"wind_range must be a finite number in \(0, 1000\], "
                                         rf"got {bad}"):
        plantlod.simplify(STALK, level=1, wind_range=wind_range, duration=1.0)


@pytest.mark.parametrize("edit, said", [
    ({"derivation_length": "3"}, "derivation_length must be a whole number"),
    ({"derivation_length": 3.0}, "derivation_length must be a whole number"),
    ({"force_absorbed": "x"}, "force_absorbed must be a number"),
    ({"leaf_force_scale": None}, "leaf_force_scale must be a number"),
    ({"axiom": "F L"}, "axiom must be a tuple of Modules"),
    ({"productions": ["F -> F F"]}, "productions must be a tuple of Productions"),
    ({"name": None}, "name must be a string"),
    ({"leaves": None}, "leaves must be a tuple of LeafSymbols"),
    ({"branching_angle": float("nan")}, "branching_angle must be a finite number"),
    # (each read back from its own text as another system: the axiom module named "F F"
    # derived no branch where the text derives 16; a length "1" was read as 1.0)
    ({"axiom": (Module("F F"),)}, "its axiom read"),
    ({"branches": (BranchSymbol("F", length="1", radius=0.02, bend_strength=20.0,
                                rotation_strength=20.0),)}, "its branches read"),
    ({"branches": (BranchSymbol("F", length=2 ** 2000, radius=0.02, bend_strength=20.0,
                                rotation_strength=20.0),)}, "a number is past a float's range"),
])
def test_a_hand_edited_lsystem_is_checked_before_use(edit, said):
    # each leaked a TypeError, ValueError or AttributeError from inside (the API fuzzer of
    # session 26), or, for a NaN, a derived tree full of NaN
    bad = dataclasses.replace(plantlod.read_lsystem(STALK), **edit)
    for call in (plantlod.derive, plantlod.write_lsystem,
                 lambda s: plantlod.simulate(s, wind=(1, 0, 0), dt=0.01, steps=2)):
        with pytest.raises(InputError, match=f"not one an .lsys file can say: {said}"):
            call(bad)
