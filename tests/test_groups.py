"""Level-of-detail groups, main paths, combined angles and group tips (model.md section 5).

Every expected value is worked out by hand from the model's definitions, or
computed by an independent literal implementation of section 3 written here
with scipy's Rotation (not plantlod's rotation code).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree
from plantlod.compare.groups import (
    assign_groups, combined_angles, group_tips, main_paths, parse_address, path_rotations,
)


def make_tree(addresses, parent, euler=None) -> Tree:
    """A hand-made tree: unit lengths, default strengths, no leaves."""
    b = len(addresses)
    ones = np.ones(b)
    tree = Tree(
        address=list(addresses), symbol=["F"] * b, parent=np.asarray(parent, dtype=np.int64),
        length=ones.copy(), radius=0.02 * ones, bend_strength=20 * ones, rotation_strength=20 * ones,
        force_absorbed=0.005 * ones, force_propagated=0.7 * ones, drag_coefficient=0.0015 * ones,
        euler=np.zeros((b, 3)) if euler is None else np.asarray(euler, dtype=np.float64),
        offset=np.zeros((b, 3)),
        leaf_branch=np.zeros(0, np.int64), leaf_area=np.zeros(0), leaf_normal=np.zeros((0, 3)),
        leaf_address=[],
    )
    tree.check()
    return tree


def chain(addresses, euler=None) -> Tree:
    """Branches each hanging from the one before."""
    return make_tree(addresses, [i - 1 for i in range(len(addresses))], euler)


# The thesis stalk: axiom `F L`, F -> F F, N = 3. F at step k has address 0.a1….ak with
# every aj in {0, 1}; the turtle draws them in binary order, each on top of the last.
STALK8 = [f"0.{a}.{b}.{c}" for a in (0, 1) for b in (0, 1) for c in (0, 1)]
STALK4 = [f"0.{a}.{b}" for a in (0, 1) for b in (0, 1)]
STALK2 = ["0.0", "0.1"]


# --- addresses --------------------------------------------------------------------

def test_parse_address():
    assert parse_address("0.1.10") == ((0, 1, 10), 0)
    assert parse_address("3:2") == ((3,), 2)
    assert parse_address("1.9") < parse_address("1.10")          # integers, not text
    assert parse_address("0.1") < parse_address("0.1:1") < parse_address("0.2")
    for bad in ("", "0..1", "a.1", "0.1:", "0.1:0", "-1.2", "0.1:x"):
        with pytest.raises(InputError):
            parse_address(bad)


# --- the stalk --------------------------------------------------------------------

@pytest.mark.parametrize("simplified, expected", [
    (STALK4, [0, 0, 1, 1, 2, 2, 3, 3]),       # level 1: pairs
    (STALK2, [0, 0, 0, 0, 1, 1, 1, 1]),       # level 2: quadruples
    (["0"], [0] * 8),                         # level 3: the axiom's F alone
    (STALK8, list(range(8))),                 # level 0: itself
])
def test_stalk_groups_and_paths(simplified, expected):
    original = chain(STALK8)
    groups = assign_groups(original, chain(simplified))
    assert groups.dtype == np.int64
    assert groups.tolist() == expected
    paths = main_paths(original, groups)
    # each group is a run of consecutive branches of the stalk, bottom to top
    want = [[i for i, g in enumerate(expected) if g == s] for s in range(len(simplified))]
    assert [p.tolist() for p in paths] == want


def test_stalk_combined_angles_are_plain_sums():
    original = chain(STALK8)
    paths = main_paths(original, assign_groups(original, chain(STALK4)))
    rng = np.random.default_rng(1)
    bend, rot = rng.normal(size=(5, 8)), rng.normal(size=(5, 8))
    tb, tr = combined_angles(original, paths, bend, rot)
    assert tb.shape == tr.shape == (5, 4)
    np.testing.assert_allclose(tb, bend[:, 0::2] + bend[:, 1::2], rtol=0, atol=1e-14)
    np.testing.assert_allclose(tr, rot[:, 0::2] + rot[:, 1::2], rtol=0, atol=1e-14)
    # one sample (B,) gives (G,)
    tb1, tr1 = combined_angles(original, paths, bend[2], rot[2])
    np.testing.assert_allclose(tb1, bend[2, 0::2] + bend[2, 1::2], rtol=0, atol=1e-14)
    np.testing.assert_allclose(tr1, rot[2, 0::2] + rot[2, 1::2], rtol=0, atol=1e-14)


def test_stalk_group_tips_are_the_top_of_each_pair():
    original = chain(STALK8)
    paths = main_paths(original, assign_groups(original, chain(STALK4)))
    tips = np.arange(4 * 8 * 3, dtype=float).reshape(4, 8, 3)
    np.testing.assert_array_equal(group_tips(paths, tips), tips[:, [1, 3, 5, 7], :])
    np.testing.assert_array_equal(group_tips(paths, tips[0]), tips[0, [1, 3, 5, 7], :])


def test_combined_angles_do_not_depend_on_the_thread_count():
    """The kernel (`compare.combined_kernel`) shares samples out between threads; each
    group's sum is one thread's, so any count gives the same bits (and an empty group 0)."""
    import numba

    original = chain(STALK8, np.random.default_rng(3).uniform(0, 3, size=(8, 3)))
    paths = main_paths(original, assign_groups(original, chain(STALK4)), n_groups=5)
    assert paths[4].tolist() == []                     # an empty group: combined angles 0
    rng = np.random.default_rng(4)
    bend, rot = rng.normal(size=(37, 8)), rng.normal(size=(37, 8))
    results = []
    saved = numba.get_num_threads()
    try:
        for threads in sorted({1, saved}):
            numba.set_num_threads(threads)
            results.append(combined_angles(original, paths, bend, rot))
    finally:
        numba.set_num_threads(saved)
    for tb, tr in results[1:]:
        assert tb.tobytes() == results[0][0].tobytes() and tr.tobytes() == results[0][1].tobytes()
    assert not results[0][0][:, 4].any() and not results[0][1][:, 4].any()


def test_float32_runs_give_the_combined_angles_of_their_float64_copies():
    """The original's runs are kept in float32 (`evaluate.Runs`) and read without a float64
    copy: a float32 angle widens exactly before its product, so the bits are the same."""
    original = chain(STALK8, np.random.default_rng(5).uniform(0, 3, size=(8, 3)))
    paths = main_paths(original, assign_groups(original, chain(STALK4)), n_groups=5)
    rng = np.random.default_rng(6)
    bend, rot = (rng.normal(size=(37, 8)).astype(np.float32) for _ in range(2))
    narrow = combined_angles(original, paths, bend, rot)
    wide = combined_angles(original, paths, bend.astype(np.float64), rot.astype(np.float64))
    assert narrow[0].dtype == np.float64
    assert np.array_equal(narrow[0], wide[0]) and np.array_equal(narrow[1], wide[1])


# --- a branching tree with an apex that draws nothing ---------------------------------

def branching_pair():
    """Original at step 2 and its level-1 simplification (step 1).

    Step 1 is F(0.0) F(0.1) A(0.2) F(0.3) with A drawing nothing; in the original
    A has grown branches 0.2.0 and 0.2.1, hanging from 0.0.1 (the turtle's branch
    when A is read). An apex's subtree must join the group of the branch it hangs
    from.
    """
    #            index: 0        1        2        3        4        5        6
    addresses = ["0.0.0", "0.0.1", "0.1.0", "0.1.1", "0.2.0", "0.2.1", "0.3.0"]
    parent = [-1, 0, 1, 2, 1, 4, 1]
    euler = np.zeros((7, 3))
    euler[2, 1] = 0.5
    euler[4, 1] = 0.3
    original = make_tree(addresses, parent, euler)
    simplified = make_tree(["0.0", "0.1", "0.3"], [-1, 0, 0])
    return original, simplified


def test_apex_subtree_joins_the_group_it_hangs_from():
    original, simplified = branching_pair()
    groups = assign_groups(original, simplified)
    assert groups.tolist() == [0, 0, 1, 1, 0, 0, 2]
    paths = main_paths(original, groups)
    # group 0 = {0, 1, 4, 5}: 0 -> 1 -> (its only child in the group) 4 -> 5
    assert [p.tolist() for p in paths] == [[0, 1, 4, 5], [2, 3], [6]]


def test_ungrouped_root_gets_minus_one_and_no_path():
    # Axiom `A F`, A -> F, N = 1; level 1 is the axiom itself, where A draws nothing.
    original = make_tree(["0.0", "1.0", "0.0:1"], [-1, -1, 0])
    simplified = make_tree(["1"], [-1])
    groups = assign_groups(original, simplified)
    assert groups.tolist() == [-1, 0, -1]
    assert [p.tolist() for p in main_paths(original, groups)] == [[1]]


# --- main path choices: ties in alpha, integer address order, several roots ----------

def test_main_path_ties_within_tolerance_go_to_lowest_integer_address():
    # root 1.0 with children 1.10 and 1.9 (both in group "1"); 1.10 has the smaller
    # alpha but only by 5e-10 < 1e-9: tied, and 1.9 < 1.10 as integers.
    addresses = ["1.0", "1.10", "1.9"]
    euler = [[0, 0, 0], [0, 0.2, 0], [0, 0.2 + 5e-10, 0]]
    original = make_tree(addresses, [-1, 0, 0], euler)
    paths = main_paths(original, assign_groups(original, make_tree(["1"], [-1])))
    assert paths[0].tolist() == [0, 2]
    # beyond the tolerance the smaller alpha wins, whatever its address
    euler[2][1] = 0.2 + 2e-9
    original = make_tree(addresses, [-1, 0, 0], euler)
    paths = main_paths(original, assign_groups(original, make_tree(["1"], [-1])))
    assert paths[0].tolist() == [0, 1]


def test_main_path_picks_among_several_roots():
    # group "0.1" has three members hanging from 0.0.0 (group "0.0"): roots.
    addresses = ["0.0.0", "0.1.2", "0.1.10", "0.1.9", "0.1.11"]
    parent = [-1, 0, 0, 0, 2]
    euler = [[0, 0, 0], [0, 0.7, 0], [0, 0.4, 0], [0, 0.4, 0], [0, 0.1, 0]]
    original = make_tree(addresses, parent, euler)
    simplified = make_tree(["0.0", "0.1"], [-1, 0])
    groups = assign_groups(original, simplified)
    assert groups.tolist() == [0, 1, 1, 1, 1]
    # 0.1.10 and 0.1.9 tie at alpha 0.4 (0.1.2's 0.7 is larger): 0.1.9 < 0.1.10,
    # and 0.1.9 has no child, so the path stops there
    assert main_paths(original, groups)[1].tolist() == [3]


def test_suffix_is_identity_not_prefix():
    # Level 0 with interpretation drawing two branches under 0.1: kept apart.
    addresses = ["0.0", "0.1", "0.1:1"]
    original = chain(addresses)
    assert assign_groups(original, chain(addresses)).tolist() == [0, 1, 2]
    # A suffixed original branch is grouped by its base address.
    original = chain(["0.0.0", "0.1.0", "0.1.0:1"])
    assert assign_groups(original, chain(["0.0", "0.1"])).tolist() == [0, 1, 1]
    # A simplified ':1' branch that no original address matches stands for nothing.
    with pytest.raises(InputError, match="0.1:1"):
        assign_groups(original, chain(["0.0", "0.1", "0.1:1"]))


# --- trees that do not correspond ------------------------------------------------------

def test_mismatches_are_input_errors():
    original = chain(STALK8)
    with pytest.raises(InputError, match="share no addresses"):
        assign_groups(original, chain(["1.0", "1.1"]))           # another axiom
    with pytest.raises(InputError, match="stand for no branch"):
        assign_groups(original, chain(["0.0", "0.1", "0.2"]))    # 0.2 is not in the original
    with pytest.raises(InputError, match="more than the original"):
        assign_groups(chain(STALK2), original)                   # the wrong way round
    with pytest.raises(InputError, match="two branches with address"):
        assign_groups(original, chain(["0.0", "0.0"]))
    with pytest.raises(InputError, match="one length"):
        assign_groups(original, chain(["0.0", "0.1.0"]))
    with pytest.raises(InputError, match="no branches"):
        assign_groups(original, chain([]))


# --- combined angles in turned frames ----------------------------------------------------

DELTA = 0.5


def turned_chain() -> Tree:
    """A vertical root, then `-` F (turned: phi = pi, alpha = delta, psi = pi), then F straight on.

    The turtle's rotation after `-` is Ry(-delta) = Rz(pi) Ry(delta) Rz(pi) in
    model.md's ZYZ form (phi = atan2(0, -sin delta) = pi, psi = atan2(0, -sin delta) = pi).
    """
    euler = [[0, 0, 0], [np.pi, DELTA, np.pi], [0, 0, 0]]
    return chain(["0.0", "0.1", "0.2"], euler)


def test_turned_member_is_carried_into_the_root_frame_by_hand():
    # By hand: W_0 = I, W_1 = Rz(pi) Ry(d), W_2 = R_1 = Ry(-d).
    #   W_1 (-r1, b1, 0) = Rz(pi) (-r1 cos d, b1, r1 sin d) = (r1 cos d, -b1, r1 sin d)
    #   W_2 (-r2, b2, 0) = (-r2 cos d, b2, -r2 sin d)
    # so Theta_b = Omega_y = b0 - b1 + b2 and Theta_r = -Omega_x = r0 - r1 cos d + r2 cos d.
    tree = turned_chain()
    paths = [np.array([0, 1, 2])]
    b = np.array([[0.01, 0.02, 0.03], [-0.004, 0.001, 0.002]])
    r = np.array([[0.005, -0.01, 0.02], [0.003, 0.0, -0.001]])
    tb, tr = combined_angles(tree, paths, b, r)
    c = np.cos(DELTA)
    np.testing.assert_allclose(tb[:, 0], b[:, 0] - b[:, 1] + b[:, 2], rtol=0, atol=1e-15)
    np.testing.assert_allclose(tr[:, 0], r[:, 0] - c * r[:, 1] + c * r[:, 2], rtol=0, atol=1e-15)
    # the naive sum (what frames must not be ignored for) differs visibly
    assert abs(tb[0, 0] - b[0].sum()) > 0.03


def scipy_pose_frames(tree: Tree, bend: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Branch frames R_i (B, 3, 3) by model.md section 3, literally, with scipy rotations."""
    frames = np.empty((tree.n_branches, 3, 3))
    for i in range(tree.n_branches):
        phi, alpha, psi = tree.euler[i]
        rp = np.eye(3) if tree.parent[i] < 0 else frames[tree.parent[i]]
        swing = rp @ Rotation.from_euler("ZYZ", [phi, alpha, 0.0]).as_matrix()
        swing = swing @ Rotation.from_rotvec([-rot[i], bend[i], 0.0]).as_matrix()   # Rot(u, theta)
        frames[i] = swing @ Rotation.from_euler("z", psi).as_matrix()
    return frames


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_combined_angles_match_the_small_angle_rotation_of_the_tip(seed):
    """To first order the rotations of a chain add as world rotation vectors.

    So the rotation that carries the last branch's rest frame to its posed frame,
    R_posed R_rest^T, has the rotation vector W_0 Omega + O(theta^2); its effect
    on the group's tip direction is the tip's actual motion.
    """
    rng = np.random.default_rng(seed)
    m = 5
    euler = np.column_stack([rng.uniform(-np.pi, np.pi, m), rng.uniform(0, np.pi, m),
                             rng.uniform(-np.pi, np.pi, m)])
    euler[2] = [np.pi, DELTA, np.pi]                  # a `-` turn among them
    tree = chain([f"0.{j}" for j in range(m)], euler)
    eps = 1e-5
    bend, rot = eps * rng.normal(size=m), eps * rng.normal(size=m)
    tb, tr = combined_angles(tree, [np.arange(m)], bend, rot)

    rest = scipy_pose_frames(tree, np.zeros(m), np.zeros(m))
    posed = scipy_pose_frames(tree, bend, rot)
    world_rotvec = Rotation.from_matrix(posed[-1] @ rest[-1].T).as_rotvec()
    w0 = Rotation.from_euler("ZYZ", [euler[0, 0], euler[0, 1], 0.0]).as_matrix()   # root: R_parent = I
    omega = w0.T @ world_rotvec
    # first order in eps: the error is O(m^2 eps^2) ~ 1e-9, the signal ~ 1e-5
    np.testing.assert_allclose([tb[0], tr[0]], [omega[1], -omega[0]], rtol=0, atol=1e-8)

    tip_move = posed[-1][:, 2] - rest[-1][:, 2]
    predicted = np.cross(w0 @ np.array([-tr[0], tb[0], omega[2]]), rest[-1][:, 2])
    np.testing.assert_allclose(tip_move, predicted, rtol=0, atol=1e-8)


def test_path_rotations_match_world_frames():
    # W_0^T W_j from relative angles only equals the product of world rest frames.
    rng = np.random.default_rng(7)
    m = 4
    euler = np.column_stack([rng.uniform(-3, 3, m), rng.uniform(0, 3, m), rng.uniform(-3, 3, m)])
    tree = make_tree(["0.0", "0.1", "0.1.0", "0.2"], [-1, 0, 1, 2], euler)
    rest = scipy_pose_frames(tree, np.zeros(m), np.zeros(m))
    path = np.array([1, 2, 3])                    # a path that does not start at a root
    w = [rest[tree.parent[j]] @ Rotation.from_euler("ZYZ", [euler[j, 0], euler[j, 1], 0]).as_matrix()
         for j in path]
    want = np.stack([w[0].T @ wj for wj in w])
    np.testing.assert_allclose(path_rotations(tree, [path]), want, rtol=0, atol=1e-13)
    # several paths at once, of different lengths, concatenated in path order
    both = path_rotations(tree, [np.array([0]), path, np.array([2, 3])])
    np.testing.assert_allclose(both[1:4], want, rtol=0, atol=1e-13)
    np.testing.assert_allclose(both[0], np.eye(3), rtol=0, atol=0)
    np.testing.assert_allclose(both[4:], path_rotations(tree, [np.array([2, 3])]), rtol=0, atol=0)
