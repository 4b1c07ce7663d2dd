"""The thesis' experiment (examples/Makefile) and its table script (examples/results_table.py).

- The quick variant (QUICK=1: the stalk at levels 1 and 2, both methods, winds
  2 and 10 m/s) runs in a temporary OUT directory and leaves the table, the
  JSON files, the OBJ frame and the PNG; the table has the rows that the
  Makefile's variables call for, and its figures are the JSON files' figures
  as percentages.
- Make sees real files: a second run has nothing to do, a changed setting
  remakes, and `make -n` lists one command per simplified file and per
  (tree, level, method, wind), which `make -j` can run side by side.
- The table script on hand-written JSON files: formatting, sorting, the
  undefined marker, and one-line errors (exit 2) for bad names and files.
"""

from __future__ import annotations

import json
import pathlib
import re
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
SCRIPT = EXAMPLES / "results_table.py"
PLANTLOD = ROOT / ".venv" / "bin" / "plantlod"

# QUICK=1 of examples/Makefile
QUICK_WINDS = ["2", "10"]
QUICK_RUNS = [("stalk8", level, method) for level in (1, 2) for method in ("derived", "thesis")]
QUICK_BRANCHES = {1: "8 → 4", 2: "8 → 2"}

needs_make = pytest.mark.skipif(shutil.which("make") is None,
                                reason="GNU make is not installed: the experiment is a Makefile")
needs_plantlod = pytest.mark.skipif(not PLANTLOD.exists(),
                                    reason=f"{PLANTLOD} missing: run `make` at the top level first")


def _make(out: pathlib.Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    command = ["make", "-C", str(EXAMPLES), "QUICK=1", f"OUT={out}", f"PLANTLOD={PLANTLOD}",
               f"PYTHON={sys.executable}", *args]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    if check and result.returncode != 0:
        pytest.fail(f"{' '.join(command)} exited {result.returncode}:\n{result.stderr[-3000:]}")
    return result


def _tables(text: str) -> list[list[list[str]]]:
    """Every Markdown table of ``text``: its body rows as lists of stripped cells."""
    tables, current = [], None
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            current = (current or []) + [line]
        elif current is not None:
            assert current[1].startswith("|---"), "expected a header and a separator line"
            tables.append([[c.strip() for c in row.strip("|").split("|")] for row in current[2:]])
            current = None
    return tables


def _table_rows(text: str) -> list[list[str]]:
    """Rows of the per-run table (the second table; the first is the summary)."""
    tables = _tables(text)
    assert len(tables) == 2, f"expected a summary and a per-run table, got {len(tables)}"
    return tables[1]


def _percent(cell: str) -> float:
    match = re.fullmatch(r"(\d+\.\d\d) %( \*)?", cell)
    assert match, f"expected a percentage with two decimals, got {cell!r}"
    return float(match.group(1))


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """OUT directory of one `make -C examples QUICK=1 -j2` run."""
    if shutil.which("make") is None:
        pytest.skip("GNU make is not installed: the experiment is a Makefile")
    if not PLANTLOD.exists():
        pytest.skip(f"{PLANTLOD} missing: run `make` at the top level first")
    out = tmp_path_factory.mktemp("experiment") / "out"
    _make(out, "-j2")
    return out


@needs_make
@needs_plantlod
def test_quick_experiment_writes_the_table(quick_run):
    table = (quick_run / "results.md").read_text(encoding="utf-8")
    rows = _table_rows(table)
    expected = [(tree, str(level), method, wind) for tree, level, method in QUICK_RUNS
                for wind in sorted(QUICK_WINDS, key=float)]
    assert [(r[0], r[1], r[3], r[4]) for r in rows] == expected
    for row in rows:
        tree, level, branches, method, wind, amplitude, period, tip, largest = row
        assert branches == QUICK_BRANCHES[int(level)]
        data = json.loads((quick_run / f"{tree}-l{level}-{method}-w{wind}.json")
                          .read_text(encoding="utf-8"))
        comparison = data["comparisons"][0]
        # every figure is a number, and the JSON's figure in percent
        for cell, key in ((amplitude, "amplitude_error"), (period, "period_error"),
                          (tip, "tip_error")):
            assert _percent(cell) == pytest.approx(100 * comparison[key], abs=0.005 + 1e-12)
        assert float(largest) == pytest.approx(comparison["largest_amplitude"], abs=5e-5)
        # a steady wind from rest moves the stalk: something counts, the figures are finite
        assert comparison["largest_amplitude"] > 0
        assert data["samples"] == 1001 and data["time"] == [0.0, 10.0]
    # the summary: per (tree, level, method), the largest of each figure over the winds
    summary = _tables(table)[0]
    assert [r[:5] for r in summary] == [[tree, str(level), QUICK_BRANCHES[level], method,
                                        ", ".join(sorted(QUICK_WINDS, key=float))]
                                       for tree, level, method in QUICK_RUNS]
    for line, (tree, level, method) in zip(summary, QUICK_RUNS):
        for cell, column in zip(line[5:], (5, 6, 7)):
            mine = [r for r in rows if (r[0], r[1], r[3]) == (tree, str(level), method)]
            worst = max(mine, key=lambda r: _percent(r[column]))
            assert cell == f"{worst[column].removesuffix(' *')} ({worst[4]})"
    # the commands that made it are printed with it
    assert "plantlod simplify TREE.lsys --level LEVEL --method METHOD" in table
    assert f"--dt 0.01 --duration 10 --wind-speed WIND --json -o {quick_run}/" in table


@needs_make
@needs_plantlod
def test_quick_experiment_writes_the_figure(quick_run):
    png = (quick_run / "figure4.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    obj = (quick_run / "figure4" / "frame_t4.obj").read_text(encoding="utf-8")
    vertices = [line.split()[1:] for line in obj.splitlines() if line.startswith("v ")]
    assert vertices and all(len(v) == 3 for v in vertices)
    coordinates = [float(x) for v in vertices for x in v]
    # three stalks of 8 m side by side: nothing above 8 m, something near the top
    heights = [float(v[2]) for v in vertices]
    assert max(heights) <= 8.0 + 0.1 and max(heights) > 7.0
    assert all(abs(x) < 100 for x in coordinates)
    objects = [line.split(maxsplit=1)[1] for line in obj.splitlines() if line.startswith("o ")]
    assert len(objects) >= 3, objects
    summary = (quick_run / "figure4.txt").read_text(encoding="utf-8")
    assert "stalk8-l1-derived.lsys" in summary and "stalk8-l2-derived.lsys" in summary


def _planned(result: subprocess.CompletedProcess, command: str) -> list[str]:
    """Lines of make's output that run `plantlod COMMAND` (continuation lines joined)."""
    lines = result.stdout.replace("\\\n", " ").splitlines()
    return [line for line in lines if re.match(rf"\S*plantlod {command}\b", line)]


@needs_make
@needs_plantlod
def test_quick_experiment_is_up_to_date_after_a_run(quick_run, tmp_path):
    """Real file targets: a second run does nothing; a changed setting remakes what used it."""
    again = _make(quick_run)
    assert _planned(again, "simplify") == [] and _planned(again, "compare") == []
    out = tmp_path / "out"
    shutil.copytree(quick_run, out)          # keeps the times, leaves the fixture as it was
    target = out / "stalk8-l1-derived-w2.json"
    before = json.loads(target.read_text(encoding="utf-8"))
    longer = _make(out, f"{target}", "DURATION=9")
    assert _planned(longer, "simplify") == [] and len(_planned(longer, "compare")) == 1
    after = json.loads(target.read_text(encoding="utf-8"))
    assert (before["time"], after["time"]) == ([0.0, 10.0], [0.0, 9.0])


@needs_make
def test_make_n_lists_one_command_per_file(tmp_path):
    """`make -n` plans 4 simplifications, 8 comparisons and the figure's, each its own target."""
    result = subprocess.run(["make", "-n", "-C", str(EXAMPLES), "QUICK=1", f"OUT={tmp_path}/o",
                             "PLANTLOD=plantlod"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    simplify, compare = _planned(result, "simplify"), _planned(result, "compare")
    assert sorted(re.search(r"-o \S+/(\S+)", c).group(1) for c in simplify) == sorted(
        f"{tree}-l{level}-{method}.lsys" for tree, level, method in QUICK_RUNS)
    outputs = sorted(re.search(r"-o \S+/(\S+)", c).group(1) for c in compare)
    assert outputs == sorted([f"{tree}-l{level}-{method}-w{wind}.json"
                              for tree, level, method in QUICK_RUNS for wind in QUICK_WINDS]
                             + ["figure4.txt"])
    assert not tmp_path.joinpath("o").exists() or not any(tmp_path.joinpath("o").glob("*.json"))


# --- results_table.py on hand-written files ------------------------------------------------

def _compare_json(amplitude, period, tip, *, undefined=(), branches=(8, 4), largest=0.0419):
    """A minimal `plantlod compare --json` document with the given worst figures."""
    return {
        "original": {"file": "t.lsys", "branches": branches[0], "leaves": 1, "rest_height": 8.0},
        "samples": 2001, "time": [0.0, 20.0],
        "bounds": {"max_amplitude_error": None, "max_period_error": None, "max_tip_error": None},
        "passed": True,
        "comparisons": [{
            "simplified": {"file": "s.lsys", "branches": branches[1], "leaves": 1},
            "amplitude_error": amplitude, "period_error": period, "tip_error": tip,
            "undefined_periods": [{"address": a, "component": "bend"} for a in undefined],
            "largest_amplitude": largest,
        }],
    }


def _script(*args: str, cwd: pathlib.Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          cwd=cwd, timeout=60)


def _write(directory: pathlib.Path, name: str, document) -> str:
    (directory / name).write_text(json.dumps(document), encoding="utf-8")
    return name


def test_results_table_by_hand(tmp_path):
    files = [
        _write(tmp_path, "stalk8-l1-thesis-w10.json", _compare_json(0.3597, 0.004973, 0.01744)),
        _write(tmp_path, "stalk8-l1-derived-w10.json", _compare_json(0.0007137, 0.0007537, 0.01067)),
        _write(tmp_path, "stalk8-l1-derived-w0.5.json", _compare_json(2.9e-6, 0.0, 0.00119,
                                                                      largest=0.00161)),
        _write(tmp_path, "abop_2_6-l1-derived-w2.json",
               _compare_json(1.274599373, None, 0.0001414626442, undefined=["0.2.1"],
                             branches=(1023, 511))),
    ]
    result = _script(*files, "--command", "plantlod  simplify X", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    rows = _table_rows(result.stdout)
    assert rows == [
        ["abop_2_6", "1", "1023 → 511", "derived", "2", "127.46 %", "- *", "0.01 %", "0.0419"],
        ["stalk8", "1", "8 → 4", "derived", "0.5", "0.00 %", "0.00 %", "0.12 %", "0.0016"],
        ["stalk8", "1", "8 → 4", "derived", "10", "0.07 %", "0.08 %", "1.07 %", "0.0419"],
        ["stalk8", "1", "8 → 4", "thesis", "10", "35.97 %", "0.50 %", "1.74 %", "0.0419"],
    ]
    summary = _tables(result.stdout)[0]
    assert summary == [
        ["abop_2_6", "1", "1023 → 511", "derived", "2", "127.46 % (2)", "-", "0.01 % (2)"],
        ["stalk8", "1", "8 → 4", "derived", "0.5, 10", "0.07 % (10)", "0.08 % (10)",
         "1.07 % (10)"],
        ["stalk8", "1", "8 → 4", "thesis", "10", "35.97 % (10)", "0.50 % (10)", "1.74 % (10)"],
    ]
    assert "Runs from t = 0 to 20 s, 2001 samples." in result.stdout
    assert "some counted components had no defined period" in result.stdout
    assert "```sh\nplantlod simplify X\n```\n" in result.stdout   # spaces collapsed
    # the bytes depend on the set of files, not their order
    again = _script(*reversed(files), "--command", "plantlod  simplify X", cwd=tmp_path)
    assert again.stdout == result.stdout


@pytest.mark.parametrize("name, content, message", [
    ("stalk8_l1_derived_w10.json", "{}", "expected a name TREE-lLEVEL-METHOD-wWIND.json"),
    ("stalk8-l1-derived-w10.json", "not json", "expected JSON from `plantlod compare --json`"),
    ("stalk8-l1-derived-w10.json", '{"original": {}}', "expected JSON from `plantlod compare"),
    ("stalk8-l1-derived-w1.2.3.json", "{}", "expected a wind speed in m/s"),
])
def test_results_table_refuses_bad_files(tmp_path, name, content, message):
    (tmp_path / name).write_text(content, encoding="utf-8")
    result = _script(name, cwd=tmp_path)
    assert result.returncode == 2 and result.stdout == ""
    assert len(result.stderr.strip().splitlines()) == 1
    assert result.stderr.startswith(f"results_table.py: error: {name}: {message}")


def test_results_table_refuses_a_missing_file_and_duplicates(tmp_path):
    missing = _script("stalk8-l1-derived-w10.json", cwd=tmp_path)
    assert missing.returncode == 2 and "cannot read" in missing.stderr
    (tmp_path / "a").mkdir()
    first = _write(tmp_path, "stalk8-l1-derived-w10.json", _compare_json(0.1, 0.1, 0.1))
    second = "a/" + _write(tmp_path / "a", "stalk8-l1-derived-w10.json",
                           _compare_json(0.2, 0.2, 0.2))
    duplicate = _script(first, second, cwd=tmp_path)
    assert duplicate.returncode == 2 and "same tree, level, method and wind" in duplicate.stderr
