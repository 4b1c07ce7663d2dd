"""A file of one kind handed where another is read, or an output named for another kind, is
named by what it is (session 25, from a new user's first hour): an angle CSV given as the
tree said "unexpected 't' outside a section", an L-system given as the angles "expected the
header to start with 't'", an .lsys file given as a scene "not valid TOML", a USD file given
to `view` a JSON parser's message, and `simplify -o out.glb` wrote L-system text into a .glb.

The files are made by the commands themselves (simulate, derive, export), not written here
in the shape the sniffer looks for, so a change of any writer that the sniffer misses fails.
"""

from __future__ import annotations

import pytest

from golden_util import ROOT, run_cli
from test_hardening_cli import one_line
from plantlod.formats.kinds import KINDS, text_kind

STALK = str(ROOT / "examples" / "stalk8.lsys")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One file of every kind plantlod writes or reads, made by plantlod."""
    d = tmp_path_factory.mktemp("kinds")
    made = {"lsys": STALK, "scene": str(ROOT / "examples" / "forest.toml")}
    made["csv"] = str(d / "a.csv")
    run_cli("simulate", STALK, "--dt", "0.01", "--duration", "0.5", "--wind-speed", "5", "-o",
            made["csv"])
    made["tree"] = str(d / "t.jsonl")
    run_cli("derive", STALK, "-o", made["tree"])
    for ext in ("gltf", "usda", "usdc", "glb"):
        made[ext] = str(d / f"s.{ext}")
        run_cli("export", STALK, made["csv"], "-o", made[ext])
    made["html"] = str(d / "page.html")
    run_cli("view", made["glb"], "-o", made["html"])
    made["report"] = str(d / "c.json")
    run_cli("compare", STALK, STALK, "--dt", "0.01", "--duration", "1", "--json", "-o",
            made["report"])
    return made


@pytest.mark.parametrize("kind, expected", [
    ("lsys", "lsys"), ("scene", "scene"), ("csv", "csv"), ("tree", "tree"),
    ("gltf", "gltf"), ("usda", "usd"), ("report", "report"), ("html", "html"),
])
def test_each_kind_is_told_by_its_start(files, kind, expected):
    with open(files[kind], encoding="utf-8") as handle:
        assert text_kind(handle.read()) == expected


# (command line with {csv} {tree} … for the files, the kind given, the kind expected there)
WRONG = [
    ("simulate {csv} --dt 0.01 --duration 1 -o /dev/null", "csv", "lsys"),
    ("derive {csv} -o /dev/null", "csv", "lsys"),
    ("export {csv} {lsys} -o {out}.glb", "csv", "lsys"),            # arguments swapped
    ("export {lsys} {tree} -o {out}.glb", "tree", "csv"),
    ("compare --angles {lsys} {csv}", "lsys", "csv"),
    ("scene {lsys} --no-cache", "lsys", "scene"),
    ("scene {csv} --no-cache", "csv", "scene"),
    ("derive {gltf} -o /dev/null", "gltf", "lsys"),
    ("simulate {gltf} --dt 0.01 --duration 1 -o /dev/null", "gltf", "tree"),
    ("derive {usda} -o /dev/null", "usd", "lsys"),
    ("view {lsys} -o {out}.html", "lsys", "gltf"),
    ("view {tree} -o {out}.html", "tree", "gltf"),
    ("scene {report} --no-cache", "report", "scene"),         # a report given as the scene
    ("derive {report} -o /dev/null", "report", "lsys"),
    ("simulate {report} --dt 0.01 --duration 1 -o /dev/null", "report", "tree"),
    # view's own page given back to it, or to derive (a helper's fuzzing, session 33)
    ("view {html} -o {out}.html", "html", "gltf"),
    ("derive {html} -o /dev/null", "html", "lsys"),
]


@pytest.mark.parametrize("line, given, read_as", WRONG)
def test_a_file_of_another_kind_is_named_by_what_it_is(files, tmp_path, line, given, read_as):
    args = line.format(out=tmp_path / "out", **files).split()
    culprit = files["usda" if given == "usd" else given]
    message = one_line(run_cli(*args, exit_code=None), 2, KINDS[given][0],
                       f"not {KINDS[read_as][0]}")
    assert message.startswith(f"{culprit}: error:")
    assert sorted(p.name for p in tmp_path.iterdir()) == []          # nothing written


@pytest.mark.parametrize("ext", ["usda", "usdc"])
def test_view_names_a_usd_file(files, tmp_path, ext):
    one_line(run_cli("view", files[ext], "-o", str(tmp_path / "v.html"), exit_code=None), 2,
             "an OpenUSD file, not a glTF", "export the tree to .glb or .gltf")


def test_a_binary_usd_file_is_named_where_text_is_read(files):
    one_line(run_cli("derive", files["usdc"], "-o", "/dev/null", exit_code=None), 2,
             "a binary OpenUSD file (.usdc)")


def test_a_file_of_its_own_kind_with_a_mistake_keeps_its_own_message(tmp_path):
    """The sniffer speaks only for another kind: an L-system with a bad line is still told
    its line and column."""
    bad = tmp_path / "bad.lsys"
    bad.write_text(open(STALK, encoding="utf-8").read().replace("axiom: F L", "axiom: F L )"))
    line = one_line(run_cli("derive", str(bad), "-o", "/dev/null", exit_code=None), 2)
    assert line.startswith(f"{bad}:") and "not an L-system" not in line


@pytest.mark.parametrize("args, fragment", [
    (["simplify", STALK, "--level", "1", "-o", "{d}/out.glb"], "writes an L-system, not a glTF"),
    (["derive", STALK, "-o", "{d}/t.csv"], "not an angle CSV (.csv)"),
    (["derive", STALK, "--format", "string", "-o", "{d}/s.jsonl"], "writes the derived string"),
    (["simulate", STALK, "--dt", "0.01", "--duration", "1", "-o", "{d}/a.lsys"],
     "writes angles"),
    (["compare", STALK, STALK, "--dt", "0.01", "--duration", "1", "--plot", "{d}/p.jpg"],
     "writes a PNG picture, not a JPEG picture"),
    (["view", STALK, "-o", "{d}/page.png"], "writes a web page"),
    (["scene", str(ROOT / "examples" / "forest.toml"), "--report", "{d}/r.csv"],
     "writes the report (JSON)"),
])
def test_an_output_named_for_another_kind_is_refused_before_any_work(tmp_path, args, fragment):
    args = [a.format(d=tmp_path) for a in args]
    one_line(run_cli(*args, exit_code=None), 2, fragment)
    assert list(tmp_path.iterdir()) == []


def test_an_output_over_its_input_is_named_so_first(tmp_path):
    """Writing over an input loses data: that refusal comes before the extension's."""
    copy = tmp_path / "s.lsys"
    copy.write_text(open(STALK, encoding="utf-8").read())
    one_line(run_cli("derive", str(copy), "-o", str(copy), exit_code=None), 2,
             "-o would write over the input")


def test_outputs_without_a_known_extension_pass(tmp_path):
    run_cli("derive", STALK, "-o", str(tmp_path / "tree.out"))
    run_cli("derive", STALK, "-o", "/dev/null")
    assert (tmp_path / "tree.out").read_text().startswith("{")


def test_empty_input_says_it_is_empty(tmp_path):
    one_line(run_cli("simulate", "-", "--dt", "0.01", "--steps", "5", input="", exit_code=None),
             2, "standard input is empty; expected an L-system")
    empty = tmp_path / "e.lsys"
    empty.write_text("\n  \n")
    one_line(run_cli("derive", str(empty), exit_code=None), 2, "the file is empty")
    # a scene said "-: error: missing [camera]" (session 35)
    one_line(run_cli("scene", "-", input="", exit_code=None), 2,
             "<stdin>:1:1: error: standard input is empty; expected a scene")
    blank = tmp_path / "s.toml"
    blank.write_text("\n \n")
    one_line(run_cli("scene", str(blank), exit_code=None), 2, "s.toml:1:1: error: the file is empty")


def test_a_leaf_symbol_that_never_draws_is_warned_of(tmp_path):
    """A misspelled leaf (`l` for the declared `L`) left the tree leafless without a word."""
    typo = tmp_path / "typo.lsys"
    typo.write_text(open(STALK, encoding="utf-8").read().replace("axiom: F L", "axiom: F l"))
    result = run_cli("derive", str(typo), "-o", "/dev/null")
    assert "no leaf symbol (L) is in the derived string" in result.stderr
    assert "0 leaves" in result.stderr
    assert "warning" not in run_cli("derive", STALK, "-o", "/dev/null").stderr


def test_a_sample_mismatch_names_the_angle_file_it_came_from(files):
    """The original's 51 samples came from --original-angles, which the message named as the
    .lsys file (session 25)."""
    line = one_line(run_cli("compare", STALK, STALK, "--dt", "0.01", "--duration", "1",
                            "--original-angles", files["csv"], exit_code=None), 2)
    assert f"{files['csv']} (the angles of {STALK}) has 51 samples" in line


def test_export_of_some_frames_says_which(files, tmp_path):
    """`--frames 5:15` was reported as the whole run's seconds."""
    out = tmp_path / "f.glb"
    result = run_cli("export", STALK, files["csv"], "-o", str(out), "--frames", "5:15")
    assert "frames 5:15 (10 frames, 0.3 s) at 30 fps" in result.stderr
    import pygltflib

    doc = pygltflib.GLTF2.load(str(out))
    times = doc.accessors[doc.animations[0].samplers[0].input]
    assert times.count == 10 and abs(times.max[0] - 9 / 30) < 1e-6


def test_an_explicit_level_of_a_leafless_tree_is_not_warned_of(tmp_path):
    """Explicit levels declare their leaf symbol whether or not the original has leaves: the
    no-leaf warning (meant for a misspelled symbol) fired on every use of such a level."""
    bare = tmp_path / "bare.lsys"
    bare.write_text(open(STALK, encoding="utf-8").read().replace("axiom: F L", "axiom: F"))
    level = tmp_path / "bare-l1.lsys"
    run_cli("simplify", str(bare), "--level", "1", "--form", "explicit", "--duration", "5",
            "-o", str(level))
    assert "leaf L" in level.read_text()
    result = run_cli("derive", str(level), "-o", "/dev/null")
    assert "0 leaves" in result.stderr and "no leaf symbol" not in result.stderr
    assert "no leaf symbol (L)" in run_cli("derive", str(bare), "-o", "/dev/null").stderr


@pytest.mark.parametrize("edit, fragment", [
    (lambda t: "#usda-style comment\n" + t.replace("axiom: F L", "axiom: F("), "unexpected end of line"),
    (lambda t: t.replace("  F -> F F", "  F -> F F\n[tree]"), "cannot be a predecessor"),
])
def test_a_broken_file_that_also_shows_its_own_kind_keeps_its_own_error(tmp_path, edit,
                                                                        fragment):
    """An L-system whose comment began `#usda`, or with a `[tree]` line among its productions,
    was named "an OpenUSD file" or "a scene file" (a regression fuzz of session 25): the
    sniffer now speaks only where the text shows no sign of the reader's own kind."""
    path = tmp_path / "t.lsys"
    path.write_text(edit(open(STALK, encoding="utf-8").read()))
    line = one_line(run_cli("derive", str(path), "-o", "/dev/null", exit_code=None), 2, fragment)
    assert "not an L-system" not in line and line.startswith(f"{path}:")


@pytest.mark.parametrize("stray", ['"nodes": [1]', '"speedup": 1'])
def test_a_tree_file_with_a_stray_key_keeps_its_own_error(files, tmp_path, stray):
    """A tree file with a key a glTF or a report has was named "a glTF" / "a report"."""
    lines = open(files["tree"], encoding="utf-8").read().splitlines()
    lines[2] = lines[2][:-1] + ", " + stray + "}"
    path = tmp_path / "t.jsonl"
    path.write_text("\n".join(lines) + "\n")
    line = one_line(run_cli("simulate", str(path), "--dt", "0.01", "--steps", "5", "-o",
                            "/dev/null", exit_code=None), 2, "unknown key")
    assert line.startswith(f"{path}:3:")


def test_compare_plot_to_standard_output_beside_the_table_is_refused(tmp_path):
    """`compare --plot -` without -o put the PNG after the table on standard output; the
    refusal names the table, not an -o nobody gave (session 29)."""
    one_line(run_cli("compare", STALK, STALK, "--dt", "0.01", "--duration", "1", "--plot", "-",
                     exit_code=None), 2, "the table (no -o) and --plot both write to standard output")


@pytest.mark.parametrize("kind, what", [
    ("csv", "an angle CSV"), ("tree", "a tree file (JSON Lines)"), ("gltf", "a glTF"),
    ("glb", "a binary glTF (.glb)"), ("usda", "an OpenUSD file (.usda)"),
    ("scene", "a scene file (TOML)"), ("report", "a report (JSON)"),
])
def test_a_scene_tree_of_another_kind_is_named_at_the_scenes_line(files, tmp_path, kind, what):
    """A scene's `file =` naming an angle CSV (a new user's, session 33), a tree file, a glTF
    and so on: refused at the scene's line, saying what the file is; it was the other file's
    reader's error, naming that file, not the scene."""
    scene = tmp_path / "s.toml"
    text = ("duration = 1\n[wind]\nspeed = 5\n[camera]\nposition = [0, -40, 1.7]\n"
            f'target = [0, 0, 1.7]\n[[tree]]\nposition = [0, 0, 0]\nfile = "{files[kind]}"\n')
    scene.write_text(text)
    line = run_cli("scene", str(scene), "--no-cache", exit_code=2).stderr.splitlines()
    at = next(n for n, t in enumerate(text.splitlines(), 1) if t.startswith("file ="))
    assert len(line) == 1 and line[0].startswith(f"{scene}:{at}:"), line
    assert f"is {what}" in line[0] and line[0].endswith("expected an .lsys file")
    # an L-system is read as before
    scene.write_text(text.replace(files[kind], files["lsys"]))
    run_cli("scene", str(scene), "--no-cache", "--budget", "1e9")
