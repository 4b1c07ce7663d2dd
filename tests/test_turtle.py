"""The turtle (lsys/turtle.py, model.md section 2).

Small strings are checked against positions, frames and angles worked out by
hand; the examples and random strings against the slow, literal reference
turtle of tests/reference_model.py (an independent implementation), to 1e-12.
Strings are built directly as `DerivedString` arrays, so these tests do not
depend on the parser or the derivation engine, except the examples test.
"""

from __future__ import annotations

import glob
import math
import re
import warnings

import numpy as np
import pytest

from plantlod.lsys.derived import DerivedString
from plantlod.lsys.errors import InputError
from plantlod.lsys.rotation import matrix_from_zyz, rot_x, rot_z
from plantlod.lsys.system import BranchSymbol, LeafSymbol, LSystem, Override
from plantlod.lsys.tree import chain_depths
from plantlod.lsys.turtle import build_tree

from reference_model import reference_turtle, tree_from_reference

D30 = math.radians(30)
S30, C30 = math.sin(D30), math.cos(D30)


# --- helpers -----------------------------------------------------------------------

def make_string(text: str, history=(), origin=None) -> DerivedString:
    """A DerivedString from ABOP text like ``F(2)[+(30)F]L`` (white space ignored)."""
    mods = re.findall(r"([^\s(])(?:\(([^)]*)\))?", text)
    alphabet = sorted({ch for ch, _ in mods})
    params = [[float(x) for x in args.split(",")] if args else [] for _, args in mods]
    starts = np.zeros(len(mods) + 1, dtype=np.int64)
    np.cumsum([len(p) for p in params], out=starts[1:])
    return DerivedString(
        alphabet=alphabet,
        codes=np.array([alphabet.index(ch) for ch, _ in mods], dtype=np.int32),
        param_start=starts,
        params=np.array([v for p in params for v in p], dtype=np.float64),
        history=[(np.asarray(p, dtype=np.int64), np.asarray(q, dtype=np.int64))
                 for p, q in history],
        origin=None if origin is None else np.asarray(origin, dtype=np.int64))


def make_system(branching=30.0, rotation=90.0, overrides=(), **header) -> LSystem:
    """Branch symbols F (length 1, radius 0.1) and G (length 0.5, own k_FA, C_d); leaf L."""
    return LSystem(
        derivation_length=0, branching_angle=branching, rotation_angle=rotation,
        force_absorbed=header.get("force_absorbed", 0.01),
        force_propagated=header.get("force_propagated", 0.7),
        drag_coefficient=header.get("drag_coefficient", 0.002),
        leaf_force_scale=header.get("leaf_force_scale", 1.0),
        axiom=(),
        branches=(BranchSymbol("F", 1.0, 0.1, 20.0, 30.0),
                  BranchSymbol("G", 0.5, 0.05, 40.0, 50.0, force_absorbed=0.03,
                               drag_coefficient=0.004)),
        leaves=(LeafSymbol("L", 0.01),),
        overrides=tuple(Override(tuple(a), tuple(sorted(v.items()))) for a, v in overrides),
        source="test.lsys")


def turtle(text, system=None, **kw):
    return build_tree(system or make_system(), make_string(text, **kw))


def rest_pose(tree):
    """World frames, bases and tips at rest (model.md section 3 with all angles 0)."""
    frames, bases, tips = [], [], []
    for i in range(tree.n_branches):
        p = int(tree.parent[i])
        r_parent = np.eye(3) if p < 0 else frames[p]
        start = np.zeros(3) if p < 0 else tips[p]
        frame = r_parent @ matrix_from_zyz(*tree.euler[i])
        base = start + r_parent @ tree.offset[i]
        frames.append(frame)
        bases.append(base)
        tips.append(base + tree.length[i] * frame[:, 2])
    return np.array(frames), np.array(bases), np.array(tips)


# --- hand-computed cases --------------------------------------------------------------

def test_f_plus_f():
    tree = turtle("F+F")
    assert tree.parent.tolist() == [-1, 0]
    assert np.array_equal(tree.euler[0], [0.0, 0.0, 0.0])
    assert np.allclose(tree.euler[1], [0.0, D30, 0.0], atol=1e-15)
    _, bases, tips = rest_pose(tree)
    assert np.allclose(tips[0], [0, 0, 1], atol=1e-15)
    assert np.allclose(bases[1], [0, 0, 1], atol=1e-15)
    assert np.allclose(tips[1], [S30, 0, 1 + C30], atol=1e-15)
    assert np.array_equal(tree.offset, np.zeros((2, 3)))


def test_pitch_in_brackets_then_roll():
    tree = turtle("F[&F]/F")
    assert tree.parent.tolist() == [-1, 0, 0]
    # &(30) = Rx(30 deg) = Rz(-pi/2) Ry(30 deg) Rz(pi/2)
    assert np.allclose(tree.euler[1], [-math.pi / 2, D30, math.pi / 2], atol=1e-15)
    # /(90) after the pop: a pure roll, alpha exactly 0 and psi = 90 degrees
    assert tree.euler[2][0] == 0.0 and tree.euler[2][1] == 0.0
    assert tree.euler[2][2] == pytest.approx(math.pi / 2, abs=1e-15)
    frames, _, tips = rest_pose(tree)
    assert np.allclose(tips[1], [0, -S30, 1 + C30], atol=1e-15)   # tipped toward -y
    assert np.allclose(tips[2], [0, 0, 2], atol=1e-15)
    assert np.allclose(frames[2], rot_z(math.pi / 2), atol=1e-15)


def test_move_gives_offset_in_parent_frame():
    tree = turtle("f(0.5) F f(2) F +(90) f F")
    assert np.allclose(tree.offset[0], [0, 0, 0.5])       # root: from the origin, world
    assert np.allclose(tree.offset[1], [0, 0, 2])         # straight on
    # after +90 the move goes along the parent's local +x
    assert np.allclose(tree.offset[2], [1, 0, 0], atol=1e-15)
    assert np.allclose(tree.euler[2], [0, math.pi / 2, 0], atol=1e-15)
    _, bases, tips = rest_pose(tree)
    assert np.allclose(bases[1], [0, 0, 3.5])
    assert np.allclose(bases[2], [1, 0, 4.5], atol=1e-15)
    assert np.allclose(tips[2], [2, 0, 4.5], atol=1e-15)
    # the offset is in the parent's frame, not the world's
    tree = turtle("+(90) F f F")
    assert np.allclose(tree.offset[1], [0, 0, 1], atol=1e-15)
    _, bases, _ = rest_pose(tree)
    assert np.allclose(bases[1], [2, 0, 0], atol=1e-15)


def test_turn_around():
    tree = turtle("F|F")
    assert tree.euler[1].tolist() == [0.0, math.pi, 0.0]   # exactly, by the degenerate rule
    _, _, tips = rest_pose(tree)
    assert np.allclose(tips[1], [0, 0, 0], atol=1e-15)


def test_stalk():
    tree = turtle("FFFFFFFFL")
    assert tree.n_branches == 8 and tree.n_leaves == 1
    assert tree.parent.tolist() == [-1, 0, 1, 2, 3, 4, 5, 6]
    assert np.array_equal(tree.euler, np.zeros((8, 3)))
    assert np.array_equal(tree.offset, np.zeros((8, 3)))
    assert tree.leaf_branch.tolist() == [7]
    assert tree.leaf_normal.tolist() == [[1.0, 0.0, 0.0]]
    assert tree.address == [str(i) for i in range(8)] and tree.leaf_address == ["8"]
    assert tree.symbol == ["F"] * 8
    assert chain_depths(tree.parent).max() == 8


def test_leaf_normal_is_turtle_x_in_branch_frame():
    tree = turtle("F &(90) /(30) L")
    # x = Rx(90) Rz(30) e_x = (cos 30, 0, sin 30)
    assert np.allclose(tree.leaf_normal[0], [C30, 0, S30], atol=1e-15)
    tree = turtle("+(90) F /(30) L")        # in the branch's frame: Rz(30) e_x
    assert np.allclose(tree.leaf_normal[0], [C30, S30, 0], atol=1e-15)


def test_dollar_makes_x_horizontal():
    # After &(90) /(30): heading h = -y, x = (cos30, 0, sin30). $ rolls x to
    # (z x h)/|z x h| = +x and y = h x x = +z: the frame becomes Rx(90) again.
    tree = turtle("F &(90) /(30) $ L")
    assert np.allclose(tree.leaf_normal[0], [1, 0, 0], atol=1e-15)
    tree = turtle("&(90) /(30) $ F")
    assert np.allclose(matrix_from_zyz(*tree.euler[0]), rot_x(math.pi / 2), atol=1e-15)
    # The branch frame is tilted: a $ after it works in world terms.
    tree = turtle("&(90) /(30) F $ L")
    frames, _, _ = rest_pose(tree)
    normal_world = frames[0] @ tree.leaf_normal[0]
    assert np.allclose(normal_world, [1, 0, 0], atol=1e-15)
    # Vertical heading: $ leaves the turtle alone.
    tree = turtle("F /(30) $ L")
    assert np.allclose(tree.leaf_normal[0], [C30, S30, 0], atol=1e-15)


def test_nested_dollars_in_world_terms():
    # Every $ leaves x horizontal, whatever came before it.
    tree = turtle("F [ &(50) /(20) $ F /(70) +(20) $ L ] &(10) $ /(15) F [ ^(40) $ L ] $ L")
    frames, _, _ = rest_pose(tree)
    for j in range(tree.n_leaves):
        n_world = frames[tree.leaf_branch[j]] @ tree.leaf_normal[j]
        assert abs(n_world[2]) < 1e-15
        assert abs(np.linalg.norm(n_world) - 1) < 1e-15


def test_leaf_without_branch_is_dropped():
    with pytest.warns(UserWarning, match=r"2 leaf module\(s\).*dropped.*addresses 0, 4"):
        tree = turtle("L [F] L F L")
    assert tree.n_leaves == 1 and tree.leaf_branch.tolist() == [1]
    assert tree.leaf_address == ["6"]


def test_parents_and_brackets():
    text = "F [ + F [ - F ] F ] F [ G ] G"
    tree = turtle(text)
    #   modules: 0 F, 1 [, 2 +, 3 F, 4 [, 5 -, 6 F, 7 ], 8 F, 9 ], 10 F, 11 [, 12 G, 13 ], 14 G
    assert tree.address == ["0", "3", "6", "8", "10", "12", "14"]
    assert tree.parent.tolist() == [-1, 0, 1, 1, 0, 4, 4]
    assert tree.symbol == ["F", "F", "F", "F", "F", "G", "G"]
    # branch 2 turned back by - relative to branch 1: Ry(-30) = Rz(pi) Ry(30) Rz(-pi)
    assert tree.euler[2][1] == pytest.approx(D30, abs=1e-15)
    assert abs(abs(tree.euler[2][0]) - math.pi) < 1e-15
    assert tree.euler[3].tolist() == [0.0, 0.0, 0.0]
    assert tree.euler[4].tolist() == [0.0, 0.0, 0.0]


def test_radius_setting_is_scoped():
    with pytest.warns(UserWarning, match="'!' without a parameter"):    # the bare ! does nothing
        tree = turtle("F !(0.5) F [ !(0.2) F ! F ] F G")
    assert tree.radius.tolist() == [0.1, 0.5, 0.2, 0.2, 0.5, 0.5]


def test_symbol_and_header_values():
    tree = turtle("F G(2)")
    assert tree.length.tolist() == [1.0, 2.0]
    assert tree.bend_strength.tolist() == [20.0, 40.0]
    assert tree.rotation_strength.tolist() == [30.0, 50.0]
    assert tree.force_absorbed.tolist() == [0.01, 0.03]          # header, then G's own
    assert tree.force_propagated.tolist() == [0.7, 0.7]
    assert tree.drag_coefficient.tolist() == [0.002, 0.004]
    assert tree.source == "test.lsys"


def test_overrides_by_address():
    # One derivation step: axiom "A B" -> A: "F[+F(3)L]F", B: "G L".
    string = make_string("F [ + F(3) L ] F G L",
                         history=[([0, 0, 0, 0, 0, 0, 0, 1, 1], [0, 1, 2, 3, 4, 5, 6, 0, 1])])
    system = make_system(overrides=[
        ((0, 3), {"length": 2.5, "force_propagated": 0.49}),   # F(3): beats its parameter
        ((1, 0), {"drag_coefficient": 0.0031, "radius": 0.3}),  # G
        ((0, 4), {"area": 0.5}),                                  # the leaf L
    ])
    tree = build_tree(system, string)
    assert tree.address == ["0.0", "0.3", "0.6", "1.0"]
    assert tree.length.tolist() == [1.0, 2.5, 1.0, 0.5]
    assert tree.force_propagated.tolist() == [0.7, 0.49, 0.7, 0.7]
    assert tree.drag_coefficient.tolist() == [0.002, 0.002, 0.002, 0.0031]
    assert tree.radius.tolist() == [0.1, 0.1, 0.1, 0.3]
    assert tree.leaf_address == ["0.4", "1.1"]
    assert tree.leaf_area.tolist() == [0.5, 0.01]


def test_override_values_of_the_other_kind_of_module_warn():
    """A branch's key where only a leaf attaches, a leaf's area where only a branch is drawn:
    applied to nothing, they were dropped without a word (session 36, a helper's fuzzing)."""
    string = make_string("F [ + F(3) L ] F G L",
                         history=[([0, 0, 0, 0, 0, 0, 0, 1, 1], [0, 1, 2, 3, 4, 5, 6, 0, 1])])
    system = make_system(overrides=[((0, 4), {"length": 2.5}),     # the leaf L
                                    ((0, 3), {"area": 0.5}),       # F(3)
                                    ((1, 0), {"radius": 0.3})])    # G: applies
    with pytest.warns(UserWarning) as record:
        tree = build_tree(system, string)
    messages = sorted(str(w.message) for w in record)
    assert messages == [
        "override area for address 0.3 applies to nothing: no leaf attaches there, only a branch",
        "override length for address 0.4 applies to nothing: no branch is drawn there, only "
        "leaves"]
    assert tree.radius.tolist()[-1] == 0.3
    # several keys on one line: one warning naming them all (a gain matrix's six keys on a
    # leaf's address said six lines, a fuzzer, session 37)
    system = make_system(overrides=[((0, 4), {"length": 2.5, "radius": 0.2})])
    with pytest.warns(UserWarning) as record:
        build_tree(system, string)
    assert [str(w.message) for w in record] == [
        "override length, radius for address 0.4 applies to nothing: no branch is drawn "
        "there, only leaves"]


def test_override_matching_nothing_warns():
    system = make_system(overrides=[((5,), {"length": 2.0}), ((0, 1), {"length": 2.0})])
    with pytest.warns(UserWarning) as record:
        build_tree(system, make_string("F F"))
    messages = sorted(str(w.message) for w in record)
    assert messages == ["override for address 0.1 matches no branch or leaf module",
                        "override for address 5 matches no branch or leaf module"]


def test_repeated_address_gets_suffix():
    # Interpretation: the axiom "A B" became "F F L G"; F F L keep A's address 0.
    string = make_string("F F L G", origin=[0, 0, 0, 1])
    system = make_system(overrides=[((0,), {"length": 3.0})])
    tree = build_tree(system, string)
    assert tree.address == ["0", "0:1", "1"]
    assert tree.leaf_address == ["0"]
    assert tree.length.tolist() == [3.0, 3.0, 0.5]    # an override covers every repeat


def test_parameters_in_degrees_and_defaults():
    a = turtle("F +(45) F", make_system(branching=10))
    b = turtle("F + F", make_system(branching=45))
    assert np.array_equal(a.euler, b.euler)
    assert a.euler[1][1] == pytest.approx(math.pi / 4, abs=1e-15)
    c = turtle("F \\ F", make_system(rotation=20))
    assert c.euler[1][2] == pytest.approx(-math.radians(20), abs=1e-15)


def test_empty_and_branchless_strings():
    tree = turtle("A + f [ ]")
    assert tree.n_branches == 0 and tree.n_leaves == 0
    tree = build_tree(make_system(), make_string(""))
    assert tree.n_branches == 0


def test_unbalanced_close_bracket_is_an_input_error():
    with pytest.raises(InputError, match=r"'\]' at address 3 closes no '\['") as err:
        turtle("F [ ] ] F")
    assert err.value.file == "test.lsys"


def test_non_finite_parameter_is_an_input_error():
    with pytest.raises(InputError, match=r"F\(inf\) at address 1 has a non-finite parameter"):
        turtle("F F(inf)")


def _joined_addresses(string, idx):
    """The literal definition: join the rows of address_array with dots."""
    return [".".join(map(str, row)) for row in string.address_array(idx).tolist()]


def test_fast_address_strings_match_derived():
    rng = np.random.default_rng(7)
    sizes = [3]
    history = []
    for _ in range(4):                              # four random rewriting steps
        counts = rng.integers(0, 4, sizes[-1])
        parent = np.repeat(np.arange(sizes[-1]), counts)
        local = np.concatenate([np.arange(c) for c in counts])
        history.append((parent, local))
        sizes.append(len(parent))
    string = make_string("A" * sizes[-1], history=history)
    idx = np.sort(rng.choice(sizes[-1], size=sizes[-1] // 2, replace=False))
    assert string.address_strings(idx) == _joined_addresses(string, idx)
    shuffled = rng.permutation(idx)
    assert string.address_strings(shuffled) == _joined_addresses(string, shuffled)


# --- against the reference turtle -----------------------------------------------------------

def compare_with_reference(system, string, tol=1e-12):
    addresses = string.address_strings(np.arange(len(string)))
    modules = [(string.alphabet[c], tuple(string.module_params(i).tolist()), addresses[i])
               for i, c in enumerate(string.codes.tolist())]
    ref = tree_from_reference(reference_turtle(system, modules),
                              system.leaf_force_scale, system.source)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = build_tree(system, string)
    assert got.address == ref.address and got.symbol == ref.symbol
    assert got.leaf_address == ref.leaf_address
    assert np.array_equal(got.parent, ref.parent)
    assert np.array_equal(got.leaf_branch, ref.leaf_branch)
    for name in ("length", "radius", "bend_strength", "rotation_strength", "force_absorbed",
                 "force_propagated", "drag_coefficient", "leaf_area"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    for name in ("offset", "leaf_normal"):
        assert np.abs(getattr(got, name) - getattr(ref, name)).max(initial=0) <= tol, name
    # alpha directly; phi and psi modulo 2 pi where they are well defined
    assert np.abs(got.euler[:, 1] - ref.euler[:, 1]).max(initial=0) <= tol
    regular = np.sin(ref.euler[:, 1]) > 1e-6
    diff = (got.euler - ref.euler + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(diff[regular]).max(initial=0) <= tol
    rot_got = matrix_from_zyz(got.euler[:, 0], got.euler[:, 1], got.euler[:, 2])
    rot_ref = matrix_from_zyz(ref.euler[:, 0], ref.euler[:, 1], ref.euler[:, 2])
    assert np.abs(rot_got - rot_ref).max(initial=0) <= tol
    return got


EXAMPLES = sorted(glob.glob(str(__import__("pathlib").Path(__file__).parent.parent
                                / "examples" / "*.lsys")))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.rsplit("/", 1)[-1])
def test_examples_match_reference(path):
    from plantlod.lsys.derive import derive, interpret
    from plantlod.lsys.parse import parse_lsys

    with open(path, encoding="utf-8") as fh:
        system = parse_lsys(fh.read(), path)
    steps = min(system.derivation_length, 4)
    tree = compare_with_reference(system, interpret(system, derive(system, steps)))
    assert tree.n_branches > 0


SYMBOLS = "FFFGLL+-&^/\\|$f!A[]"
TURN_HEAVY = "F+-&^/\\|$$fffAAAAA[]" + "+-&^/\\" * 6      # long runs between branches


def random_string(rng, n, symbols=SYMBOLS):
    """Random balanced text over every turtle symbol, parameters sometimes given."""
    out, depth = [], 0
    for _ in range(n):
        ch = symbols[rng.integers(len(symbols))]
        if ch == "]" and depth == 0:
            ch = "["
        depth += {"[": 1, "]": -1}.get(ch, 0)
        if ch in "+-&^/\\" and rng.random() < 0.5:
            ch += f"({rng.uniform(-200, 200)!r})"
        elif ch in "FGfL!" and rng.random() < 0.5:
            ch += f"({rng.uniform(0.01, 2.0)!r})"
        out.append(ch)
    return "".join(out) + "]" * depth


@pytest.mark.parametrize("seed,size,symbols",
                         [(seed, 120, SYMBOLS) for seed in range(40)]
                         + [(seed, 3000, SYMBOLS) for seed in range(100, 102)]
                         + [(seed, 3000, TURN_HEAVY) for seed in range(200, 203)])
def test_random_strings_match_reference(seed, size, symbols):
    rng = np.random.default_rng(seed)
    text = random_string(rng, int(rng.integers(1, size)), symbols)
    n = len(re.findall(r"[^\s(](?:\([^)]*\))?", text))
    # one fake derivation step: the axiom's modules produced runs of the string
    cuts = np.sort(rng.choice(np.arange(1, n), size=min(n - 1, 5), replace=False)) if n > 1 else []
    parent = np.zeros(n, dtype=np.int64)
    for c in cuts:
        parent[c:] += 1
    local = np.arange(n) - np.searchsorted(parent, parent)
    origin = None
    if seed % 3 == 0:       # interpretation: consecutive modules share an origin
        origin = np.minimum(np.arange(n) // 2 * 2, n - 1)
    string = make_string(text, history=[(parent, local)], origin=origin)
    addresses = string.address_array(np.arange(n))
    picks = rng.choice(n, size=min(n, 4), replace=False)
    overrides = [(tuple(addresses[i]), {"length": 1.5, "radius": 0.07, "area": 0.2})
                 for i in picks]
    system = make_system(branching=float(rng.uniform(5, 60)), rotation=float(rng.uniform(5, 120)),
                         overrides=overrides)
    compare_with_reference(system, string)


def test_deep_dollar_chain_matches_reference():
    text = "".join(f"F(0.1)&({7 + i % 5})/({11 * i % 37})$" for i in range(300)) + "L"
    compare_with_reference(make_system(), make_string(text))
