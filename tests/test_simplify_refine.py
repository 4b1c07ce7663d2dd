"""The global static refinement of closed_form (`refine.StaticModel`) against independent computations.

- its forward model against simplify/static.py run on the *written* level-n
  file (a different path: the tree built from the text, overrides resolved);
- its analytic Jacobian against central finite differences of its residual;
- the refinement against the sequential solution alone, and against the
  simulation run with damping to equilibrium (the static angles by definition).
"""

from __future__ import annotations

import numpy as np
import pytest

from plantlod.formats.lsys_file import read_lsys
from plantlod.simplify.constants import (FIT_ELEVATION, MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS,
                                     REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS)
from plantlod.lsys.tree import leaf_keys
from plantlod.simplify import refine as cf
from plantlod.simplify.targets import static_targets
from plantlod.simplify.closed_form import closed_form
from plantlod.simplify.static import fit_directions, static_angles, static_parts
from plantlod.sim.wind import wind_from_speed
from plantlod.compare.groups import combined_angles
from simplify_util import (assert_close_where_counted, level_case, settled, settled_combined,
                           small_case, written_tree)

SPEEDS = (0.5, 20.0)


def capture_model(monkeypatch):
    """Run closed_form and keep the StaticModel it builds and the x it starts from."""
    seen = {}
    original_refine = cf.StaticModel.refine

    def spy(self, kappa, p, c, area, *settings):
        seen["model"] = self
        seen["x"] = np.log(np.concatenate([kappa, p, c, area]))
        return original_refine(self, kappa, p, c, area, *settings)

    monkeypatch.setattr(cf.StaticModel, "refine", spy)
    return seen


def worst_static_error(original, gmap, tree, speed, d=None):
    """Largest relative error of the counted static combined angles (by default in the
    directions simplify matches: 16 horizontal, 8 azimuths tilted up and down)."""
    if d is None:
        d = fit_directions(MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS, FIT_ELEVATION)
    t = static_targets(original, gmap, d)
    target = speed * t.leaf + speed ** 2 * t.drag                      # (D, G, 2)
    parts = static_parts(tree, d)
    b, r = static_angles(tree, speed * parts.leaf + speed ** 2 * parts.drag)
    got = np.stack([b, r], axis=-1)
    largest = np.abs(target).max(axis=(1, 2), keepdims=True)
    counted = np.abs(target) >= 0.01 * largest
    return float(np.max(np.abs(got - target)[counted] / np.abs(target)[counted]))


def test_model_angles_equal_the_static_theory_of_the_written_file(monkeypatch):
    original, skeleton, skel_tree, gmap = small_case("abop_2_6", 5)
    seen = capture_model(monkeypatch)
    params = closed_form(original, skel_tree, gmap, refine=True, speeds=SPEEDS)
    model = seen["model"]
    # the refined parameters, as the model sees them ...
    x = np.log(np.concatenate([params.branch["force_absorbed"], params.branch["force_propagated"],
                               params.branch["drag_coefficient"] * 2 * np.pi * skel_tree.radius
                               * params.branch["length"],
                               np.maximum([params.leaf_areas[a] for a in
                                           leaf_keys(skel_tree)], 1e-300)]))
    theta, _, _ = model.angles(x)                                     # (S, D, G, 2)
    # ... and the written file through static.py (the refinement's directions)
    tree = written_tree(skeleton, params)
    d = fit_directions(REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS, FIT_ELEVATION)
    parts = static_parts(tree, d)
    for s, v in enumerate(SPEEDS):
        b, r = static_angles(tree, v * parts.leaf + v * v * parts.drag)
        ref = np.stack([b, r], axis=-1)
        scale = np.abs(ref).max()
        np.testing.assert_allclose(theta[s], ref, rtol=1e-9, atol=1e-9 * scale)


def test_jacobian_matches_finite_differences(monkeypatch):
    original, skeleton, skel_tree, gmap = small_case("abop_2_6", 4)
    seen = capture_model(monkeypatch)
    closed_form(original, skel_tree, gmap, refine=True, speeds=SPEEDS)
    model = seen["model"]
    rng = np.random.default_rng(3)
    x = seen["x"] + rng.uniform(-0.3, 0.3, size=seen["x"].shape)
    op = model.jacobian(x)
    jac = op @ np.eye(len(x))
    # the transpose product is the adjoint of the forward one
    u = rng.normal(size=op.shape[0])
    np.testing.assert_allclose(op.rmatvec(u), jac.T @ u, rtol=1e-9, atol=1e-12 * np.abs(jac.T @ u).max())
    h = 1e-6
    for col in range(len(x)):
        e = np.zeros_like(x)
        e[col] = h
        fd = (model.residual(x + e) - model.residual(x - e)) / (2 * h)
        np.testing.assert_allclose(jac[:, col], fd, rtol=1e-5, atol=1e-6 * max(1.0, np.abs(fd).max()))


@pytest.mark.parametrize("name, steps", [("abop_2_6", 5), ("abop_1_24c", 3)])
def test_refinement_lowers_the_worst_static_error(name, steps):
    original, skeleton, skel_tree, gmap = small_case(name, steps)
    before = written_tree(skeleton, closed_form(original, skel_tree, gmap, refine=False))
    after = written_tree(skeleton, closed_form(original, skel_tree, gmap, refine=True))
    # the refinement's own directions, where its acceptance rule applies
    d = fit_directions(REFINE_DIRECTIONS, REFINE_TILTED_DIRECTIONS, FIT_ELEVATION)
    e0 = max(worst_static_error(original, gmap, before, v, d) for v in SPEEDS)
    e1 = max(worst_static_error(original, gmap, after, v, d) for v in SPEEDS)
    assert e1 < e0


def test_refined_branching_tree_settles_near_the_original():
    # abop_1_24c at N = 3: every counted combined angle of the settled original must be
    # matched by the settled level-1 tree within 5 %.
    original, skeleton, skel_tree, gmap = small_case("abop_1_24c", 3)
    tree = written_tree(skeleton, closed_form(original, skel_tree, gmap))
    for direction in (0.0, 90.0, 30.0):
        wind = wind_from_speed(0.5, direction)
        assert_close_where_counted(np.stack(settled(tree, wind), -1),
                                   settled_combined(original, gmap, wind), 0.05)


@pytest.mark.parametrize("level", [1, 2])
def test_stalk_is_left_exactly_as_the_tips_down_fit_gives_it(level):
    # The tips-down fit matches a stalk exactly, so the refinement must not touch it.
    original, _, skel_tree, gmap = level_case(read_lsys("examples/stalk8.lsys"), level)
    a = closed_form(original, skel_tree, gmap, refine=False)
    b = closed_form(original, skel_tree, gmap, refine=True)
    for key in a.branch:
        np.testing.assert_array_equal(a.branch[key], b.branch[key])
    assert a.leaf_areas == b.leaf_areas


def test_fused_passes_give_the_numpy_recursion_bit_for_bit():
    """`refine_kernels.force_product` and `adjoint_down` (the Jacobian products' passes over
    the tree, one kernel each) against the numpy terms through `tree_sums.TreeSums` they
    replaced: the same operations in the same order, so the same bits, on a random tree of
    several roots and a few children per branch."""
    from plantlod.simplify.refine_kernels import adjoint_down, force_product
    from plantlod.simplify.tree_sums import TreeSums

    rng = np.random.default_rng(11)
    g, d = 60, 5
    parent = np.array([-1, -1] + [int(rng.integers(0, i)) for i in range(2, g)], dtype=np.int64)
    sums = TreeSums(parent)
    p, c = rng.uniform(0.5, 0.9, g), rng.uniform(1e-4, 1e-2, g)
    dp, dc = rng.normal(size=g), rng.normal(size=g)
    d_own, leaf, drag, shape = (rng.normal(size=(d, g, 3)) for _ in range(4))
    want_leaf = sums.up(p, d_own + (dp / p)[None, :, None] * leaf, True)
    want_drag = sums.up(p, (c * dc)[None, :, None] * shape
                        + dp[None, :, None] * (drag - c[None, :, None] * shape), False)
    got_leaf, got_drag = np.empty_like(leaf), np.empty_like(drag)
    force_product(sums.first, sums.child, p, c, dp, dc, d_own, leaf, drag, shape, got_leaf, got_drag)
    assert np.array_equal(got_leaf, want_leaf) and np.array_equal(got_drag, want_drag)
    l_bar, d_bar = rng.normal(size=(d, g, 3)), rng.normal(size=(d, g, 3))
    want = sums.down(p, l_bar), sums.down(p, d_bar)
    adjoint_down(parent, p, l_bar, d_bar)
    assert np.array_equal(l_bar, want[0]) and np.array_equal(d_bar, want[1])


def test_static_targets_kept_for_an_original_are_its_own():
    """`targets.member_statics` keeps the original's per-branch static angles for the levels
    fitted to it: what `static_targets` gives from the kept values equals a computation from
    scratch (static.py directly), and an original with one strength changed is not served
    the first one's."""
    from dataclasses import replace

    from plantlod.simplify import targets

    original, _skeleton, _skel_tree, gmap = small_case("abop_2_6", 4)
    d = fit_directions(MATCH_DIRECTIONS, MATCH_TILTED_DIRECTIONS, FIT_ELEVATION)

    def from_scratch(tree):
        parts = static_parts(tree, d)
        return np.stack([np.stack(combined_angles(tree, gmap.paths, *static_angles(tree, f)), -1)
                         for f in (parts.leaf, parts.drag)])

    for tree in (original, replace(original, bend_strength=original.bend_strength * 1.5),
                 original):
        for _ in range(2):                               # computed, then kept
            t = static_targets(tree, gmap, d)
            assert np.array_equal(np.stack([t.leaf, t.drag]), from_scratch(tree))
    assert len(targets._member_statics) >= 2
