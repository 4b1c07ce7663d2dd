"""The numba kernel and the chunked runner against the slow reference of model.md.

`reference_model.reference_simulate` is an independent, literal reading of
model.md sections 3 and 4 (plain Python, explicit 3x3 matrices); the kernel
must agree with it to 1e-9 on random trees, winds and dampings. The rest
checks the runner's promises: sample rows, chunking, determinism, lazy numba.
"""

from __future__ import annotations

import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from plantlod.lsys.errors import InputError, RunFailure
from plantlod.sim import run as sim_run
from plantlod.sim.run import simulate, simulate_arrays
from plantlod.sim.wind import ConstantWind, GustyWind, KeyframeWind

from reference_model import reference_simulate
from treegen import abop_124a, make_tree, random_trees, stalk, y_tree

DT = 0.01
TOL = 1e-9


def reference(tree, dt, steps, wind, damping=0.0):
    bend, rot = reference_simulate(tree, dt, steps, lambda t: wind.sample(np.array([t]))[0],
                                   damping=damping)
    return np.array(bend, dtype=np.float64).reshape(steps + 1, -1), \
        np.array(rot, dtype=np.float64).reshape(steps + 1, -1)


def assert_matches_reference(tree, steps, wind, damping):
    got = simulate_arrays(tree, DT, steps, wind, damping=damping)
    want_bend, want_rot = reference(tree, DT, steps, wind, damping)
    np.testing.assert_allclose(got.bend, want_bend, rtol=0, atol=TOL)
    np.testing.assert_allclose(got.rot, want_rot, rtol=0, atol=TOL)
    return got


finite = lambda lo, hi: st.floats(lo, hi, allow_nan=False, allow_infinity=False)  # noqa: E731
vectors = st.tuples(finite(-8, 8), finite(-8, 8), finite(-3, 3))


@st.composite
def winds(draw):
    kind = draw(st.sampled_from(["constant", "keyframes", "gusts"]))
    if kind == "constant":
        return ConstantWind(draw(vectors))
    if kind == "keyframes":
        n = draw(st.integers(1, 4))
        gaps = [draw(finite(0.05, 0.5)) for _ in range(n)]
        times = np.cumsum(gaps) - gaps[0] + draw(finite(-0.2, 0.3))
        return KeyframeWind(times, [draw(vectors) for _ in range(n)])
    return GustyWind(ConstantWind(draw(vectors)), seed=draw(st.integers(0, 2**32)),
                     strength=draw(finite(0.0, 1.0)))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tree=random_trees(dt=DT), wind=winds(), damping=st.sampled_from([0.0, 0.05, 0.9]),
       steps=st.integers(1, 120))
def test_kernel_matches_reference_on_random_trees(tree, wind, damping, steps):
    assert_matches_reference(tree, steps, wind, damping)


@pytest.mark.parametrize("damping", [0.0, 0.2])
def test_kernel_matches_reference_on_abop_tree(damping):
    # 25 branches, strong gusty wind: angles of tenths of a radian, so the
    # frames move well away from rest.
    tree = abop_124a(2, bend_strength=150, rotation_strength=90, force_absorbed=0.2,
                     drag_coefficient=0.05)
    wind = GustyWind(ConstantWind((6.0, -3.0, 1.0)), seed=7, strength=0.5)
    got = assert_matches_reference(tree, 200, wind, damping)
    assert np.abs(got.bend).max() > 0.05 and np.abs(got.rot).max() > 0.05


def test_kernel_matches_reference_with_large_angles():
    # A stalk pushed past a right angle: the whole swing rotation is exercised.
    tree = stalk(3, bend_strength=40, rotation_strength=60, force_absorbed=0.5, leaf_area=0.1,
                 leaf_normal=(0.6, 0.8, 0.0), drag_coefficient=0.01)
    got = assert_matches_reference(tree, 300, ConstantWind((7.0, 5.0, 0.0)), 0.0)
    assert np.hypot(got.bend, got.rot).max() > math.pi / 2


def test_rows_are_every_kth_step_and_times_are_k_dt():
    tree = y_tree()
    wind = ConstantWind((3.0, 1.0, 0.0))
    full = simulate_arrays(tree, DT, 10, wind)
    some = simulate_arrays(tree, DT, 10, wind, every=3)
    assert full.bend.shape == (11, 3)
    np.testing.assert_array_equal(some.times, np.array([0, 3, 6, 9]) * DT)
    np.testing.assert_array_equal(some.bend, full.bend[[0, 3, 6, 9]])
    np.testing.assert_array_equal(some.rot, full.rot[[0, 3, 6, 9]])
    np.testing.assert_array_equal(full.times, np.arange(11) * DT)
    assert np.all(full.bend[0] == 0) and np.all(full.rot[0] == 0)


@pytest.mark.parametrize("chunk,every,cap", [(1, 1, 1 << 16), (7, 1, 3), (2, 5, 4), (1000, 2, 1)])
def test_chunking_does_not_change_results(monkeypatch, chunk, every, cap):
    tree = abop_124a(1)
    wind = GustyWind(ConstantWind((4.0, 2.0, 0.0)), seed=3, strength=0.4)
    whole = simulate_arrays(tree, DT, 41, wind, every=every)
    monkeypatch.setattr(sim_run, "SIM_STEPS_PER_CALL", cap)
    parts = list(simulate(tree, DT, 41, wind, every=every, chunk=chunk))
    assert all(1 <= len(p.times) <= chunk for p in parts)
    assert sum(len(p.times) for p in parts) == 41 // every + 1
    np.testing.assert_array_equal(np.concatenate([p.times for p in parts]), whole.times)
    np.testing.assert_array_equal(np.concatenate([p.bend for p in parts]), whole.bend)
    np.testing.assert_array_equal(np.concatenate([p.rot for p in parts]), whole.rot)


def test_identical_input_gives_identical_output():
    tree = abop_124a(2)
    wind = GustyWind(ConstantWind((5.0, 0.0, 0.0)), seed=11, strength=0.3)
    a = simulate_arrays(tree, DT, 50, wind)
    b = simulate_arrays(tree, DT, 50, wind)
    assert a.bend.tobytes() == b.bend.tobytes() and a.rot.tobytes() == b.rot.tobytes()


def test_zero_steps_gives_the_rest_row():
    out = simulate_arrays(y_tree(), DT, 0, ConstantWind((1.0, 0.0, 0.0)))
    assert out.times.tolist() == [0.0] and out.bend.tolist() == [[0.0, 0.0, 0.0]]


def test_tree_without_branches_runs():
    tree = make_tree([])
    out = simulate_arrays(tree, DT, 5, ConstantWind((1.0, 0.0, 0.0)))
    assert out.bend.shape == (6, 0) and out.times.shape == (6,)


def test_divergence_is_a_run_failure_naming_time_and_branch():
    # k_FA so large that one step's velocity overflows to inf: the angle of
    # the branch at address "1" (the leaf's) is no longer finite after step 2.
    tree = stalk(2, force_absorbed=[1.0, 1e308], address=["0", "1"], drag_coefficient=0.0,
                 force_propagated=[0.0, 1.0])
    wind = KeyframeWind([0.0, 0.015], [[0.0, 0.0, 0.0], [1e3, 0.0, 0.0]])   # (at most 1000 m/s)
    chunks = simulate(tree, DT, 100, wind, chunk=1)
    got = [next(chunks), next(chunks)]          # t0 and step 1 (wind 0 at t0: at rest)
    assert [c.times[0] for c in got] == [0.0, DT]
    with pytest.raises(RunFailure, match=r"diverged at t=0\.02 s \(step 2\) in branch 1\b"):
        next(chunks)


def test_bad_counts_are_input_errors():
    tree = y_tree()
    wind = ConstantWind((1.0, 0.0, 0.0))
    for kwargs in ({"steps": -1}, {"steps": 5, "every": 0}, {"steps": 5, "chunk": 0}):
        steps = kwargs.pop("steps")
        with pytest.raises(InputError):
            simulate(tree, DT, steps, wind, **kwargs)


def test_unstable_time_step_is_refused_before_running():
    tree = y_tree(bend_strength=1e5)
    with pytest.raises(InputError, match="time step too large"):
        simulate(tree, 0.04, 10, ConstantWind((1.0, 0.0, 0.0)))   # s = 4 >= 4


def test_importing_the_simulation_api_does_not_import_numba():
    code = ("import sys\n"
            "import plantlod.sim, plantlod.sim.run, plantlod.sim.wind, plantlod.sim.stability\n"
            "import plantlod.sim.kinematics, plantlod.formats.angles_csv\n"
            "assert 'numba' not in sys.modules, 'numba imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True)


# --- the interpreted and the compiled kernel give the same bits ---------------------------

def _both_engines(tree, steps, wind_samples, damping):
    from plantlod.sim import kernel

    out = []
    for engine in ("interpreted", "compiled"):
        model, state = kernel.prepare(tree, damping), kernel.KernelState(tree.n_branches)
        bend, rot = np.empty((steps, tree.n_branches)), np.empty((steps, tree.n_branches))
        result = kernel.advance(model, state, wind_samples, DT, 1, 1, bend, rot, 0, engine)
        out.append((result, bend[:result[0]], rot[:result[0]], state.bend_vel.copy()))
    return out


def _assert_same_bits(a, b):
    assert a[0] == b[0]
    for x, y in zip(a[1:], b[1:]):
        assert np.array_equal(x.view(np.int64), y.view(np.int64))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tree=random_trees(dt=DT), wind=winds(), damping=st.sampled_from([0.0, 0.05, 0.9]),
       steps=st.integers(1, 60))
def test_interpreted_kernel_equals_compiled_bit_for_bit(tree, wind, damping, steps):
    samples = np.asarray(wind.sample(np.arange(steps) * DT), dtype=np.float64)
    _assert_same_bits(*_both_engines(tree, steps, samples, damping))


def test_interpreted_kernel_equals_compiled_with_gains_ratio_and_divergence():
    from test_gain_damping import gain_tree

    from plantlod.sim.damping import as_damping

    tree = gain_tree()
    samples = np.random.default_rng(5).normal(size=(300, 3)) * 6.0
    _assert_same_bits(*_both_engines(tree, 300, samples, as_damping(ratio=0.05)))
    # a run that diverges: both stop at the same step and branch with the same bits
    big = stalk(2, force_absorbed=[1.0, 1e307], address=["0", "1"], drag_coefficient=0.0,
                force_propagated=[0.0, 1.0])
    wind = np.array([[0.0, 0.0, 0.0], [1e4, 0.0, 0.0], [1e4, 0.0, 0.0]])
    runs = _both_engines(big, 3, wind, 0.0)
    assert runs[0][0][1] == 1 and runs[0][0][2] == 2
    _assert_same_bits(*runs)


def test_a_short_simulate_does_not_load_numba():
    code = ("import sys\n"
            "from plantlod.sim.run import simulate_arrays\n"
            "from plantlod.sim.wind import ConstantWind\n"
            "from treegen import stalk\n"
            "simulate_arrays(stalk(8), 0.01, 10, ConstantWind((5.0, 0.0, 0.0)))\n"
            "assert 'numba' not in sys.modules, 'numba imported'\n")
    env = {**os.environ, "PYTHONPATH": str(pathlib.Path(__file__).parent)}
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


def test_kernel_environment_variable_forces_the_engine(monkeypatch):
    from plantlod.sim import kernel

    model = kernel.prepare(stalk(8))
    monkeypatch.setenv("PLANTLOD_KERNEL", "interpreted")
    assert kernel.engine_for(model, 10**6) == "interpreted"
    monkeypatch.setenv("PLANTLOD_KERNEL", "compiled")
    assert kernel.engine_for(model, 1) == "compiled"
    monkeypatch.setenv("PLANTLOD_KERNEL", "fast")
    with pytest.raises(InputError, match="PLANTLOD_KERNEL"):
        kernel.engine_for(model, 1)


def test_the_engine_is_chosen_alike_from_a_tree_and_its_flattened_model(monkeypatch):
    from plantlod.sim import kernel

    monkeypatch.delenv("PLANTLOD_KERNEL", raising=False)
    monkeypatch.delitem(sys.modules, "numba", raising=False)     # as before numba loads
    monkeypatch.setattr(kernel, "_interpreted_work", 0)
    tree = stalk(8)
    size = tree.n_branches + tree.n_leaves
    last = kernel.INTERPRET_BRANCH_STEPS // size        # the longest run still interpreted
    for steps, engine in ((1, "interpreted"), (last, "interpreted"), (last + 1, "compiled")):
        assert kernel.engine_for(tree, steps) == engine
        assert kernel.engine_for(kernel.prepare(tree), steps) == engine
