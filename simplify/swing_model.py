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
gives A and its derivatives in the θ*_m (A is piecewise linear in them).
"""

from __future__ import annotations

import numpy as np

from plantlod.sim.damping import Damping, coefficients


def step_responses(strength: np.ndarray, dt: float, steps: int, every: int,
                   damping: Damping) -> np.ndarray:
    """(K, S, 2) h_m(t_k): each branch's own angle m over its static angle after a constant
    force from rest, by model.md 4's semi-implicit Euler step, sampled as `evaluate.run_times`
    (K = steps // every + 1, row 0 at rest).

    strength (S, 2): k_bs and k_rs (N m / rad scaled as model.md 4: the step's k / 1000);
    damping: the runs' c or damping ratio (`sim.damping.coefficients`).
    """
    q = np.asarray(strength, dtype=np.float64) / 1000.0                     # (S, 2)
    cb, cr = coefficients(damping, q[:, 0], q[:, 1], dt)
    c = np.stack([cb, cr], axis=1)
    theta = np.zeros_like(q)
    v = np.zeros_like(q)
    out = np.empty((steps // every + 1,) + q.shape)
    out[0] = 0.0
    for k in range(1, steps + 1):
        v = v + q * (1.0 - theta) - c * v          # drive q θ* with θ* = 1
        theta = theta + v * dt
        if k % every == 0:
            out[k // every] = theta
    return out


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

