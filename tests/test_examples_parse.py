"""The bundled example trees in examples/: they parse, say what their comments say,
and meet the design conditions of examples/README.md.

Every expected value here is computed independently of plantlod: header values
from the rules stated in each file's comments (e.g. force_propagated = 0.25^seg),
branch and leaf counts from closed forms or recurrences of the productions, the
sway period by running the semi-implicit Euler scheme of model.md section 4 by
hand, and the static bend at 20 m/s by a literal loop over the built tree.
"""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parent.parent / "examples"

DT = 0.01          # s, the time step the stability and period conditions are for
WIND = 20.0        # m/s, the wind speed of the static-bend condition


def _node_rewriting_counts(n: int, f_per_x: int, x_per_x: int) -> tuple[int, int]:
    """Branches (F) and apices (X) after n steps of X -> (f_per_x F, x_per_x X), F -> FF."""
    f, x = 0, 1
    for _ in range(n):
        f, x = 2 * f + f_per_x * x, x_per_x * x
    return f, x


def _bush_counts(n: int) -> tuple[int, int]:
    """F and L after n steps of ABOP 1.25: A -> 3x [&FL!A], F -> S/////F, S -> FL."""
    a, f, s, leaf = 1, 0, 0, 0
    for _ in range(n):
        a, f, s, leaf = 3 * a, f + s + 3 * a, f, leaf + s + 3 * a
    return f, leaf


_D_BRANCHES, _D_LEAVES = _node_rewriting_counts(7, 2, 3)
_F_BRANCHES, _F_LEAVES = _node_rewriting_counts(5, 3, 4)
_BUSH_BRANCHES, _BUSH_LEAVES = _bush_counts(7)


def _per_metre(seg: float, kfa_per_metre: float) -> dict:
    """Header forces of the Figure 1.24 and 1.25 files: per-metre rules of their comments."""
    return {"force_absorbed": kfa_per_metre * seg, "force_propagated": 0.25 ** seg}


# file -> expected header values, symbols and counts. rotation_angle defaults to
# branching_angle; drag_coefficient to 0.0015, leaf_force_scale to 1, seed to 0.
EXPECTED = {
    "stalk8.lsys": dict(
        derivation_length=3, branching_angle=30.0, rotation_angle=90.0,
        force_absorbed=0.005, force_propagated=0.7,
        branches={"F": (1.0, 0.02, 20.0, 20.0)}, leaves={"L": 0.01},
        n_branches=2 ** 3, n_leaves=1, height=8.0),
    "abop_1_24a.lsys": dict(
        derivation_length=5, branching_angle=25.7, **_per_metre(0.016, 0.0005),
        branches={"F": (0.016, 0.01, 40.0, 40.0)}, leaves={"L": 0.002},
        # F -> 5 F, 2 new leaves per rewritten F, plus the axiom's leaf.
        n_branches=5 ** 5, n_leaves=1 + 2 * sum(5 ** k for k in range(5)),
        height=3 ** 5 * 0.016),   # the main axis: 3 F in line per step, straight up
    "abop_1_24b.lsys": dict(
        derivation_length=5, branching_angle=20.0, **_per_metre(0.06, 0.0005),
        branches={"F": (0.06, 0.01, 40.0, 40.0)}, leaves={"L": 0.002},
        n_branches=5 ** 5, n_leaves=3 * 5 ** 4),   # leaves of the last step only
    "abop_1_24c.lsys": dict(
        derivation_length=4, branching_angle=22.5, **_per_metre(0.07, 0.0015),
        branches={"F": (0.07, 0.01, 40.0, 40.0)}, leaves={"L": 0.002},
        n_branches=8 ** 4, n_leaves=2 * 8 ** 3),
    "abop_1_24d.lsys": dict(
        derivation_length=7, branching_angle=20.0, **_per_metre(0.016, 0.001),
        branches={"F": (0.016, 0.01, 40.0, 40.0)}, leaves={"L": 0.002},
        n_branches=_D_BRANCHES, n_leaves=_D_LEAVES),
    "abop_1_24e.lsys": dict(
        derivation_length=7, branching_angle=25.7, **_per_metre(0.016, 0.0007),
        branches={"F": (0.016, 0.01, 40.0, 40.0)}, leaves={"L": 0.002},
        n_branches=_D_BRANCHES, n_leaves=_D_LEAVES),
    "abop_1_24f.lsys": dict(
        derivation_length=5, branching_angle=22.5, **_per_metre(0.05, 0.0015),
        branches={"F": (0.05, 0.01, 40.0, 40.0)}, leaves={"L": 0.002},
        n_branches=_F_BRANCHES, n_leaves=_F_LEAVES),
    "abop_1_25.lsys": dict(
        derivation_length=7, branching_angle=22.5, rotation_angle=22.5,
        **_per_metre(0.06, 0.004),
        branches={"F": (0.06, 0.008, 60.0, 60.0)}, leaves={"L": 0.001},
        n_branches=_BUSH_BRANCHES, n_leaves=_BUSH_LEAVES),
    "abop_2_6.lsys": dict(
        derivation_length=10, branching_angle=45.0, force_absorbed=0.0008, force_propagated=0.7,
        branches={"F": (1.0, 0.01, 30.0, 30.0)}, leaves={"L": 0.005},
        defines={"r1": 0.9, "r2": 0.6, "a0": 45.0, "a2": 45.0, "d": 137.5, "wr": 0.707},
        n_branches=2 ** 10 - 1, n_leaves=2 ** 10,   # every apex splits in two per step
        height=0.6 * (1 - 0.9 ** 10) / (1 - 0.9)),  # the straight trunk
    "abop_2_7.lsys": dict(
        derivation_length=6, branching_angle=18.95, force_absorbed=0.0012, force_propagated=0.7,
        branches={"F": (1.0, 0.01, 50.0, 50.0)}, leaves={"L": 0.01},
        defines={"d1": 94.74, "d2": 132.63, "a": 18.95, "lr": 1.109, "vr": 1.732},
        # the trunk, then 4 F per rewritten apex; 3 apices per apex.
        n_branches=1 + 4 * sum(3 ** k for k in range(6)), n_leaves=3 ** 6),
}

NAMES = sorted(EXPECTED)


def _parse(name: str):
    from plantlod.lsys.parse import parse_lsys

    path = EXAMPLES / name
    return parse_lsys(path.read_text(encoding="utf-8"), str(path))


_BUILT: dict[str, object] = {}


def _tree(name: str):
    """The built tree of an example (cached: the larger ones take a moment)."""
    build = pytest.importorskip("plantlod.lsys.build").build
    if name not in _BUILT:
        _BUILT[name] = build(_parse(name)).tree
    return _BUILT[name]


def test_the_examples_are_exactly_the_listed_ones():
    assert sorted(p.name for p in EXAMPLES.glob("*.lsys")) == NAMES


@pytest.mark.parametrize("name", NAMES)
def test_example_parses_with_header_as_written(name):
    exp = EXPECTED[name]
    system = _parse(name)
    assert system.name == name.removesuffix(".lsys")
    assert system.derivation_length == exp["derivation_length"]
    assert system.branching_angle == pytest.approx(exp["branching_angle"], rel=1e-12)
    assert system.rotation_angle == pytest.approx(
        exp.get("rotation_angle", exp["branching_angle"]), rel=1e-12)
    assert system.force_absorbed == pytest.approx(exp["force_absorbed"], rel=1e-12)
    assert system.force_propagated == pytest.approx(exp["force_propagated"], rel=1e-12)
    assert system.drag_coefficient == pytest.approx(0.0015, rel=1e-12)
    assert system.leaf_force_scale == 1.0
    assert system.seed == 0
    defines = dict(system.defines)
    for key, value in exp.get("defines", {}).items():
        assert defines[key] == pytest.approx(value, rel=1e-12), key


@pytest.mark.parametrize("name", NAMES)
def test_example_declares_its_branch_and_leaf_symbols(name):
    exp = EXPECTED[name]
    system = _parse(name)
    assert len(system.branches) >= 1 and len(system.leaves) >= 1
    assert {b.name for b in system.branches} == set(exp["branches"])
    assert {leaf.name for leaf in system.leaves} == set(exp["leaves"])
    for sym, (length, radius, k_bs, k_rs) in exp["branches"].items():
        b = system.branch_symbol(sym)
        assert (b.length, b.radius, b.bend_strength, b.rotation_strength) == pytest.approx(
            (length, radius, k_bs, k_rs), rel=1e-12)
    for sym, area in exp["leaves"].items():
        assert system.leaf_symbol(sym).area == pytest.approx(area, rel=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_example_is_stable_at_dt_001(name):
    """model.md section 4: s = k dt / 1000 < 4 for every bend and rotation strength."""
    for b in _parse(name).branches:
        for k in (b.bend_strength, b.rotation_strength):
            assert k > 0
            assert k * DT / 1000 < 4, f"{name}: {b.name} strength {k}"


def _scheme_period(k: float, dt: float, steps: int) -> float:
    """Period of one free branch under the model's scheme, by running it literally.

    v <- v - theta k / 1000; theta <- theta + v dt, from theta = 1, v = 0; the
    period is the mean spacing of the upward zero crossings (linear interpolation).
    """
    theta, v = 1.0, 0.0
    crossings = []
    for i in range(1, steps + 1):
        v -= theta * k / 1000
        new = theta + v * dt
        if theta < 0 <= new:
            crossings.append((i - 1 + (-theta) / (new - theta)) * dt)
        theta = new
    assert len(crossings) >= 3
    return (crossings[-1] - crossings[0]) / (len(crossings) - 1)


@pytest.mark.parametrize("name", NAMES)
def test_example_sways_with_a_period_of_a_few_seconds(name):
    for b in _parse(name).branches:
        for k in (b.bend_strength, b.rotation_strength):
            closed_form = 2 * math.pi * DT / math.acos(1 - k * DT / 1000 / 2)
            measured = _scheme_period(k, DT, steps=3000)
            assert measured == pytest.approx(closed_form, rel=1e-3)
            assert 2.0 <= measured <= 6.0, f"{name}: {b.name} period {measured:.2f} s"


def test_derived_stalk_has_eight_branches_and_one_leaf():
    derive = pytest.importorskip("plantlod.lsys.derive").derive
    derived = derive(_parse("stalk8.lsys"))
    names = [derived.alphabet[c] for c in derived.codes]
    assert names.count("F") == 8
    assert names.count("L") == 1
    assert len(names) == 9


@pytest.mark.parametrize("name", NAMES)
def test_example_tree_has_the_expected_branch_and_leaf_counts(name):
    tree = _tree(name)
    assert tree.n_branches == EXPECTED[name]["n_branches"]
    assert tree.n_leaves == EXPECTED[name]["n_leaves"]


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rest_height(tree) -> float:
    """Largest tip z at rest: R_i = R_parent Rz(phi) Ry(alpha) Rz(psi), tip = base + L R e_z."""
    frames, tips = [], []
    for i in range(tree.n_branches):
        p = int(tree.parent[i])
        r_parent = frames[p] if p >= 0 else np.eye(3)
        base = (tips[p] if p >= 0 else np.zeros(3)) + r_parent @ tree.offset[i]
        phi, alpha, psi = tree.euler[i]
        r = r_parent @ _rz(phi) @ _ry(alpha) @ _rz(psi)
        frames.append(r)
        tips.append(base + tree.length[i] * r[:, 2])
    return max(t[2] for t in tips)


@pytest.mark.parametrize("name", NAMES)
def test_example_tree_is_a_few_metres_tall(name):
    height = _rest_height(_tree(name))
    if "height" in EXPECTED[name]:
        assert height == pytest.approx(EXPECTED[name]["height"], rel=1e-9)
    if name != "stalk8.lsys":
        assert 1.5 <= height <= 5.0, f"{name}: {height:.2f} m"


def _static_bend_bound(tree, v: float) -> float:
    """Upper bound of the whole tree's static bend (rad) in a wind of speed v (m/s).

    Every force is taken perpendicular to its branch: leaf force s_L A v, drag
    C_d v^2 2 pi r L; F_i = d_i + k_fp,i (leaf forces on i + sum of the children's
    F); equilibrium angle 1000 k_FA,i F_i / k_bs,i (model.md section 4), summed
    along each root-to-tip path; the largest sum.
    """
    b = tree.n_branches
    leaf_sum = [0.0] * b
    for j in range(tree.n_leaves):
        leaf_sum[int(tree.leaf_branch[j])] += tree.leaf_force_scale * float(tree.leaf_area[j]) * v
    force = [float(tree.drag_coefficient[i]) * v * v * 2 * math.pi
             * float(tree.radius[i]) * float(tree.length[i]) for i in range(b)]
    child_sum = [0.0] * b
    for i in range(b - 1, -1, -1):          # children come after their parent
        force[i] += float(tree.force_propagated[i]) * (leaf_sum[i] + child_sum[i])
        p = int(tree.parent[i])
        if p >= 0:
            child_sum[p] += force[i]
    bend = [0.0] * b
    for i in range(b):
        p = int(tree.parent[i])
        own = 1000 * float(tree.force_absorbed[i]) * force[i] / float(tree.bend_strength[i])
        bend[i] = own + (bend[p] if p >= 0 else 0.0)
    return max(bend)


@pytest.mark.parametrize("name", NAMES)
def test_example_bends_well_under_one_radian_at_20_m_per_s(name):
    bound = _static_bend_bound(_tree(name), WIND)
    assert 0.05 < bound < 0.5, f"{name}: {bound:.3f} rad"


def test_static_bend_bound_of_the_stalk_matches_the_hand_computation():
    """stalk8.lsys's comment: forces 0.215 N at the top, F_i = 0.075 + 0.7 F_(i+1)."""
    drag = 0.0015 * 400 * 2 * math.pi * 0.02 * 1
    f, total = drag + 0.7 * 0.2, 0.0
    for _ in range(8):
        total += f
        f = drag + 0.7 * f
    expected = 1000 * 0.005 * total / 20
    assert _static_bend_bound(_tree("stalk8.lsys"), WIND) == pytest.approx(expected, rel=1e-12)
    assert expected == pytest.approx(0.47, abs=0.005)
