"""`plantlod derive`: outputs, options, the module guard and bad input.

Expected values come from the L-systems worked by hand: stalk8 (F -> F F from
`F L`: 2^n branches in one chain) and ABOP 1.24a (F -> F[+FL]F[-FL]F from `F L`:
5^n branches, m_n = 2 + 12 (5^n - 1) / 4 modules, since each rewritten F adds 12).
"""

from __future__ import annotations

import json
import os
import re

import pytest

from golden_util import run_cli

STALK8 = "examples/stalk8.lsys"
ABOP_124A = "examples/abop_1_24a.lsys"

BAD_LSYS = """name: bad
derivation_length: 2
branching_angle: 30
force_absorbed: 0.1
force_propagated: 0.5
branch F: length=1 radius=0.1 bend_strength=20 rotation_strength=20
axiom: F(
"""
# the error is on line 7, at the end of `axiom: F(` (column 10): no argument follows '('
BAD_LOCATION = "7:10"


def abop_124a_modules(n: int) -> int:
    """Length of ABOP 1.24a's string after n steps: 2 + 12 * (1 + 5 + ... + 5^(n-1))."""
    return 2 + 12 * sum(5 ** j for j in range(n))


def _jsonl(text: str) -> list[dict]:
    assert text.endswith("\n")
    return [json.loads(line) for line in text.split("\n")[:-1]]


def _no_traceback(result) -> None:
    assert "Traceback" not in result.stderr and "Traceback" not in result.stdout


def test_tree_output_is_pure_json_lines_and_summary_on_stderr():
    result = run_cli("derive", STALK8)
    records = _jsonl(result.stdout)              # every stdout line parses as JSON
    assert records[0]["format"] == "plantlod-tree"
    assert [r.get("type") for r in records] == [None] + ["branch"] * 8 + ["leaf"]
    # one summary line, on stderr only, with the counts worked out by hand
    lines = result.stderr.splitlines()
    assert len(lines) == 1
    assert re.fullmatch(r"derive: 9 modules, 8 branches, 1 leaf, depth 8, \d+\.\d{3} s", lines[0])
    assert "derive:" not in result.stdout


def test_string_format_matches_hand_rewriting():
    # F -> F[+FL]F[-FL]F applied twice to `F L`, every F at once
    text = "FL"
    for _ in range(2):
        text = "".join("F[+FL]F[-FL]F" if ch == "F" else ch for ch in text)
    result = run_cli("derive", ABOP_124A, "-n", "2", "--format", "string")
    assert result.stdout == text + "\n"
    assert len(text) == abop_124a_modules(2)
    assert "derive:" in result.stderr and "F[" not in result.stderr


@pytest.mark.parametrize("n", [0, 1, 2, 4])
def test_n_sets_the_derivation_length(n):
    records = _jsonl(run_cli("derive", STALK8, "-n", str(n)).stdout)
    header = records[0]
    assert (header["branches"], header["leaves"], header["depth"]) == (2 ** n, 1, 2 ** n)
    assert [r["parent"] for r in records[1:-1]] == list(range(-1, 2 ** n - 1))
    # the leaf sits on the last branch; its address is the axiom's index 1, then n zeros
    assert records[-1]["branch"] == 2 ** n - 1
    assert records[-1]["address"] == ".".join(["1"] + ["0"] * n)


def test_output_file_gets_the_stdout_bytes(tmp_path):
    direct = run_cli("derive", STALK8).stdout
    out = tmp_path / "stalk8.tree.jsonl"
    result = run_cli("derive", STALK8, "-o", str(out))
    assert result.stdout == ""
    assert out.read_bytes() == direct.encode("utf-8")
    assert os.listdir(tmp_path) == ["stalk8.tree.jsonl"]     # no temporary file left
    assert "derive: 9 modules" in result.stderr


def test_output_dash_is_stdout():
    assert run_cli("derive", STALK8, "-o", "-").stdout == run_cli("derive", STALK8).stdout


def test_stdin_input_gives_the_same_tree():
    text = open(os.path.join(os.path.dirname(__file__), "..", STALK8), encoding="utf-8").read()
    from_file = _jsonl(run_cli("derive", STALK8).stdout)
    from_stdin = _jsonl(run_cli("derive", "-", input=text).stdout)
    assert from_stdin[0]["source"] == "<stdin>"
    from_file[0]["source"] = "<stdin>"
    assert from_stdin == from_file


def test_max_modules_guard(tmp_path):
    out = tmp_path / "big.jsonl"
    limit = abop_124a_modules(4) - 1
    result = run_cli("derive", ABOP_124A, "-n", "5", "--max-modules", str(limit), "-o", str(out),
                     exit_code=2)
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1
    counts = [int(x.replace(",", "")) for x in re.findall(r"\d[\d,]*", lines[0])]
    assert abop_124a_modules(4) in counts          # names the module count step 4 would make
    assert limit in counts
    assert "error" in lines[0]
    _no_traceback(result)
    assert os.listdir(tmp_path) == []
    # exactly at the limit the derivation goes through
    ok = run_cli("derive", ABOP_124A, "-n", "4", "--max-modules", str(limit + 1))
    assert _jsonl(ok.stdout)[0]["branches"] == 5 ** 4


def test_bad_lsys_one_line_error_and_no_output_file(tmp_path):
    src = tmp_path / "bad.lsys"
    src.write_text(BAD_LSYS, encoding="utf-8")
    out = tmp_path / "out.jsonl"
    result = run_cli("derive", "bad.lsys", "-o", "out.jsonl", exit_code=2, cwd=tmp_path)
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"bad.lsys:{BAD_LOCATION}: error: ")
    assert "expected" in lines[0]
    _no_traceback(result)
    assert not out.exists()
    assert sorted(os.listdir(tmp_path)) == ["bad.lsys"]


def test_bad_lsys_on_stdin_is_named_stdin():
    result = run_cli("derive", "-", input=BAD_LSYS, exit_code=2)
    assert result.stderr.startswith(f"<stdin>:{BAD_LOCATION}: error: ")
    assert result.stderr.count("\n") == 1


def test_missing_output_directory_is_input_error(tmp_path):
    result = run_cli("derive", STALK8, "-o", str(tmp_path / "no" / "such" / "dir.jsonl"),
                     exit_code=2)
    assert "output directory does not exist" in result.stderr
    assert result.stdout == ""


def test_dropped_leaf_warning_goes_to_stderr(tmp_path):
    src = tmp_path / "leaf_first.lsys"
    src.write_text(BAD_LSYS.replace("axiom: F(", "leaf L: area=0.01\naxiom: L F"), encoding="utf-8")
    result = run_cli("derive", "leaf_first.lsys", cwd=tmp_path)
    records = _jsonl(result.stdout)
    assert (records[0]["leaves"], records[0]["branches"]) == (0, 1)   # no productions
    assert "warning:" in result.stderr
    assert "warning" not in result.stdout


def test_derive_twice_gives_identical_bytes():
    for args in ((STALK8,), ("examples/abop_1_25.lsys",), ("examples/abop_2_6.lsys", "--format",
                                                            "string", "-n", "4")):
        assert run_cli("derive", *args).stdout == run_cli("derive", *args).stdout
