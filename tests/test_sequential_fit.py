"""The sequential fit's leaf split (simplify/sequential_fit.py, `leaf_split`): λ (the gain on
the children's force) and u_k (each own leaf's) from one group's static angles, checked
against hand-made groups whose answer is known."""

from __future__ import annotations

import numpy as np

from plantlod.simplify.sequential_fit import leaf_split

GAIN = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])       # the swing frame's x and y: no z


def _winds(count: int = 8) -> np.ndarray:
    """(D, 3) horizontal-ish forces of unit size from ``count`` directions, with an upward part
    so that a force along z is there in every wind."""
    a = 2 * np.pi * np.arange(count) / count
    return np.stack([np.cos(a), np.sin(a), 0.5 + 0.25 * np.cos(3 * a)], axis=1)


def test_a_split_that_fits_exactly_is_found():
    # children passed through with λ = 0.7 and two lateral leaves pushing along x and y with
    # u = (0.02, 0.05): the targets are exactly what they give, and the natural split
    # (λ : u = 1 : natural area) is that same split, so the fit returns it
    f = _winds()
    incoming = 0.3 * f
    own = np.stack([f * [1.0, 0.0, 0.0], f * [0.0, 1.0, 0.0]], axis=1)   # (D, 2, 3)
    lam, u = 0.7, np.array([0.02, 0.05])
    target = (lam * incoming + np.einsum("k,dkj->dj", u, own)) @ GAIN.T
    got_lam, got_u = leaf_split(GAIN, incoming, own, target, u / lam)
    assert abs(got_lam - lam) < 1e-3 * lam
    np.testing.assert_allclose(got_u, u, rtol=1e-3)


def test_a_leaf_the_statics_cannot_see_keeps_its_natural_area():
    # a third leaf whose force runs along the branch's axis, tilted off it by 1e-7 rad: it
    # turns the branch by almost nothing, so the group's own angles say nothing about its
    # area. It must keep its natural share (u_k / λ = its natural area), not fit the
    # targets' small misfit through its vanishing column with an area thousands of times
    # its own (family bent_leafy-123's level 1: a leaf along its chord at 26x the group's
    # leaf area pushed its branch along its axis and swung it 26x the tree's largest swing)
    f = _winds()
    incoming = 0.3 * f
    tilt = 1e-7
    axial = f[:, 2:3] * np.array([tilt, 0.0, 1.0])                       # (D, 3)
    own = np.stack([f * [1.0, 0.0, 0.0], f * [0.0, 1.0, 0.0], axial], axis=1)
    natural = np.array([0.02, 0.05, 0.01])
    lam = 0.7
    # the lateral leaves at their natural areas, and a misfit of 1 % that no area explains
    target = (lam * incoming + np.einsum("k,dkj->dj", lam * natural[:2], own[:, :2])) @ GAIN.T
    target = target * (1.0 + 0.01 * np.cos(np.arange(len(f))))[:, None]
    got_lam, got_u = leaf_split(GAIN, incoming, own, target, natural)
    area = got_u / got_lam
    assert 0.5 * natural[2] <= area[2] <= 2.0 * natural[2]
    np.testing.assert_allclose(area[:2], natural[:2], rtol=0.05)
