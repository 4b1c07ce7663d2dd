"""What a new user pasting from L-Py or cpfg trips over, and runs that say nothing where
they should (issue 24): hints in the parser's errors, warnings (stderr, exit 0) for
preprocessor lines, L-Py's width module, a tree with no branches and angles beyond the
small-angle model's range, each once per run."""

from __future__ import annotations

import warnings

import pytest

import plantlod
from golden_util import ROOT, run_cli
from plantlod.lsys.errors import InputError, PlantlodWarning
from plantlod.lsys.parse import parse_lsys
from test_hardening_cli import one_line

STALK = (ROOT / "examples" / "stalk8.lsys").read_text()
HEAD = """derivation_length: 2
branching_angle: 30
force_absorbed: 0.005
force_propagated: 0.7
"""
SIM = ("--dt", "0.01", "--steps", "3", "--wind-speed", "1")


def parse_error(text: str) -> InputError:
    with pytest.raises(InputError) as info:
        parse_lsys(text, "x.lsys")
    return info.value


@pytest.mark.parametrize("text, where, fragment", [
    ("c = 1\n" + STALK, (1, 1), "a constant is 'define c = 1'"),
    ("  width = 0.5 * 2\n" + STALK, (1, 3), "'define width = 0.5 * 2'"),
    (STALK + "  c = 1\n", (32, 3), "'define c = 1'"),
    (STALK.replace("axiom:", "define q = 2**3\naxiom:"), (29, 13), "'**' (L-Py and Python"),
    (STALK + "endlsystem\n", (32, 1), "'endlsystem' (L-Py, cpfg) ends an L-system"),
    ("Lsystem: 1\n" + STALK, (1, 1), "cpfg"),
    ("derivation length: 3\n" + STALK, (1, 1), "is 'derivation_length: N' here"),
    (STALK.replace("axiom:", "Axiom:"), (29, 1), "'Axiom:' (L-Py, cpfg) is 'axiom:' here"),
    (STALK.replace("productions:", "homomorphism:"), (30, 1), "is 'interpretation:' here"),
    (STALK.replace("axiom: F L", 'axiom: F "L'), (29, 10), "multiply the length"),
    (STALK.replace("axiom: F L", "axiom: F ;L"), (29, 10), "colour index"),
    ("from math import *\n" + STALK, (1, 1), "Python code (L-Py) is not read here"),
    (STALK.replace("F -> F F", "F -> F F : 0.3"), (31, 12), "'A -> (0.3) B'"),
    # an arrow mistyped: not read as an assignment `F = > F F` (a new user's, session 33)
    (STALK.replace("F -> F F", "F => F F"), (31, 5), "'=>' is not a production arrow; expected '->'"),
    (STALK.replace("F -> F F", "F(x) ==> F F"), (31, 8), "'==>' is not a production arrow"),
])
def test_lpy_and_cpfg_spellings_get_a_hint(text, where, fragment):
    error = parse_error(text)
    assert (error.line, error.col) == where, error
    assert fragment in error.message, error.message


def test_a_statement_is_not_taken_for_an_assignment():
    parse_lsys(STALK.replace("name: stalk8", "name: stalk8\ndefine c = 1"), "x.lsys")
    assert parse_error("branching_angle = 3\n" + STALK).message == (
        "a header key takes ':'; expected 'branching_angle: 3'")


def test_preprocessor_lines_and_the_width_module_warn_once(tmp_path):
    path = tmp_path / "w.lsys"
    path.write_text("#define c 1\n#define d 2\n" + STALK.replace("axiom: F L", "axiom: _(2) F L"))
    result = run_cli("derive", str(path), "-o", str(tmp_path / "t.jsonl"))
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert warned == [
        f"warning: {path}:1: '#define' (cpfg's C preprocessor) is read as a comment here; a "
        "constant is 'define NAME = VALUE'",
        f"warning: {path}:31:8: '_' (L-Py: set the width) is an ordinary module here that draws "
        "nothing; a branch's radius is its 'radius=' or !(r)"]
    # a comment that mentions define is only a comment
    path.write_text("# define the stalk\n" + STALK)
    assert "warning" not in run_cli("derive", str(path), "-o", str(tmp_path / "t.jsonl")).stderr


def test_an_undeclared_F_warns_once_where_other_branches_draw(tmp_path):
    """ABOP's F draws a segment; here an undeclared F is an ordinary module that draws nothing
    (docs/lsys-format.md): a new user who wrote it in the axiom of a tree of other symbols
    got one branch fewer and no word (session 33). Said once, at its first place; not where
    F is declared, interpreted, or no branch symbol is declared at all (that has its own
    warning, above)."""
    body = STALK.replace("branch F:", "branch G:").replace("F -> F F", "G -> G G")
    body = body.replace("axiom: F L", "axiom: F G L F")
    path = tmp_path / "f.lsys"
    path.write_text(body)
    result = run_cli("derive", str(path), "-o", str(tmp_path / "t.jsonl"))
    line = next(n for n, text in enumerate(body.splitlines(), 1) if text.startswith("axiom:"))
    assert [w for w in result.stderr.splitlines() if w.startswith("warning:")] == [
        f"warning: {path}:{line}:8: 'F' (ABOP: draw a segment) is not declared, so here it "
        "draws nothing; declare it, e.g. 'branch F: length=1 radius=0.02 bend_strength=20 "
        "rotation_strength=20'"]
    path.write_text(body + "interpretation:\n  F -> G\n")
    assert "ABOP" not in run_cli("derive", str(path), "-o", str(tmp_path / "t.jsonl")).stderr
    path.write_text(STALK)
    assert "warning" not in run_cli("derive", str(path), "-o", str(tmp_path / "t.jsonl")).stderr


@pytest.mark.parametrize("command", [("derive",), ("simulate", *SIM)])
def test_a_tree_with_no_branches_warns(tmp_path, command):
    path = tmp_path / "nb.lsys"
    path.write_text(HEAD + "axiom: A B\nproductions:\n  A -> A B\n")
    result = run_cli(command[0], str(path), *command[1:], "-o", str(tmp_path / "out"))
    assert result.stderr.count("warning:") == 1
    assert f"warning: {path}: no branch symbol declared, so the tree has no branches" in result.stderr
    path.write_text(HEAD + "branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20\n"
                    "axiom: A\n")
    result = run_cli(command[0], str(path), *command[1:], "-o", str(tmp_path / "out"))
    assert "no branch symbol (F) is in the derived string" in result.stderr


def test_the_api_warns_of_a_tree_with_no_branches():
    system = parse_lsys(HEAD + "axiom: A\n", "nb.lsys")
    with pytest.warns(PlantlodWarning, match="no branch symbol declared"):
        plantlod.derive(system)


BIG = STALK.replace("length=1 ", "length=457 ")       # the book's units: a 457 m trunk


def test_angles_beyond_one_radian_warn_once_naming_branch_and_time(tmp_path):
    path = tmp_path / "big.lsys"
    path.write_text(BIG)
    result = run_cli("simulate", str(path), "--dt", "0.01", "--duration", "10", "--wind-speed", "5",
                     "-o", str(tmp_path / "a.csv"))
    warned = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    assert warned == [f"warning: {path}: branch 0.0.0.0 tilts 1.01 rad at t = 0.93 s, beyond 1 "
                      "rad: the small-angle model (docs/model.md) is far outside its range "
                      "there; check the units (metres), the wind and the strengths"]
    small = run_cli("simulate", str(ROOT / "examples" / "stalk8.lsys"), "--dt", "0.01",
                    "--duration", "10", "--wind-speed", "5", "-o", str(tmp_path / "b.csv"))
    assert "warning" not in small.stderr
    both = run_cli("compare", str(path), str(path), "--dt", "0.01", "--duration", "3",
                   "--wind-speed", "5", "--json")
    assert both.stderr.count("tilts 1.01 rad at t = 0.93 s") == 1


def test_the_api_warns_of_large_angles_once_per_call():
    tree = plantlod.derive(parse_lsys(BIG, "big.lsys"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        plantlod.simulate(tree, wind=[(5.0, 0, 0), (6.0, 0, 0)], dt=0.01, duration=3)
    messages = [str(w.message) for w in caught if issubclass(w.category, PlantlodWarning)]
    assert len(messages) == 1 and "big.lsys, wind 0: branch 0.0.0.0 tilts" in messages[0]


# --- texts that must not go out of date -------------------------------------------------

def test_the_group_help_lists_every_command_without_a_stale_count():
    import re

    from plantlod.cli.main import cli

    text = run_cli("--help").stdout
    listed = re.findall(r"^    (\w+)  ", text, re.M)
    assert sorted(listed) == sorted(cli.commands), listed
    words = ("two", "three", "four", "five", "six", "seven", "eight", "nine")
    assert not re.search(rf"\b({'|'.join(words)}) commands\b", text)


def test_simplify_help_does_not_promise_the_grammar_form():
    text = " ".join(run_cli("simplify", "--help").stdout.split())
    assert "The result keeps FILE's axiom and productions" not in text
    assert "explicit form" in text and "groups: section" in text


def test_scene_docs_describe_plot_as_built():
    text = (ROOT / "docs" / "scene.md").read_text()
    assert "Not built yet" not in text and "`--plot FILE.png` draws" in text
