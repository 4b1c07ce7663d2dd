"""Level-n skeletons: addresses, groups, equivalent-leaf rules, bad levels (simplify/levels.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from plantlod.formats.lsys_file import format_production, read_lsys, write_lsys
from plantlod.lsys.build import build
from plantlod.lsys.errors import InputError
from plantlod.lsys.parse import parse_lsys
from plantlod.lsys.tree import occurrence_numbers
from plantlod.simplify.targets import group_map
from plantlod.simplify.levels import (equivalent_leaf_rules, level_system, round_sig,
                                      write_parameters)


def stalk():
    return read_lsys("examples/stalk8.lsys")


@pytest.mark.parametrize("level, addresses", [
    # F -> F F from axiom "F L": step 2 has F at 0.0.0, 0.0.1, 0.1.0, 0.1.1 (by hand)
    (1, ["0.0.0", "0.0.1", "0.1.0", "0.1.1"]),
    (2, ["0.0", "0.1"]),
])
def test_stalk_levels_have_the_expected_branches_and_groups(level, addresses):
    system = stalk()
    skeleton, expanded = level_system(system, level, equivalent_leaves=True)
    assert skeleton.derivation_length == 3 - level
    assert skeleton.axiom == system.axiom and skeleton.productions == system.productions
    assert expanded == []                     # F -> F F attaches no leaf: nothing to stand in
    tree = build(skeleton).tree
    assert tree.address == addresses
    original = build(system).tree
    gmap = group_map(original, tree)
    for g, a in enumerate(addresses):
        members = [original.address[i] for i in np.flatnonzero(gmap.groups == g)]
        assert members == [x for x in original.address if x.startswith(a + ".")]
        assert len(members) == 2 ** level
        # the main path of a straight stalk is the whole group, bottom to top
        assert [original.address[i] for i in gmap.paths[g]] == members


@pytest.mark.parametrize("level", [0, 3, 7])
def test_level_must_lie_between_1_and_n_minus_1(level):
    with pytest.raises(InputError, match="level"):
        level_system(stalk(), level, equivalent_leaves=False)


def test_equivalent_leaf_rules_by_hand():
    # abop_1_24a: F -> F[+FL]F[-FL]F; dropping the branches leaves the two side leaves,
    # with their turns, bracketed so that nothing after F is turned.
    rules = equivalent_leaf_rules(read_lsys("examples/abop_1_24a.lsys"))
    assert [format_production(r) for r in rules] == ["F -> F[[+L][-L]]"]
    # abop_1_24b: F -> F[+FL]F[-FL][FL] and L -> (old leaves are erased): the L of the
    # level-n string is gone in the original, so it goes in the level-n tree too.
    rules = equivalent_leaf_rules(read_lsys("examples/abop_1_24b.lsys"))
    assert [format_production(r) for r in rules] == ["F -> F[[+L][-L][L]]", "L ->"]
    # abop_2_6: apices A, B, C show a leaf now (A -> L); in the original they are replaced
    # by their successors, whose apices are leaves: A(l,w) -> !(w)F(l)[&(a0)B(..)]/(d)A(..)
    rules = equivalent_leaf_rules(read_lsys("examples/abop_2_6.lsys"))
    assert [format_production(r) for r in rules] == [
        "A(l,w) -> [[&(a0)L]/(d)L]", "B(l,w) -> [[-(a2)$L]L]", "C(l,w) -> [[+(a2)$L]L]"]


# A module drawn through interpretation (X shows a branch P and a leaf): a new user's fern.
INTERPRETED_BRANCH = """derivation_length: 3
branching_angle: 40
force_absorbed: 0.002
force_propagated: 0.7
branch S: length=0.3 radius=0.015 bend_strength=45 rotation_strength=45
branch P: length=0.12 radius=0.004 bend_strength=35 rotation_strength=32
leaf L: area=0.002
axiom: A
productions:
  A -> S [+X] A
  X -> P X
interpretation:
  X -> /(30) P L
"""


@pytest.mark.parametrize("shown, turns", [("/(30) P L", 1), ("+(40) P L", 1),
                                          ("&(20) P /(50) L", 2)])
def test_a_module_drawing_a_branch_keeps_it_under_equivalent_leaves(shown, turns):
    # X -> P X, shown as /(30) P L: in the original X is replaced by P X, shown as
    # P /(30) P L, so the level's X keeps what it draws (its P stands for its group), the
    # roll included, and its own leaf goes; the successor's leaf comes in brackets, its
    # turns taken from X's own frame: the leaves' rest normals are the original's
    # (a first version turned them twice: 60° for a roll of 30°)
    from plantlod.simplify.static import rest_frames

    system = parse_lsys(INTERPRETED_BRANCH.replace("X -> /(30) P L", f"X -> {shown}"))
    rules = {r.pred.name: format_production(r) for r in equivalent_leaf_rules(system)}
    assert rules["X"].startswith("X -> " + shown.split(" L")[0].split(" /")[0].replace(" ", ""))
    plain, _ = level_system(system, 1, equivalent_leaves=False)
    skeleton, expanded = level_system(system, 1, equivalent_leaves=True)
    assert "X" in expanded
    level = build(skeleton).tree
    assert level.address == build(plain).tree.address
    original = build(system).tree
    assert level.n_leaves == original.n_leaves == 3              # one leaf per X, as before

    def normals(tree):
        frames = rest_frames(tree).frame[tree.leaf_branch]
        n = np.einsum("fij,fj->fi", frames, tree.leaf_normal)
        return np.array(sorted(map(tuple, np.round(n, 9))))

    np.testing.assert_allclose(normals(level), normals(original), atol=1e-8)
    assert len(np.unique(normals(original).round(6), axis=0)) >= 1 and turns


def test_a_module_whose_interpretation_rolls_to_the_horizontal_gets_no_leaf_rule():
    # $ cannot be undone: the leaf's turns from X's frame would be lost
    system = parse_lsys(INTERPRETED_BRANCH.replace("X -> /(30) P L", "X -> $ P L"))
    assert "X" not in {r.pred.name for r in equivalent_leaf_rules(system)}


def test_simplify_a_module_drawing_a_branch_in_either_form(tmp_path):
    # It used to stop with "internal error" (the leaf rule dropped X's branch, so the
    # level's branches no longer matched its groups).
    from golden_util import run_cli
    path = tmp_path / "fern.lsys"
    path.write_text(INTERPRETED_BRANCH)
    for form in ("grammar", "auto"):
        out = tmp_path / f"l1-{form}.lsys"
        run = run_cli("simplify", str(path), "--level", "1", "--form", form, "-o", str(out))
        assert "internal error" not in run.stderr
        level = build(parse_lsys(out.read_text())).tree
        assert 0 < level.n_branches < build(parse_lsys(INTERPRETED_BRANCH)).tree.n_branches


def test_equivalent_leaves_have_the_originals_rest_normals():
    # Level 1 of abop_2_6 at N = 3: every original leaf at step 3 hangs under an apex of
    # step 2, and the equivalent leaves repeat the turns that lead to it, so the sets of
    # world-frame normals are equal.
    from plantlod.simplify.static import rest_frames
    system = replace(read_lsys("examples/abop_2_6.lsys"), derivation_length=3)
    original = build(system).tree
    skeleton, expanded = level_system(system, 1, equivalent_leaves=True)
    simplified = build(skeleton).tree
    assert expanded == ["A", "B", "C"]

    def normals(tree):
        frames = rest_frames(tree).frame[tree.leaf_branch]
        n = np.einsum("fij,fj->fi", frames, tree.leaf_normal)
        return np.array(sorted(map(tuple, np.round(n, 9))))

    assert simplified.n_leaves == original.n_leaves
    np.testing.assert_allclose(normals(simplified), normals(original), atol=1e-8)


def test_write_parameters_uses_symbols_where_one_value_suffices():
    skeleton, _ = level_system(stalk(), 1, equivalent_leaves=False)
    drag = np.array([0.5, 0.5, 0.5, 0.25])
    out = write_parameters(skeleton, {"drag_coefficient": drag, "length": np.full(4, 2.0)},
                           {("1.0.0", 0): 0.03})   # the axiom's L (address 1), copied twice
    f = out.branch_symbol("F")
    assert f.drag_coefficient == 0.5 and f.length == 2.0
    assert out.leaf_symbol("L").area == 0.03
    assert [(o.address, o.values) for o in out.overrides] == [
        ((0, 1, 1), (("drag_coefficient", 0.25),))]
    tree = build(parse_lsys(write_lsys(out))).tree
    np.testing.assert_array_equal(tree.drag_coefficient, drag)
    np.testing.assert_array_equal(tree.leaf_area, [0.03])


AREA_K_SYSTEM = """derivation_length: 1
branching_angle: 30
rotation_angle: 30
force_absorbed: 0.001
force_propagated: 0.5
branch F: length=1 radius=0.01 bend_strength=20 rotation_strength=20
leaf L: area=0.01
axiom: Y G
productions:
  G -> F L
interpretation:
  Y -> F[+L][-L]L
"""


def test_write_parameters_gives_each_leaf_of_an_address_its_own_area():
    # Y (address 0.0) draws three leaves under one address; two areas need area_K
    system = parse_lsys(AREA_K_SYSTEM)
    tree = build(system).tree
    assert tree.leaf_address == ["0.0", "0.0", "0.0", "1.1"]
    keys = [("0.0", 0), ("0.0", 1), ("0.0", 2)]
    out = write_parameters(system, {}, {keys[0]: 0.02, keys[1]: 0.03, keys[2]: 0.02,
                                        ("1.1", 0): 0.02})
    assert out.leaf_symbol("L").area == 0.02                  # the most common value
    assert [(o.address, o.values) for o in out.overrides] == [((0, 0), (("area_1", 0.03),))]
    text = write_lsys(out)
    assert "0.0: area_1=0.03" in text
    np.testing.assert_array_equal(build(parse_lsys(text)).tree.leaf_area, [0.02, 0.03, 0.02, 0.02])
    # all leaves of the address alike, but not the symbol's value: one area= line
    out = write_parameters(system, {}, {**{k: 0.05 for k in keys}, ("1.1", 0): 0.01})
    assert out.leaf_symbol("L").area == 0.05
    assert [(o.address, o.values) for o in out.overrides] == [((1, 1), (("area", 0.01),))]


def test_area_k_overrides_apply_after_area_and_by_drawing_order():
    text = AREA_K_SYSTEM + """overrides:
  0.0: area=0.5 area_2=0.7 area_9=1
  1.1: area_0=0.2
"""
    built = build(parse_lsys(text))
    assert built.warnings == ["override area_9 for address 0.0 matches no leaf (3 attached there)"]
    tree = built.tree
    np.testing.assert_array_equal(tree.leaf_area, [0.5, 0.5, 0.7, 0.2])
    assert "0.0: area=0.5 area_2=0.7 area_9=1" in write_lsys(parse_lsys(text))


def test_write_parameters_rejects_impossible_values():
    skeleton, _ = level_system(stalk(), 1, equivalent_leaves=False)
    with pytest.raises(InputError, match="drag_coefficient"):
        write_parameters(skeleton, {"drag_coefficient": np.array([1.0, -1.0, 1.0, 1.0])}, {})
    with pytest.raises(ValueError, match="no leaf"):
        write_parameters(skeleton, {}, {("1", 0): 0.03})


def test_round_sig():
    assert round_sig(0.1 + 0.2) == 0.3
    assert round_sig(1 / 3) == 0.333333333333
    assert round_sig(0.0) == 0.0


def test_occurrence_numbers():
    np.testing.assert_array_equal(occurrence_numbers(["a", "b", "a", "c", "b", "a"]),
                                  [0, 0, 1, 0, 1, 2])
    np.testing.assert_array_equal(occurrence_numbers([3, 3, -1, 3]), [0, 1, 0, 2])
    assert occurrence_numbers([]).shape == (0,)
    with pytest.raises(ValueError, match="1-D"):
        occurrence_numbers([[0, 1], [0, 1]])


DROPPED_LEAF_SYSTEM = AREA_K_SYSTEM.replace("  Y -> F[+L][-L]L\n", "  Y -> L F[+L]L\n")


def test_area_k_counts_only_attached_leaves():
    # Y (address 0.0) reads L before drawing F: that leaf is dropped, so area_0 is the
    # second L read (the first one attached)
    text = DROPPED_LEAF_SYSTEM + """overrides:
  0.0: area_0=0.3
"""
    built = build(parse_lsys(text))
    assert any("dropped" in w or "no branch" in w for w in built.warnings)
    assert built.tree.leaf_address == ["0.0", "0.0", "1.1"]
    np.testing.assert_array_equal(built.tree.leaf_area, [0.3, 0.01, 0.01])


def test_write_parameters_with_a_dropped_leaf_sets_every_area_by_override():
    system = parse_lsys(DROPPED_LEAF_SYSTEM)
    wanted = {("0.0", 0): 0.02, ("0.0", 1): 0.03, ("1.1", 0): 0.02}
    out = write_parameters(system, {}, wanted)
    assert out.leaf_symbol("L").area == 0.01          # which symbol a leaf is is not known here
    np.testing.assert_array_equal(build(parse_lsys(write_lsys(out))).tree.leaf_area,
                                  [0.02, 0.03, 0.02])
