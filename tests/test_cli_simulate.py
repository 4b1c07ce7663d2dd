"""`plantlod simulate`: inputs, options, usage errors, refusal, divergence, pipes.

Expected values are independent of the code under test: exact equalities
between runs that must agree by the model (the same tree by two routes, the
same wind by two spellings, --duration T = --steps T/dt), unit conversions
(degrees = radians * 180/pi), the scheme's rule that step 1 uses the wind at
t0 (a wind file starting at rest leaves row t = dt all zero), and the stability
limit dt < (4 - 2c) 1000 / k (model.md section 4) worked out for stalk8 (k = 20).
"""

from __future__ import annotations

import math
import os
import pathlib
import subprocess

import pytest

from golden_util import ROOT, run_cli

STALK8 = "examples/stalk8.lsys"
RUN = ("--dt", "0.01", "--steps", "40", "--wind-speed", "10")

# A one-branch tree whose leaf drives it hard enough (k_FA = 1e300) to overflow.
DIVERGING_LSYS = """derivation_length: 1
branching_angle: 30
force_absorbed: 1e300
force_propagated: 0.7
branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20
leaf L: area=1
axiom: F L
"""


def _table(text: str) -> tuple[list[str], list[list[float]]]:
    lines = text.splitlines()
    return lines[0].split(","), [[float(x) for x in line.split(",")] for line in lines[1:]]


def _one_line_error(result, *fragments: str) -> str:
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    for fragment in fragments:
        assert fragment in lines[0]
    return lines[0]


def test_from_lsys_header_rows_and_times():
    result = run_cli("simulate", STALK8, *RUN)
    header, rows = _table(result.stdout)
    addresses = [f"0.{j >> 2 & 1}.{j >> 1 & 1}.{j & 1}" for j in range(8)]
    assert header == ["t"] + [f"{k}:{a}" for a in addresses for k in ("b", "r")]
    assert len(rows) == 41
    assert [r[0] for r in rows] == pytest.approx([k * 0.01 for k in range(41)], rel=1e-12)
    assert rows[0][1:] == [0.0] * 16
    # a wind toward +x bends the stalk (b > 0) and does not rotate it
    assert all(r[2::2] == [0.0] * 8 for r in rows)
    assert all(v > 0 for v in rows[-1][1::2])
    summary = result.stderr.splitlines()
    assert len(summary) == 1 and summary[0].startswith("simulate: examples/stalk8.lsys: 8 branches")


def test_tree_file_and_stdin_give_the_lsys_bytes(tmp_path):
    direct = run_cli("simulate", STALK8, *RUN).stdout
    tree_text = run_cli("derive", STALK8).stdout
    tree_file = tmp_path / "stalk8.tree.jsonl"
    tree_file.write_text(tree_text, encoding="utf-8")
    assert run_cli("simulate", str(tree_file), *RUN).stdout == direct
    assert run_cli("simulate", "-", *RUN, input=tree_text).stdout == direct
    # and an .lsys file on stdin too
    lsys_text = (ROOT / STALK8).read_text(encoding="utf-8")
    assert run_cli("simulate", "-", *RUN, input=lsys_text).stdout == direct


def test_derive_pipe_simulate_equivalence_parametric_tree():
    """`derive | simulate -` on a tree with angles and offsets: the file keeps every bit."""
    args = ("--dt", "0.01", "--steps", "20", "--wind", "3,4,0")
    direct = run_cli("simulate", "examples/abop_2_6.lsys", "-n", "4", *args).stdout
    tree_text = run_cli("derive", "examples/abop_2_6.lsys", "-n", "4").stdout
    assert run_cli("simulate", "-", *args, input=tree_text).stdout == direct


def test_n_is_refused_for_a_tree_file():
    tree_text = run_cli("derive", STALK8).stdout
    result = run_cli("simulate", "-", "-n", "2", *RUN, input=tree_text, exit_code=2)
    _one_line_error(result, "-n")


def test_output_file(tmp_path):
    direct = run_cli("simulate", STALK8, *RUN).stdout
    out = tmp_path / "a.csv"
    result = run_cli("simulate", STALK8, *RUN, "-o", str(out))
    assert result.stdout == ""
    assert out.read_text(encoding="utf-8") == direct
    assert os.listdir(tmp_path) == ["a.csv"]


@pytest.mark.parametrize("every", [1, 3, 7, 40])     # (41: refused since session 34)
def test_every_keeps_every_kth_row(every):
    _h, full = _table(run_cli("simulate", STALK8, *RUN).stdout)
    _h, kept = _table(run_cli("simulate", STALK8, *RUN, "--every", str(every)).stdout)
    assert kept == full[::every]
    assert len(kept) == 40 // every + 1


def test_degrees_are_radians_times_180_over_pi():
    _h, rad = _table(run_cli("simulate", STALK8, *RUN).stdout)
    _h, deg = _table(run_cli("simulate", STALK8, *RUN, "--degrees").stdout)
    for r, d in zip(rad, deg):
        assert d[0] == r[0]                                  # times stay seconds
        assert d[1:] == pytest.approx([x * 180.0 / math.pi for x in r[1:]], rel=2e-9, abs=0)


def test_duration_is_steps_times_dt():
    by_steps = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "40", "--wind-speed", "10")
    by_time = run_cli("simulate", STALK8, "--dt", "0.01", "--duration", "0.4", "--wind-speed", "10")
    assert by_time.stdout == by_steps.stdout
    # round(T / dt): 0.004 s of 0.003 s steps is one step (1.33), 0.005 s is two (1.67)
    for duration, steps in (("0.004", 1), ("0.005", 2), ("0", 0)):
        _h, rows = _table(run_cli("simulate", STALK8, "--dt", "0.003", "--duration", duration,
                                  "--wind-speed", "1").stdout)
        assert len(rows) == steps + 1


def test_wind_spellings_agree():
    vector = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "40", "--wind", "10,0,0").stdout
    speed = run_cli("simulate", STALK8, *RUN).stdout
    assert vector == speed
    # toward 90 degrees is +y: the same as the vector (0, 10, 0)
    sideways = run_cli("simulate", STALK8, *RUN, "--wind-direction", "90").stdout
    assert sideways == run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "40",
                               "--wind", "0,10,0").stdout
    # a wind along +y on the vertical stalk rotates it (r > 0) and does not bend it
    _h, rows = _table(sideways)
    assert all(v > 0 for v in rows[-1][2::2]) and rows[-1][1::2] == [0.0] * 8
    # an oblique direction: the vector (10 cos 30, 10 sin 30, 0)
    oblique = run_cli("simulate", STALK8, *RUN, "--wind-direction", "30").stdout
    spelled = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "40", "--wind",
                      f"{10 * math.cos(math.radians(30))!r},{10 * math.sin(math.radians(30))!r},0")
    assert oblique == spelled.stdout


def test_no_wind_option_is_calm():
    _h, rows = _table(run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "5").stdout)
    assert all(r[1:] == [0.0] * 16 for r in rows)


def test_wind_file(tmp_path):
    # held at 10 m/s: the same run as a constant wind (interpolation between equal keys)
    steady = tmp_path / "steady.csv"
    steady.write_text("0,10,0,0\n1,10,0,0\n", encoding="utf-8")
    _h, from_file = _table(run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "40",
                                   "--wind-file", str(steady)).stdout)
    _h, constant = _table(run_cli("simulate", STALK8, *RUN).stdout)
    for a, b in zip(from_file, constant):
        assert a == pytest.approx(b, rel=1e-12, abs=0)
    # a ramp from rest: step 1 uses the wind at t0 = 0, so row t = dt is still all zero
    ramp = tmp_path / "ramp.csv"
    ramp.write_text("0,0,0,0\n1,10,0,0\n", encoding="utf-8")
    _h, rows = _table(run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "3",
                              "--wind-file", str(ramp)).stdout)
    assert rows[1][1:] == [0.0] * 16
    assert all(v > 0 for v in rows[2][1::2])


def test_wind_file_errors(tmp_path):
    missing = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "3",
                      "--wind-file", str(tmp_path / "none.csv"), exit_code=2)
    _one_line_error(missing, "none.csv", "error")
    bad = tmp_path / "bad.csv"
    bad.write_text("0,1,0\n", encoding="utf-8")
    result = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "3", "--wind-file", str(bad),
                     exit_code=2)
    assert _one_line_error(result, "error").startswith(f"{bad}:1:")


def test_gusts_are_seeded():
    base = ("simulate", STALK8, *RUN)
    plain = run_cli(*base).stdout
    gusty = run_cli(*base, "--gust-strength", "0.5").stdout
    assert gusty != plain
    assert run_cli(*base, "--gust-strength", "0.5").stdout == gusty
    assert run_cli(*base, "--gust-strength", "0.5", "--gust-seed", "1").stdout != gusty
    assert run_cli(*base, "--gust-strength", "0").stdout == plain


@pytest.mark.parametrize("args, fragment", [
    (("--dt", "0.01"), "--duration"),
    (("--dt", "0.01", "--steps", "3", "--duration", "1"), "--duration"),
    (("--dt", "0.01", "--steps", "3", "--wind", "1,0,0", "--wind-speed", "2"), "--wind"),
    (("--dt", "0.01", "--steps", "3", "--wind-speed", "2", "--wind-file", "x.csv"), "--wind"),
    (("--dt", "0.01", "--steps", "3", "--wind", "1,0"), "--wind"),
    (("--dt", "0.01", "--steps", "3", "--wind", "1,0,nan"), "--wind"),
    (("--steps", "3"), "--dt"),
    (("--dt", "0", "--steps", "3"), "--dt"),
])
def test_usage_errors_exit_2(args, fragment):
    result = run_cli("simulate", STALK8, *args, exit_code=2)
    assert result.stdout == ""
    assert "Traceback" not in result.stderr
    assert fragment in result.stderr


def test_stdin_twice_is_a_usage_error():
    result = run_cli("simulate", "-", "--dt", "0.01", "--steps", "3", "--wind-file", "-",
                     input="", exit_code=2)
    assert "INPUT and --wind-file both read standard input (-)" in result.stderr


@pytest.mark.parametrize("dt, damping, largest", [("250", "0", "200"), ("150", "1", "100")])
def test_stability_refusal(tmp_path, dt, damping, largest):
    """stalk8 has k_bs = k_rs = 20: dt must stay below (4 - 2c) * 1000 / 20."""
    out = tmp_path / "x.csv"
    result = run_cli("simulate", STALK8, "--dt", dt, "--steps", "3", "--damping", damping,
                     "-o", str(out), exit_code=2)
    line = _one_line_error(result, "'F'", f"dt < {largest} s", "error")
    assert line.startswith("examples/stalk8.lsys")
    assert result.stdout == ""
    assert os.listdir(tmp_path) == []
    # just below the limit runs
    below = str(float(largest) * 0.999)
    run_cli("simulate", STALK8, "--dt", below, "--steps", "3", "--damping", damping)


def test_divergence_exit_1_and_no_output_file(tmp_path):
    (tmp_path / "div.lsys").write_text(DIVERGING_LSYS, encoding="utf-8")
    result = run_cli("simulate", "div.lsys", "--dt", "0.01", "--steps", "100", "--wind-speed",
                     "10", "-o", "div.csv", exit_code=1, cwd=tmp_path)
    _one_line_error(result, "diverged", "error")
    assert sorted(os.listdir(tmp_path)) == ["div.lsys"]


def test_progress_bar_not_shown_when_stderr_is_not_a_terminal():
    result = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "2000", "--wind-speed", "5")
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("simulate:")
    assert "\r" not in result.stderr and "\x1b" not in result.stderr
    assert "simulating" not in result.stderr


def _plantlod() -> str:
    return str(ROOT / ".venv" / "bin" / "plantlod")


def test_progress_bar_not_shown_in_a_subprocess_with_piped_stderr(tmp_path):
    done = subprocess.run([_plantlod(), "simulate", STALK8, "--dt", "0.01", "--steps", "20000",
                           "--wind-speed", "5", "-o", str(tmp_path / "out.csv")],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("simulate:")
    assert "\r" not in done.stderr and "\x1b" not in done.stderr


def test_head_ends_the_pipe_quietly():
    command = (f"{_plantlod()} simulate examples/stalk8.lsys --dt 0.01 --steps 200000 "
               f"--wind-speed 5 | head -n 2")
    done = subprocess.run(["bash", "-c", command], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr
    assert done.stdout.count("\n") == 2
    assert done.stdout.startswith("t,b:0.0.0.0,r:0.0.0.0,")
    assert done.stdout.splitlines()[1] == "0" + ",0" * 16


def test_simulate_twice_gives_identical_bytes():
    args = ("simulate", "examples/abop_1_24a.lsys", "-n", "3", "--dt", "0.01", "--steps", "50",
            "--wind", "4,1,0", "--gust-strength", "0.3")
    assert run_cli(*args).stdout == run_cli(*args).stdout


def test_every_must_be_positive():
    result = run_cli("simulate", STALK8, *RUN, "--every", "0", exit_code=2)
    assert "--every" in result.stderr


def test_pathlib_paths_in_messages_are_as_given(tmp_path):
    """A missing input is named as the user wrote it."""
    name = str(pathlib.Path("no") / "such.lsys")
    result = run_cli("simulate", name, *RUN, exit_code=2)
    assert _one_line_error(result).startswith(f"{name}: error: ")


def test_every_past_the_run_is_refused_as_the_api_refuses_it(tmp_path):
    """--every 11 over 10 steps wrote the row at t = 0 alone, exit 0, where
    plantlod.simulate(..., steps=10, every=11) refused it (session 34's fuzzing)."""
    out = tmp_path / "a.csv"
    result = run_cli("simulate", "examples/stalk8.lsys", "--dt", "0.01", "--steps", "10",
                     "--every", "11", "--wind-speed", "5", "-o", str(out), exit_code=2)
    assert "'--every': 11 is more than the run's 10 steps; expected at most 10" in result.stderr
    assert not out.exists()
    run_cli("simulate", "examples/stalk8.lsys", "--dt", "0.01", "--steps", "10", "--every", "10",
            "--wind-speed", "5", "-o", str(out))
    assert len(out.read_text().splitlines()) == 3          # the header, t = 0 and t = 0.1


HEADER = """\
# plantlod simplify: level 1 of stalk8.lsys (derivation length 3 -> 2)
# form: grammar
# method: derived
{damping}# errors of this file against the original (model.md section 6), steady winds from rest,
# dt 0.02 s, 20 s, every 4 steps sampled:
"""


@pytest.mark.parametrize("damping, options, said", [
    ("", ("--dt", "0.02"), None),
    ("", ("--dt", "0.01"), "at dt 0.02 s, undamped (its header); this run differs, and the "
     "level's figures hold only under those: give --dt 0.02"),
    ("# damping ratio: 0.05 (fitted and measured under it; simulate it with --damping-ratio)\n",
     ("--dt", "0.02"), "give --damping-ratio 0.05"),
    ("# damping ratio: 0.05 (fitted and measured under it; simulate it with --damping-ratio)\n",
     ("--dt", "0.02", "--damping-ratio", "0.05"), None),
    ("", ("--dt", "0.02", "--damping", "0.01"), "give no --damping"),
])
def test_a_level_run_otherwise_than_fitted_says_so(tmp_path, damping, options, said):
    """A new user's first hour (session 42): a level fitted with a damping ratio or at
    another dt (its header says which) ran under other conditions without a word, though
    its periods move with dt (model.md 4) and its fitted swing with ζ."""
    body = open(ROOT / STALK8, encoding="utf-8").read()
    path = tmp_path / "level.lsys"
    path.write_text(HEADER.format(damping=damping) + "\n" + body, encoding="utf-8")
    result = run_cli("simulate", str(path), *options, "--steps", "5", "--wind-speed", "3",
                     "-o", os.devnull)
    warnings = [x for x in result.stderr.splitlines() if x.startswith("warning:")]
    if said is None:
        assert warnings == []
    else:
        assert len(warnings) == 1 and said in warnings[0], warnings


def test_only_simplify_s_own_header_is_read():
    """Comment lines that only look like it, or a header after the first statement, say
    nothing (`formats.level_header`)."""
    from plantlod.formats.level_header import fitted_conditions

    assert fitted_conditions("# my tree\n# dt 0.02 s, 20 s, every 4 steps sampled:\n") is None
    assert fitted_conditions("name: x\n# plantlod simplify: level 1\n# dt 0.02 s, 1 s, x\n") is None
    assert fitted_conditions("# plantlod simplify: level 1\n# dt nan s, 1 s,\n") is None
    got = fitted_conditions("\n#  plantlod simplify: level 2 of a\n# damping ratio: 0.1 (x)\n"
                            "# dt 0.005 s, 20 s, every 4 steps sampled:\nname: a\n")
    assert (got.dt, got.damping_ratio) == (0.005, 0.1)


def test_simplify_s_header_reads_back(tmp_path):
    """The writer (`simplify.pipeline.header_comment`) and the reader agree: a level fitted
    at dt 0.02 s under damping ratio 0.05 says so."""
    from plantlod.formats.level_header import fitted_conditions

    out = tmp_path / "l1.lsys"
    run_cli("simplify", STALK8, "--level", "1", "--dt", "0.02", "--damping-ratio", "0.05",
            "-o", str(out))
    got = fitted_conditions(out.read_text(encoding="utf-8"))
    assert (got.dt, got.damping_ratio) == (0.02, 0.05)
