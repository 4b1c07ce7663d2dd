"""How far a level branch swings, read in its group root's frame W_0, from its gain matrix:
the motion fit's model of a branch's swing in its second fit (`motion_fit.dynamic_gain_step`).

Below the small-angle limit a branch's force hardly changes as it swings, so each of its own
angles m (bend, rotation) answers a steady wind as model.md 4's oscillator answers a constant
force from rest: θ_m(t) = θ*_m h_m(t), with θ*_m = (1000 / k_m) (G f)_m its static angle
(model.md 4, 5) and h_m the step response of its strength k_m, time step and damping
(`step_responses`: 0 at rest, 1 at equilibrium, about 2 at its first peak). Carried into W_0
by its carry map C (model.md 5's combined angles of a one-branch main path), component c
reads x_c(t) = Σ_m C[c, m] θ*_m h_m(t), and its amplitude (model.md 6: half the peak-to-peak
range) is

    A_c = (max_t x_c - min_t x_c) / 2.

Where the two own angles differ in period and C mixes them, A_c is not |static reading| times
a constant: a component whose static reading cancels between the two (a group that swings
across its own frame) still swings, as the group it stands for does. `swing_amplitudes`
gives A and its derivatives in the θ*_m (A is piecewise linear in them). `unit_response`, the
one step response of model.md 4's scheme, also serves the group swing model
(`explicit.dominant_strengths`, the strength search) and the merge costs' crossing skew.
"""

from __future__ import annotations

import numpy as np

from plantlod.sim.damping import Damping, ratio_coefficient


def unit_response(strength: np.ndarray, dt: float, steps: int, damping_ratio: float = 0.0,
                  every: int = 1) -> np.ndarray:
    """(steps // every + 1, n) angle of a branch of each ``strength`` (n,) (k, model units)
    started at rest under a constant force whose equilibrium angle is 1, by model.md 4's step
    itself: v <- v + s (1 - theta) - c v, theta <- theta + v dt, with s = k dt / 1000 ... per
    step (the velocity gain k/1000 times (theta_eq - theta)); c from the damping ratio ζ
    (`plantlod.sim.damping.ratio_coefficient`); every ``every``-th step kept (row 0 at rest),
    as `evaluate.run_times` samples a run."""
    k = np.asarray(strength, dtype=np.float64) / 1000.0
    damping = ratio_coefficient(k, dt, damping_ratio)
    theta = np.zeros_like(k)
    v = np.zeros_like(k)
    out = np.empty((steps // every + 1, k.size))
    out[0] = 0.0
    for step in range(1, steps + 1):
        v = v + k * (1.0 - theta) - damping * v
        theta = theta + v * dt
        if step % every == 0:
            out[step // every] = theta
    return out


def step_responses(strength: np.ndarray, dt: float, steps: int, every: int,
                   damping: Damping) -> np.ndarray:
    """(K, S, 2) h_m(t_k): `unit_response` of each branch's k_bs and k_rs (``strength``
    (S, 2)), sampled as `evaluate.run_times` (K = steps // every + 1, row 0 at rest). damping:
    the runs' (simplify damps its runs by a ratio alone, `pipeline.Options.damping`)."""
    strength = np.asarray(strength, dtype=np.float64)
    return unit_response(strength.reshape(-1), dt, steps, damping.ratio,
                         every).reshape((-1,) + strength.shape)


def carry_mixing(carry: np.ndarray) -> np.ndarray:
    """(S,) how far each carry map (S, 2, 2) mixes a branch's two own angles in W_0: the
    smaller of its largest diagonal and its largest off-diagonal entry (0 for a frame turned
    by 0 or 90° about its axis)."""
    c = np.abs(carry)
    return np.minimum(np.maximum(c[:, 0, 0], c[:, 1, 1]), np.maximum(c[:, 0, 1], c[:, 1, 0]))


def swing_amplitudes(h: np.ndarray, own: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Amplitudes A (W, S, c) of x_c(t) = Σ_m own[w, s, c, m] h[t, s, m], and dA / d own
    (W, S, c, m): h (K, S, 2) `step_responses`, own (W, S, c, 2) each own angle's static
    angle times its carry weight C[c, m] θ*_m (rad)."""
    w_count, s_count = own.shape[:2]
    amp = np.empty(own.shape[:3])
    grad = np.empty(own.shape)
    rows = np.arange(s_count)[:, None]
    cols = np.arange(2)[None, :]
    for w in range(w_count):
        x = np.einsum("ksm,scm->ksc", h, own[w])                              # (K, S, c)
        hi, lo = x.argmax(axis=0), x.argmin(axis=0)                           # (S, c)
        amp[w] = (x[hi, rows, cols] - x[lo, rows, cols]) / 2.0
        # dA/d own[c, m] = (h_m(t_max) - h_m(t_min)) / 2
        grad[w] = (h[hi, rows, :] - h[lo, rows, :]) / 2.0                      # (S, c, m)
    return amp, grad

