"""What the tool writes, its own readers read back: valid but extreme inputs found by a
fuzzing round in session 24 (each was refused by the tool's own reader, or an internal
error), and a tree that absorbs no force refused in words."""

from __future__ import annotations

import numpy as np
import pytest

from plantlod.formats.lsys_file import parse_lsys_text, write_lsys
from plantlod.lsys.build import build
from plantlod.lsys.errors import InputError

HEAD = """derivation_length: 2
branching_angle: 25
force_absorbed: 0.005
force_propagated: 0.7
branch F: length=0.4 radius=0.01 bend_strength=30 rotation_strength=30
"""

# an interpretation that draws two branches from one module: the level's group roots
# include an address with a ':1' suffix
TWO_DRAWN = "name: im\n" + HEAD + "axiom: A\nproductions:\n  A -> A [+A]\ninterpretation:\n  A -> F [+F]\n"


def test_a_levels_tree_file_keeps_group_roots_that_end_in_a_suffix(tmp_path):
    """A level whose `groups:` names '0.0.0:1' was written to a tree file (.jsonl, .npz) that
    the tree readers refused ('"group_root" must be an address like "0.2.1"')."""
    import io

    from plantlod.formats.npz import read_tree_bytes, tree_bytes
    from plantlod.formats.treefile import read_tree, write_tree
    from plantlod.simplify.explicit import explicit_system_text, level_header, merge_levels

    system = parse_lsys_text(TWO_DRAWN, "im.lsys")
    original = build(system).tree
    text, tree = explicit_system_text(original, merge_levels(original)[1], name="im",
                                      header=level_header(system), level=1, dt=0.01,
                                      duration=2.0)
    level = build(parse_lsys_text(text, "l1.lsys")).tree
    assert any(":" in r for r in level.group_root)          # (else this shows nothing)
    out = io.StringIO()
    write_tree(level, out)
    for back in (read_tree(io.StringIO(out.getvalue()), "l1.jsonl"),
                 read_tree_bytes(tree_bytes(level), "l1.npz")):
        assert back.group_root == level.group_root
        assert back.address == level.address


@pytest.mark.parametrize("word", ["seed", "leafs", "brnch", "name", "groups"])
def test_a_long_axiom_is_split_where_the_reader_reads_modules(word):
    """An axiom over AXIOM_LINE_CHARS is written on indented lines; a line that began with
    modules spelling a statement word ('seed', or a near miss such as 'leafs') was read as
    that statement: the written file did not read back."""
    from plantlod.formats.constants import AXIOM_LINE_CHARS

    text = ("name: ax\n" + HEAD + "leaf L: area=0.01\naxiom: F L " + "A" * (AXIOM_LINE_CHARS - 2)
            + " " + word + "\nproductions:\n  F -> F F\n")
    system = parse_lsys_text(text, "ax.lsys")
    written = write_lsys(system)
    assert "\naxiom:\n" in written                       # split over lines
    assert parse_lsys_text(written, "back.lsys") == system


def test_an_axiom_that_cannot_be_split_is_written_on_one_line():
    """Where the first line itself would start with a statement word, the axiom is written
    on one line (it fits the reader's line limit)."""
    from plantlod.formats.constants import AXIOM_LINE_CHARS

    text = ("name: ax\n" + HEAD + "leaf L: area=0.01\naxiom: seed [F] " + "A" * AXIOM_LINE_CHARS
            + "\nproductions:\n  F -> F F\n")
    system = parse_lsys_text(text, "ax.lsys")
    written = write_lsys(system)
    assert "\naxiom: seed[F]A" in written
    assert parse_lsys_text(written, "back.lsys") == system


def test_a_very_long_name_gives_a_level_that_reads_back(tmp_path):
    from plantlod.simplify.constants import LEVEL_NAME_CHARS
    from plantlod.simplify.explicit import explicit_system_text, level_header, merge_levels

    system = parse_lsys_text("name: " + "n" * 999_990 + "\n" + HEAD
                             + "axiom: F\nproductions:\n  F -> F [+F] F\n", "long.lsys")
    original = build(system).tree
    text, _tree = explicit_system_text(original, merge_levels(original)[1], name=system.name,
                                       header=level_header(system), level=1, dt=0.01,
                                       duration=2.0)
    name = parse_lsys_text(text, "l1.lsys").name
    assert name == "n" * LEVEL_NAME_CHARS + "… level 1 (explicit form)"


def test_a_tree_that_absorbs_no_force_is_refused_in_words(tmp_path):
    """force_absorbed 0 everywhere: the tree stands still. `simplify` said 'unstable in
    simplify's winds' (explicit) or 'drag_coefficient = nan' naming no file (grammar)."""
    from click.testing import CliRunner

    from plantlod.cli.main import cli

    path = tmp_path / "fa0.lsys"
    path.write_text("name: fa0\n" + HEAD.replace("force_absorbed: 0.005", "force_absorbed: 0")
                    + "leaf L: area=0.01\naxiom: F [+F L] [-F L] F L\nproductions:\n"
                      "  F -> F [+F] F\n")
    tree = build(parse_lsys_text(path.read_text(), str(path))).tree
    assert np.all(tree.force_absorbed == 0)
    for form in ("auto", "explicit", "grammar"):
        result = CliRunner().invoke(cli, ["simplify", str(path), "--level", "1", "--form", form,
                                          "-o", str(tmp_path / "o.lsys")])
        assert result.exit_code == 2, result.output
        assert f"{path}: error: the tree absorbs no force" in result.output
        assert not (tmp_path / "o.lsys").exists()


def test_a_scene_tree_that_absorbs_no_force_is_refused_naming_its_file(tmp_path):
    from plantlod.scene.file import read_scene
    from plantlod.scene.run import check_scene

    lsys = tmp_path / "fa0.lsys"
    lsys.write_text("name: fa0\n" + HEAD.replace("force_absorbed: 0.005", "force_absorbed: 0")
                    + "axiom: F\nproductions:\n  F -> F [+F] F\n")
    scene = tmp_path / "s.toml"
    scene.write_text('dt = 0.01\nduration = 2\n[camera]\nposition = [0, -30, 2]\n'
                     f'target = [0, 0, 2]\n[[tree]]\nfile = "{lsys}"\n')
    with pytest.raises(InputError) as err:
        check_scene(read_scene(str(scene)))
    assert err.value.file == str(lsys) and "absorbs no force" in err.value.message


def test_a_strength_at_the_stability_edge_is_not_rounded_past_it(tmp_path):
    """k = 399999.9999999 runs at dt 0.01 (s = k dt / 1000 just under 4); rounded to 12
    digits it was 400000 (s = 4), and the grammar-form level was refused as unstable,
    naming the original file."""
    from click.testing import CliRunner

    from plantlod.cli.main import cli
    from plantlod.simplify.levels import round_sig, round_sig_down

    k = 399999.9999999
    assert round_sig(k) == 400000.0 and round_sig_down(k) == 399999.999999
    path = tmp_path / "edge.lsys"
    path.write_text("name: edge\n" + HEAD.replace("bend_strength=30 rotation_strength=30",
                                                  f"bend_strength={k} rotation_strength={k}")
                    .replace("derivation_length: 2", "derivation_length: 3")
                    + "axiom: F\nproductions:\n  F -> F [+F] F\n")
    out = tmp_path / "l1.lsys"
    result = CliRunner().invoke(cli, ["simplify", str(path), "--level", "1", "--form", "grammar",
                                      "--dt", "0.01", "-o", str(out)])
    assert result.exit_code == 0, result.output
    level = build(parse_lsys_text(out.read_text(), str(out))).tree
    assert level.bend_strength.max() * 0.01 / 1000 < 4


def test_a_grammar_form_that_cannot_follow_names_the_file(tmp_path):
    """An interpretation that draws two branches from one module: the grammar form's level
    has branches no original branch falls under; the refusal named no file."""
    from plantlod.simplify.pipeline import Options, simplify

    with pytest.raises(InputError) as err:
        simplify(parse_lsys_text(TWO_DRAWN, "im.lsys"), Options(level=1, form="grammar"))
    assert err.value.file == "im.lsys"
    assert "stand for no branch of the original" in err.value.message


def test_angles_past_what_degrees_hold_are_refused_and_nothing_is_written(tmp_path):
    """`write_angles(..., degrees=True)` of angles near 1e307 rad wrote 'inf', which the
    angle-CSV reader refuses (and numpy warned of an overflow)."""
    import dataclasses
    import pathlib
    import warnings

    import plantlod

    stalk8 = pathlib.Path(__file__).resolve().parents[1] / "examples" / "stalk8.lsys"
    run = plantlod.simulate(str(stalk8), wind_speed=3, dt=0.01, steps=5)
    huge = dataclasses.replace(run, bend=np.full_like(run.bend, 1e307))
    out = tmp_path / "deg.csv"
    with warnings.catch_warnings():
        warnings.simplefilter("error")                 # (no overflow warning either)
        with pytest.raises(InputError, match="not finite numbers in degrees"):
            plantlod.write_angles(huge, str(out), degrees=True)
    assert not out.exists() and not list(tmp_path.iterdir())
    back = plantlod.read_angles(plantlod.write_angles(huge))      # radians: finite, read back
    assert np.array_equal(back.bend, huge.bend)
