"""`plantlod compare` through click's CliRunner: groups, figures, outputs and exit codes.

Figures are checked against the slow literal model in tests/reference_model.py
(the original's angles) and against closed forms of the groups and main paths
worked out by hand from the productions; stdout and stderr are asserted apart.
"""

from __future__ import annotations

import json
import math
import os
import pathlib
import shutil

import numpy as np
import pytest

from golden_util import ROOT, assert_golden, run_cli
from plantlod.cli.main import cli
from reference_model import reference_simulate

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"

# The thesis' level-1 stalk for stalk8.lsys: N = 2, F twice as long, k_fp = 0.7^2.
STALK8_LEVEL1 = """\
# level 1 of stalk8.lsys by the thesis' rules
name: stalk8_level1
derivation_length: 2
branching_angle: 30
rotation_angle: 90
seed: 0
force_absorbed: 0.005
force_propagated: 0.49
drag_coefficient: 0.0015

branch F: length=2 radius=0.02 bend_strength=20 rotation_strength=20
leaf L: area=0.01

axiom: F L
productions:
  F -> F F
"""
RUN = ["--dt", "0.01", "--steps", "1000", "--wind-speed", "20"]


@pytest.fixture
def stalks(tmp_path, monkeypatch):
    """A working directory holding stalk8.lsys and its level-1 file stalk8_level1.lsys."""
    shutil.copy(EXAMPLES / "stalk8.lsys", tmp_path / "stalk8.lsys")
    (tmp_path / "stalk8_level1.lsys").write_text(STALK8_LEVEL1)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def invoke(runner, args):
    return runner.invoke(cli, ["compare", *args], catch_exceptions=False)


def test_stalk_groups_and_figures_against_the_reference_model(runner, stalks):
    result = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    (comp,) = doc["comparisons"]
    # 8 branches 0.a.b.c, 4 groups 0.a.b, each a chain of two: the main path is the whole group
    assert [g["address"] for g in comp["groups"]] == ["0.0.0", "0.0.1", "0.1.0", "0.1.1"]
    for g in comp["groups"]:
        assert g["members"] == 2
        assert g["main_path"] == [g["address"] + ".0", g["address"] + ".1"]
    assert comp["unassigned_branches"] == 0 and doc["samples"] == 1001
    assert doc["original"] == {"file": "stalk8.lsys", "branches": 8, "leaves": 1, "rest_height": 8.0}

    # the original's motion from the literal model; the stalk is straight, so a group's
    # combined bend is the sum of its two members' bends (model.md 5)
    from plantlod.cli.loading import load_tree
    tree, _ = load_tree("stalk8.lsys")
    bend, rot = reference_simulate(tree, 0.01, 1000, lambda t: (20.0, 0.0, 0.0))
    bend = np.array(bend)
    assert np.abs(np.array(rot)).max() == 0.0          # wind along x: no rotation at all
    largest = 0.0
    for j, g in enumerate(comp["groups"]):
        combined = bend[:, 2 * j] + bend[:, 2 * j + 1]
        amp = (combined.max() - combined.min()) / 2
        largest = max(largest, amp)
        assert g["bend"]["amplitude_original"] == pytest.approx(amp, rel=1e-8)
        assert g["rotation"]["amplitude_original"] == 0.0
        assert g["rotation"]["counted"] is False and g["rotation"]["period_original"] is None
    assert comp["largest_amplitude"] == pytest.approx(largest, rel=1e-8)
    worst = max(comp["groups"], key=lambda g: g["bend"]["amplitude_error"])
    assert comp["amplitude_error"] == worst["bend"]["amplitude_error"]
    assert comp["amplitude_error_at"] == {"address": worst["address"], "component": "bend"}
    assert result.stderr.startswith("compare: stalk8_level1.lsys against stalk8.lsys: 4 groups")


def test_branching_tree_groups_and_main_paths(runner):
    # abop_1_24a: F -> F[+FL]F[-FL]F. In the successor F[+FL]F[-FL]F the branches have
    # indices 0, 3, 6, 9, 12; the first F carries the side branch 3 (+, alpha 25.7 deg)
    # and the straight 6, which carries 9 (-) and the straight 12. So the group of the
    # level-1 branch 0.a (n = 1 against n = 2) holds 0.a.{0,3,6,9,12} and its main path
    # is 0.a.0, 0.a.6, 0.a.12 (the straight line); 25 branches, 5 groups.
    lsys = str(EXAMPLES / "abop_1_24a.lsys")
    result = invoke(runner, [lsys, lsys, "-n", "2", "--simplified-n", "1", "--dt", "0.01",
                             "--steps", "300", "--wind-speed", "20", "--json"])
    assert result.exit_code == 0, result.stderr
    (comp,) = json.loads(result.stdout)["comparisons"]
    assert comp["simplified"]["file"].endswith("abop_1_24a.lsys (n=1)")
    assert [g["address"] for g in comp["groups"]] == ["0.0", "0.3", "0.6", "0.9", "0.12"]
    for g in comp["groups"]:
        a = g["address"]
        assert g["members"] == 5
        assert g["main_path"] == [f"{a}.0", f"{a}.6", f"{a}.12"]


def test_table_is_plain_aligned_text(runner, stalks):
    table = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", *RUN])
    assert table.exit_code == 0
    doc = json.loads(invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--json"]).stdout)
    lines = table.stdout.splitlines()
    assert lines[0].startswith("original:   stalk8.lsys (8 branches, 1 leaf, rest height 8 m)")
    header = next(i for i, line in enumerate(lines) if line.startswith("group"))
    assert set(lines[header + 1]) <= {"-", " "}
    rows = lines[header + 2: header + 10]
    # the bend rows carry the figures of the JSON, amplitudes in degrees
    for j, g in enumerate(doc["comparisons"][0]["groups"]):
        bend_row, rot_row = rows[2 * j].split(), rows[2 * j + 1].split()
        assert bend_row[:4] == [g["address"], "2", "2", "bend"]
        assert float(bend_row[4]) == pytest.approx(math.degrees(g["bend"]["amplitude_original"]), rel=1e-3)
        assert float(bend_row[6]) == pytest.approx(g["bend"]["amplitude_error"], rel=1e-3)
        assert float(bend_row[-1]) == pytest.approx(g["tip_error"], rel=1e-3)
        assert rot_row == ["rotation", "0", "0", "-", "-", "-", "-", "no"]
    assert "\x1b" not in table.stdout                   # no terminal codes when piped
    assert table.stdout == invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", *RUN]).stdout


def test_compare_stalk8_level1_golden(runner, stalks):
    result = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", "--dt", "0.01", "--duration", "10",
                             "--wind-speed", "20", "--json"])
    assert result.exit_code == 0
    assert_golden("compare_stalk8_level1.json", result.stdout)


def test_bounds_and_exit_codes(runner, stalks):
    base = ["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--json"]
    doc = json.loads(invoke(runner, base).stdout)["comparisons"][0]
    amp, per, tip = doc["amplitude_error"], doc["period_error"], doc["tip_error"]
    ok = invoke(runner, base + ["--max-amplitude-error", str(amp * 1.01), "--max-period-error",
                                str(per * 1.01), "--max-tip-error", str(tip * 1.01)])
    assert ok.exit_code == 0 and json.loads(ok.stdout)["passed"] is True

    bad = invoke(runner, base + ["--max-tip-error", str(tip * 0.99)])
    assert bad.exit_code == 1
    out = json.loads(bad.stdout)                         # the JSON is still written
    assert out["passed"] is False
    (exceeded,) = out["comparisons"][0]["exceeded"]
    assert exceeded["bound"] == "--max-tip-error" and exceeded["at"] == doc["tip_error_at"]
    errors = [line for line in bad.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1
    assert "--max-tip-error" in errors[0] and f"at group {doc['tip_error_at']['address']}" in errors[0]

    table = invoke(runner, base[:-1] + ["--max-amplitude-error", "0"])
    assert table.exit_code == 1 and table.stdout.startswith("original:")

    # a percentage is read as one (simplify's summary prints them): 100 x the fraction
    for percent, code in ((f"{amp * 101:.12g}%", 0), (f"{amp * 99:.12g}%", 1)):
        assert invoke(runner, base + ["--max-amplitude-error", percent]).exit_code == code
    for wrong in ("5 percent", "-1%", "nan%", "%"):
        refused = invoke(runner, base + ["--max-amplitude-error", wrong])
        assert refused.exit_code == 2 and "expected a fraction (0.05) or a percentage (5%)" \
            in refused.stderr


@pytest.mark.parametrize("figure, option", [("motion_error", "--max-motion-error"),
                                            ("period_error_major", "--max-period-error-major"),
                                            ("tip_error_max_m", "--max-tip-error-m")])
def test_visible_motion_bounds(runner, stalks, figure, option):
    base = ["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--json"]
    doc = json.loads(invoke(runner, base).stdout)["comparisons"][0]
    value = doc[figure]
    # model.md 6 from the JSON's own group figures: motion error and major period error
    groups, largest = doc["groups"], doc["largest_amplitude"]
    comps = [g[c] for g in groups for c in ("bend", "rotation")]
    if figure == "motion_error":
        assert value == pytest.approx(max(abs(c["amplitude_simplified"] - c["amplitude_original"])
                                          for c in comps if c["counted"]) / largest, rel=1e-8)
    if figure == "period_error_major":
        assert value == pytest.approx(max(c["period_error"] for c in comps
                                          if c["amplitude_original"] >= 0.1 * largest
                                          and c["period_error"] is not None), rel=1e-8)
    assert invoke(runner, base + [option, str(value * 1.01)]).exit_code == 0
    bad = invoke(runner, base + [option, str(value * 0.99)])
    assert bad.exit_code == 1 and json.loads(bad.stdout)["comparisons"][0]["exceeded"][0]["bound"] == option
    # with a picture too: still one line, which says the picture was written (two before)
    pictured = invoke(runner, base + [option, str(value * 0.99), "--plot", "p.png"])
    assert pictured.exit_code == 1 and pictured.stderr.count("\n") == 1
    assert pictured.stderr.rstrip().endswith("; wrote p.png") and os.path.exists("p.png")


def test_usage_errors_exit_2(runner, stalks):
    cases = [
        (["stalk8.lsys", "stalk8_level1.lsys", "--steps", "10"], "--dt is required"),
        (["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--simplified-n", "1", "--simplified-n", "2"],
         "--simplified-n was given 2 time(s) for 1"),
        (["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--window", "5"], "T0,T1"),
        (["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--at", "4"], "--obj"),
        (["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--window", "20,30"], "window"),
        (["stalk8_level1.lsys", "stalk8.lsys", *RUN], "more than the original"),
        (["stalk8.lsys", "missing.lsys", *RUN], "missing.lsys: error: no such file"),
        (["--angles", "a.csv", "b.csv", "--wind-speed", "3"], "does not apply to --angles"),
    ]
    for args, message in cases:
        result = invoke(runner, args)
        assert result.exit_code == 2, (args, result.stderr)
        assert message in result.stderr, (args, result.stderr)
        assert result.stdout == ""


def simulate_csv(runner, source, out, extra=()):
    result = runner.invoke(cli, ["simulate", source, *RUN, "-o", out, *extra], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr


def test_tree_files_with_angle_csvs(runner, stalks):
    for name in ("stalk8", "stalk8_level1"):
        derived = runner.invoke(cli, ["derive", f"{name}.lsys", "-o", f"{name}.tree.jsonl"])
        assert derived.exit_code == 0
        simulate_csv(runner, f"{name}.lsys", f"{name}.csv")
    from_csv = invoke(runner, ["stalk8.tree.jsonl", "stalk8_level1.tree.jsonl", "--original-angles",
                               "stalk8.csv", "--simplified-angles", "stalk8_level1.csv", "--json"])
    assert from_csv.exit_code == 0, from_csv.stderr
    simulated = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", *RUN, "--json"])
    a = json.loads(from_csv.stdout)["comparisons"][0]
    b = json.loads(simulated.stdout)["comparisons"][0]
    for key in ("amplitude_error", "period_error", "tip_error"):    # the CSV keeps 10 digits
        assert a[key] == pytest.approx(b[key], rel=1e-6)

    # the wrong CSV for a tree, runs of different lengths, simulation options with nothing to run
    wrong = invoke(runner, ["stalk8.tree.jsonl", "stalk8_level1.tree.jsonl", "--original-angles",
                            "stalk8_level1.csv", "--simplified-angles", "stalk8_level1.csv"])
    assert wrong.exit_code == 2 and "stalk8_level1.csv: error: the angle CSV does not belong" in wrong.stderr
    short = runner.invoke(cli, ["simulate", "stalk8_level1.lsys", "--dt", "0.01", "--steps", "500",
                                "--wind-speed", "20", "-o", "short.csv"])
    assert short.exit_code == 0
    mixed = invoke(runner, ["stalk8.lsys", "stalk8_level1.tree.jsonl", *RUN, "--simplified-angles",
                            "short.csv"])
    assert mixed.exit_code == 2 and "1001 samples" in mixed.stderr and "501" in mixed.stderr
    extra = invoke(runner, ["stalk8.tree.jsonl", "stalk8_level1.tree.jsonl", "--original-angles",
                            "stalk8.csv", "--simplified-angles", "stalk8_level1.csv", "--dt", "0.01"])
    assert extra.exit_code == 2 and "--dt applies only when a side is simulated" in extra.stderr


def test_two_csvs_of_one_tree(runner, stalks):
    simulate_csv(runner, "stalk8.lsys", "golden.csv")
    same = invoke(runner, ["--angles", "golden.csv", "golden.csv", "--atol", "0"])
    assert same.exit_code == 0
    assert "largest difference 0 rad" in same.stderr
    # another wind: the differences, read back independently from both files
    other = runner.invoke(cli, ["simulate", "stalk8.lsys", "--dt", "0.01", "--steps", "1000",
                                "--wind-speed", "21", "-o", "new.csv"])
    assert other.exit_code == 0
    a = np.loadtxt("golden.csv", delimiter=",", skiprows=1)
    b = np.loadtxt("new.csv", delimiter=",", skiprows=1)
    want = np.abs(a[:, 1:] - b[:, 1:]).max(axis=0)          # b:0.0.0.0, r:0.0.0.0, b:...
    result = invoke(runner, ["--angles", "golden.csv", "new.csv", "--json"])
    assert result.exit_code == 0
    doc = json.loads(result.stdout)
    np.testing.assert_allclose([br["bend"] for br in doc["branches"]], want[0::2], rtol=1e-9)
    np.testing.assert_allclose([br["rotation"] for br in doc["branches"]], want[1::2], atol=0)
    assert doc["largest"] == pytest.approx(want.max(), rel=1e-9) and doc["at"]["component"] == "bend"
    limit = want.max()
    above = invoke(runner, ["--angles", "golden.csv", "new.csv", "--atol", str(limit * 0.99)])
    assert above.exit_code == 1 and above.stdout.startswith("branch")
    assert "--atol" in above.stderr and above.stderr.count("\n") == 1   # (the summary too before)
    below = invoke(runner, ["--angles", "golden.csv", "new.csv", "--atol", str(limit * 1.01)])
    assert below.exit_code == 0
    # degrees: the limit is read in degrees too
    deg = invoke(runner, ["--angles", "golden.csv", "new.csv", "--degrees", "--atol",
                          str(limit * 0.99)])
    assert deg.exit_code == 1 and " deg " in deg.stderr


def test_window_and_several_simplified_files(runner, stalks):
    (stalks / "stalk8_level2.lsys").write_text(
        STALK8_LEVEL1.replace("derivation_length: 2", "derivation_length: 1").replace("length=2", "length=4"))
    result = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", "stalk8_level2.lsys", *RUN,
                             "--window", "2,", "--json"])
    assert result.exit_code == 0, result.stderr
    doc = json.loads(result.stdout)
    assert [c["simplified"]["file"] for c in doc["comparisons"]] == ["stalk8_level1.lsys",
                                                                     "stalk8_level2.lsys"]
    assert all(c["window"] == [2.0, 10.0] for c in doc["comparisons"])
    # level 2: two groups 0.0 and 0.1 of four straight branches each
    level2 = doc["comparisons"][1]["groups"]
    assert [(g["address"], g["members"]) for g in level2] == [("0.0", 4), ("0.1", 4)]
    assert level2[1]["main_path"] == ["0.1.0.0", "0.1.0.1", "0.1.1.0", "0.1.1.1"]
    table = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", "stalk8_level2.lsys", *RUN])
    assert table.stdout.count("\noriginal:   stalk8.lsys") == 1            # the second block
    assert table.stdout.count("window:     0 to 10 s (1001 samples)") == 2
    assert len(table.stderr.splitlines()) == 2                           # one summary per file


def test_errors_of_the_samples_name_the_files_at_fault_not_the_simplified_one(tmp_path):
    """Every error while comparing one SIMPLIFIED was prefixed with its name: angles of 1e308
    in the original's CSV, a CSV of one row, and --window 0.3,0.1 all read "s1.lsys: error:"
    (session 28's fuzzing)."""
    from golden_util import run_cli

    stalk = str(ROOT / "examples" / "stalk8.lsys")
    level = tmp_path / "s1.lsys"
    run_cli("simplify", stalk, "--level", "1", "-o", str(level))
    csv = {}
    for name, tree in (("o", stalk), ("s", str(level))):
        csv[name] = tmp_path / f"{name}.csv"
        run_cli("simulate", tree, "--dt", "0.01", "--steps", "20", "--wind-speed", "5",
                "-o", str(csv[name]))
    lines = csv["o"].read_text().splitlines()
    huge = tmp_path / "huge.csv"
    huge.write_text("\n".join(lines[:4] + [lines[4].split(",")[0] + ",1e308" * 16] + lines[5:])
                    + "\n")
    one_row = tmp_path / "one.csv"
    one_row.write_text("\n".join(lines[:2]) + "\n")
    base = ("compare", stalk, str(level), "--simplified-angles", str(csv["s"]))
    result = run_cli(*base, "--original-angles", str(huge), exit_code=2)
    assert result.stderr.startswith(f"{huge}: error: its angles pose tips that are not finite "
                                    "at t = 0.03 s")
    result = run_cli(*base, "--original-angles", str(one_row), exit_code=2)
    assert result.stderr.startswith(f"plantlod compare: error: {one_row} (the angles of {stalk}) has "
                                    "1 sample (0 to 0 s) but")
    result = run_cli(*base, "--original-angles", str(csv["o"]), "--window", "0.3,0.1",
                     exit_code=2)
    assert "Invalid value for --window: the start 0.3 s is after the end 0.1 s" in result.stderr
    assert str(level) not in result.stderr


def test_a_simplified_file_whose_groups_miss_the_original_is_named(tmp_path):
    """With several SIMPLIFIED files, an error of one's groups against the original names
    that file (it named none before session 21) and the groups: line (since session 31)."""
    good = tmp_path / "l1.lsys"
    run_cli("simplify", str(ROOT / "examples" / "stalk8.lsys"), "--level", "1", "--form",
            "explicit", "-o", str(good))
    bad = tmp_path / "bad.lsys"
    bad.write_text(good.read_text().replace("  3: 0.0.1.0", "  3: 9.9.9.9"))
    result = run_cli("compare", str(ROOT / "examples" / "stalk8.lsys"), str(good), str(bad),
                     "--dt", "0.01", "--steps", "20", "--wind-speed", "5", exit_code=2)
    lines = result.stderr.strip().splitlines()
    at = bad.read_text().splitlines().index("  3: 9.9.9.9") + 1      # the groups: line's own
    assert lines[-1].startswith(f"{bad}:{at}:1: error:") and "9.9.9.9" in lines[-1], lines


def test_an_angle_csv_kept_every_k_steps_is_compared_at_its_samples(tmp_path):
    # simulate --every 10 keeps every 10th sample; the simplified side, simulated here at
    # every step, is read at those samples: the same figures as two CSVs both kept every
    # 10th sample (no thinning on that route).
    level = tmp_path / "l1.lsys"
    level.write_text(STALK8_LEVEL1)
    wind = ["--dt", "0.01", "--duration", "6", "--wind-speed", "5"]
    for name, tree in (("o10.csv", "examples/stalk8.lsys"), ("s10.csv", str(level))):
        run_cli("simulate", tree, *wind, "--every", "10", "-o", str(tmp_path / name))
    mixed = run_cli("compare", "examples/stalk8.lsys", str(level), "--original-angles",
                    str(tmp_path / "o10.csv"), *wind, "--json")
    both = run_cli("compare", "examples/stalk8.lsys", str(level), "--original-angles",
                   str(tmp_path / "o10.csv"), "--simplified-angles", str(tmp_path / "s10.csv"),
                   "--json")
    a, b = json.loads(mixed.stdout), json.loads(both.stdout)
    assert a["samples"] == b["samples"] == 61
    a, b = a["comparisons"][0], b["comparisons"][0]
    assert a.keys() == b.keys() and len(a["groups"]) == len(b["groups"]) == 4
    for key, value in a.items():          # (the CSV keeps 10 digits of the simplified angles)
        if isinstance(value, float):
            assert value == pytest.approx(b[key], rel=1e-6, abs=1e-12), key
        elif key not in ("simplified", "groups"):
            assert value == b[key], key
    assert "61 samples" in mixed.stderr
    # another span is still refused, and the message names the way that works
    short = run_cli("compare", "examples/stalk8.lsys", str(level), "--original-angles",
                    str(tmp_path / "o10.csv"), "--dt", "0.01", "--duration", "5",
                    "--wind-speed", "5", exit_code=2)
    assert "simulate --every" in short.stderr and "--obj" not in short.stderr


def test_an_explicit_levels_table_names_each_groups_root(tmp_path):
    # an explicit level's branches have addresses of their own ('1', '3', ...): the table
    # says which original branch roots each group, as the file's groups: section does, and
    # as the JSON's main path (found from the groups, not from that section) begins
    level = tmp_path / "l1.lsys"
    run_cli("simplify", "examples/stalk8.lsys", "--level", "1", "--form", "explicit",
            "-o", str(level))
    args = ["compare", "examples/stalk8.lsys", str(level), "--dt", "0.01", "--duration", "3",
            "--wind-speed", "5"]
    text = run_cli(*args).stdout
    lines = text.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("group"))
    assert lines[head].split()[:3] == ["group", "root", "members"]
    rows = [line.split() for line in lines[head + 2:] if line[:1].strip()]
    rows = [r for r in rows if r[0][0].isdigit()]
    doc = json.loads(run_cli(*args, "--json").stdout)["comparisons"][0]["groups"]
    assert [(r[0], r[1]) for r in rows] == [(g["address"], g["main_path"][0]) for g in doc]
    section = level.read_text().split("groups:\n", 1)[1].split()
    assert [r[1] for r in rows] == section[1::2]
    # a grammar-form level keeps the table as it was
    grammar = tmp_path / "g1.lsys"
    run_cli("simplify", "examples/stalk8.lsys", "--level", "1", "--form", "grammar",
            "-o", str(grammar))
    text = run_cli("compare", "examples/stalk8.lsys", str(grammar), *args[3:]).stdout
    assert "group  members  path" in text


@pytest.mark.parametrize("every", [5, 3])          # 3 does not divide the 10 steps
def test_pictures_and_figures_of_a_side_kept_every_k_steps(tmp_path, every):
    # the original's CSV at every step, the level's kept every K-th: compared at the level's
    # samples, and --at T poses both trees at T. The same OBJ and figures as with both CSVs
    # kept every K-th step (no thinning on that route); compare's --at used to index the
    # level's 3 samples with the original's sample number (an internal error, or a frame of
    # another time)
    level = tmp_path / "l1.lsys"
    level.write_text(STALK8_LEVEL1)
    wind = ["--dt", "0.01", "--steps", "10", "--wind-speed", "5"]
    csv = {}
    for name, tree, k in (("o1", "examples/stalk8.lsys", 1), ("ok", "examples/stalk8.lsys", every),
                          ("sk", str(level), every)):
        csv[name] = str(tmp_path / f"{name}.csv")
        run_cli("simulate", tree, *wind, "--every", str(k), "-o", csv[name])
    at = f"{2 * every * 0.01:g}"
    results = {}
    for name, original in (("mixed", csv["o1"]), ("both", csv["ok"])):
        out = run_cli("compare", "examples/stalk8.lsys", str(level), "--original-angles", original,
                      "--simplified-angles", csv["sk"], "--at", at, "--obj",
                      str(tmp_path / name), "--json")
        results[name] = (json.loads(out.stdout), (tmp_path / name / f"frame_t{at}.obj").read_text())
    assert results["mixed"][1] == results["both"][1]
    a = results["mixed"][0]["comparisons"][0]
    b = results["both"][0]["comparisons"][0]
    assert a["amplitude_error"] == pytest.approx(b["amplitude_error"], rel=1e-9, abs=1e-15)
    assert a["tip_error"] == pytest.approx(b["tip_error"], rel=1e-9, abs=1e-15)
    # two CSVs of one tree (`--angles`) are not thinned, and the message says so
    diff = run_cli("compare", "--angles", csv["o1"], csv["ok"], exit_code=2)
    assert "the same --dt, span and --every" in diff.stderr and "simulate --every" not in diff.stderr


def test_first_hour_messages(runner, stalks):
    """A new user's first hour (session 42): an angle CSV in degrees read as radians is named
    with the --degrees hint (as export names it); an undefined period says which run lacks it
    and why; swapped trees are asked about; --angles reads the new file against the
    reference, as trees read."""
    simulate_csv(runner, "stalk8.lsys", "rad.csv")
    deg = runner.invoke(cli, ["simulate", "stalk8.lsys", *RUN, "--degrees", "-o", "deg.csv"])
    assert deg.exit_code == 0
    # stalk8 at 20 m/s bends its top branch past 57.3° = 1 rad: in degrees, far past 1 "rad"
    both = invoke(runner, ["stalk8.lsys", "stalk8.lsys", "--original-angles", "rad.csv",
                           "--simplified-angles", "deg.csv"])
    warnings = [line for line in both.stderr.splitlines() if "tilts" in line]
    assert len(warnings) == 1 and warnings[0].startswith("warning: deg.csv: branch")
    assert "give --degrees" in warnings[0]
    # 1 s holds less than one swing (4.44 s): the original has no period, and is named
    short = invoke(runner, ["stalk8.lsys", "stalk8_level1.lsys", "--dt", "0.01", "--steps",
                            "100", "--wind-speed", "5"])
    assert short.exit_code == 0
    line = next(x for x in short.stderr.splitlines() if "no defined period" in x)
    assert "stalk8.lsys crosses its mean upward fewer than twice in the 1 s window" in line
    assert "--duration" in line
    swapped = invoke(runner, ["stalk8_level1.lsys", "stalk8.lsys", *RUN])
    assert swapped.exit_code == 2 and swapped.stderr.count("\n") == 1
    assert "given the other way round?" in swapped.stderr
    # unrelated trees are not asked so (an API fuzzing round): abop_1_24a's addresses do not
    # begin with stalk8's
    shutil.copy(ROOT / "examples" / "abop_1_24a.lsys", "abop.lsys")
    unrelated = invoke(runner, ["stalk8.lsys", "abop.lsys", *RUN])
    assert unrelated.exit_code == 2 and "more than the original's" in unrelated.stderr
    assert "other way round" not in unrelated.stderr
    order = invoke(runner, ["--angles", "rad.csv", "deg.csv"])
    assert "compare: deg.csv against rad.csv:" in order.stderr


def test_a_level_compared_with_another_tree_than_its_own_is_named(tmp_path):
    """compare took a level with any original: 100 % figures, or an error about addresses
    that named the wrong problem (a newcomer's first hour). The level's header names the
    file it was made from: where that is another file than ORIGINAL (by name), a warning
    says so, and an error about the trees' groups says it too. The API warns alike."""
    import warnings

    import plantlod

    level = tmp_path / "l1.lsys"
    run_cli("simplify", str(ROOT / "examples" / "stalk8.lsys"), "--level", "1", "-o", str(level))
    copy = tmp_path / "mine.lsys"
    shutil.copy(ROOT / "examples" / "stalk8.lsys", copy)
    said = f"its header says it is a level of {ROOT / 'examples' / 'stalk8.lsys'}"
    run = ("--dt", "0.01", "--duration", "1", "--wind-speed", "5")
    renamed = run_cli("compare", str(copy), str(level), *run)
    assert f"warning: {level}: {said}, and it is compared here with {copy}" in renamed.stderr
    wrong = run_cli("compare", str(ROOT / "examples" / "eval" / "twin_draw.lsys"), str(level),
                    *run, exit_code=2)
    assert wrong.stderr.count("\n") == 1 and "stand for no branch of the original" in wrong.stderr
    assert f"({said}, and it is compared here with " in wrong.stderr
    own = run_cli("compare", str(ROOT / "examples" / "stalk8.lsys"), str(level), *run)
    assert "its header says" not in own.stderr
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plantlod.compare(str(copy), str(level), wind=(5, 0, 0), dt=0.01, duration=1)
    assert any(said in str(w.message) for w in caught)
