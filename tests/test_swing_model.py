"""The motion fit's model of a level branch's swing (simplify/swing_model.py): step responses
against model.md 4's closed form and the simulator, amplitudes against a literal half range,
and the gain step that fits them. Checked against independent computations."""

from __future__ import annotations

import math

import numpy as np

from plantlod.lsys.build import build
from plantlod.lsys.parse import parse_lsys
from plantlod.sim.damping import Damping
from plantlod.sim.run import simulate_arrays
from plantlod.sim.wind import ConstantWind
from plantlod.simplify.swing_model import step_responses, swing_amplitudes
from test_gain_damping import ONE_GAIN_BRANCH

DT = 0.01


def test_an_undamped_step_response_is_the_schemes_closed_form():
    """Semi-implicit Euler from rest under a constant force: with s = k Δt / 1000 and
    cos φ = 1 - s/2, θ_k / θ* = 1 - cos kφ + (s/2) sin kφ / sin φ (the scheme's map has
    eigenvalues e^(±iφ); e_0 = -1, e_1 = -1 + s)."""
    strength = np.array([[40.0, 55.0], [300.0, 12.0]])
    h = step_responses(strength, DT, 3000, 3, Damping())
    k = np.arange(0, 3001, 3)[:, None, None]
    s = strength[None] * DT / 1000.0
    phi = np.arccos(1.0 - s / 2.0)
    expect = 1.0 - np.cos(k * phi) + (s / 2.0) * np.sin(k * phi) / np.sin(phi)
    np.testing.assert_allclose(h, expect, atol=1e-9)


def test_a_damped_step_response_is_what_the_simulator_swings():
    """One branch with a gain matrix under a weak steady leaf force (its frame barely turns):
    each own angle over its static angle 1000 (G f)_m / k_m follows the step response, damping
    ratio included."""
    tree = build(parse_lsys(ONE_GAIN_BRANCH, "one.lsys")).tree
    v = np.array([0.03, 0.02, 0.01])
    n = np.asarray(tree.leaf_normal[0])
    f = 0.02 * (v @ n) * n
    g = tree.force_gain[0].reshape(2, 3)
    static = 1000.0 * (g @ f) / np.array([200.0, 100.0])
    damping = Damping(ratio=0.05)
    run = simulate_arrays(tree, DT, 1500, ConstantWind(v), every=5, damping=damping)
    h = step_responses(np.array([[200.0, 100.0]]), DT, 1500, 5, damping)
    np.testing.assert_allclose(run.bend[:, 0] / static[0], h[:, 0, 0], atol=1e-4)
    np.testing.assert_allclose(run.rot[:, 0] / static[1], h[:, 0, 1], atol=1e-4)


def test_amplitudes_are_the_half_range_of_the_summed_swings_and_their_slopes():
    rng = np.random.default_rng(3)
    h = step_responses(rng.uniform(20.0, 80.0, (5, 2)), DT, 2000, 4, Damping(ratio=0.03))
    own = rng.normal(0.0, 1e-3, (3, 5, 2, 2))
    amp, grad = swing_amplitudes(h, own)
    for w in range(3):
        for s in range(5):
            for c in range(2):
                x = own[w, s, c, 0] * h[:, s, 0] + own[w, s, c, 1] * h[:, s, 1]
                assert math.isclose(amp[w, s, c], (x.max() - x.min()) / 2.0, rel_tol=1e-12)
                for m in range(2):
                    bumped = own.copy()
                    bumped[w, s, c, m] *= 1.0 + 1e-7
                    a2, _ = swing_amplitudes(h, bumped)
                    slope = (a2[w, s, c] - amp[w, s, c]) / (own[w, s, c, m] * 1e-7)
                    assert math.isclose(grad[w, s, c, m], slope, rel_tol=1e-4, abs_tol=1e-9)


def test_the_dynamic_gain_step_recovers_a_gain_from_modelled_swings():
    """Swings made by the model itself with a gain G* (each branch's two own angles mixed into
    W_0 by a turned carry map, so a component swings where its static reading cancels): from a
    nearby G, with a negligible ridge, the step returns G* (or -G*, which swings alike)."""
    from plantlod.simplify.motion_fit import dynamic_gain_step

    rng = np.random.default_rng(7)
    s_count, w_count = 3, 8
    k = rng.uniform(30.0, 60.0, (s_count, 2))
    h = step_responses(k, DT, 2000, 4, Damping())
    true = rng.normal(0.0, 1e-3, (s_count, 2, 3))
    gain = true * (1.0 + 0.1 * rng.normal(0.0, 1.0, true.shape))
    angle = rng.uniform(0.3, 1.2, s_count)
    carry = np.stack([np.stack([np.cos(angle), -np.sin(angle)], -1),
                      np.stack([np.sin(angle), np.cos(angle)], -1)], 1)         # (S, 2, 2)
    force = rng.normal(0.0, 1.0, (w_count, s_count, 3))

    def swing(g):
        own = 1000.0 / k[None] * np.einsum("smj,wsj->wsm", g, force)
        amp, _ = swing_amplitudes(h, carry[None] * own[:, :, None, :])
        return np.transpose(amp, (0, 2, 1))                                    # (W, 2, S)

    ax, ay = swing(true), swing(gain)
    a_max = ax.max(axis=(1, 2))
    new = dynamic_gain_step(gain, k, k, carry, force, ax, ay, a_max, h, h, ridge=1e-12,
                            iterations=30)
    sign = np.sign(np.einsum("smj,smj->s", new, true))[:, None, None]
    np.testing.assert_allclose(sign * new, true, rtol=1e-5, atol=1e-9)
    np.testing.assert_allclose(swing(new), ax, rtol=1e-7)
