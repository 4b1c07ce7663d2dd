"""The lanes engine (plantlod.sim.lanes) against separate single runs of the kernel.

Each lane must give, bit for bit, what `plantlod.sim.run.simulate_arrays` gives for
that lane's tree and wind alone; the thread count and running in pieces must not
change a bit either.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from plantlod.lsys.errors import InputError, RunFailure
from plantlod.sim.lanes import LaneModel, new_state, run_lanes
from plantlod.sim.run import simulate_arrays
from plantlod.sim.wind import ConstantWind, GustyWind, wind_from_speed
from treegen import abop_124a, make_tree, y_tree

DT = 0.01
WINDS = np.array([[2.0, 0.0, 0.0], [0.0, 5.0, 0.0], [3.0, 3.0, 1.0], [0.0, 0.0, 0.0],
                  [10.0, -4.0, 0.5], [0.5, 0.2, 0.0]])


def _leafy_tree():
    """Leaves at several angles, two on one branch."""
    euler = [[0, 0, 0], [0, 0.5, 0], [np.pi, 0.4, np.pi], [1.0, 0.3, 0.2]]
    normals = [[1, 0, 0], [0.6, 0, 0.8], [0, 1, 0], [0, 0.6, 0.8]]
    return make_tree([-1, 0, 0, 1], euler, leaf_branch=[1, 2, 3, 3], leaf_area=0.02,
                     leaf_normal=normals)


@pytest.mark.parametrize("tree", [y_tree(), abop_124a(2), _leafy_tree()],
                         ids=["y", "abop2", "leafy"])
def test_every_lane_equals_its_single_run(tree):
    steps = 150
    bend, rot = run_lanes(LaneModel.from_tree(tree), WINDS, DT, steps)
    assert bend.shape == (len(WINDS), steps, tree.n_branches)
    for w, vector in enumerate(WINDS):
        single = simulate_arrays(tree, DT, steps, ConstantWind(vector))
        assert np.array_equal(single.bend[1:], bend[w])
        assert np.array_equal(single.rot[1:], rot[w])


def test_per_step_winds_equal_a_gusty_single_run():
    tree = abop_124a(2)
    steps = 120
    winds = [GustyWind(wind_from_speed(4.0, d), seed=s, strength=0.5) for d, s in ((0, 1), (70, 2))]
    samples = np.stack([w.sample(np.arange(steps) * DT) for w in winds])
    bend, rot = run_lanes(LaneModel.from_tree(tree), samples, DT, steps, every=3)
    for w, wind in enumerate(winds):
        single = simulate_arrays(tree, DT, steps, wind, every=3)
        assert np.array_equal(single.bend[1:], bend[w]) and np.array_equal(single.rot[1:], rot[w])


def test_per_lane_parameters_equal_runs_of_modified_trees():
    tree = y_tree()
    factors = np.array([0.5, 1.0, 2.0, 3.0, 1.5])
    model = LaneModel.from_tree(tree)
    lane_model = model.with_lane_parameters(
        absorbed=tree.force_absorbed[:, None] * factors[None, :],
        bend_k=(tree.bend_strength[:, None] * np.sqrt(factors)[None, :]) / 1000.0)   # k_bs / 1000
    steps = 100
    bend, rot = run_lanes(lane_model, np.tile([4.0, 1.0, 0.0], (len(factors), 1)), DT, steps)
    for w, f in enumerate(factors):
        modified = dataclasses.replace(tree, force_absorbed=tree.force_absorbed * f,
                                       bend_strength=tree.bend_strength * np.sqrt(f))
        single = simulate_arrays(modified, DT, steps, ConstantWind((4.0, 1.0, 0.0)))
        assert np.array_equal(single.bend[1:], bend[w]) and np.array_equal(single.rot[1:], rot[w])


def test_thread_counts_give_identical_bits():
    tree = abop_124a(3)
    model = LaneModel.from_tree(tree)
    winds = np.vstack([WINDS, WINDS * 0.7, WINDS[:3] * 1.3])    # 15 lanes: blocks of several sizes
    one = run_lanes(model, winds, DT, 80, threads=1)
    two = run_lanes(model, winds, DT, 80, threads=2)
    assert np.array_equal(one[0], two[0]) and np.array_equal(one[1], two[1])


def test_state_in_pieces_equals_one_run():
    tree = abop_124a(2)
    model = LaneModel.from_tree(tree)
    whole = run_lanes(model, WINDS, DT, 90, every=2)
    state = new_state(model, len(WINDS))
    first = run_lanes(model, WINDS, DT, 41, every=2, state=state)
    second = run_lanes(model, WINDS, DT, 49, every=2, state=state, first_step=42)
    assert np.array_equal(np.concatenate([first[0], second[0]], axis=1), whole[0])
    assert np.array_equal(np.concatenate([first[1], second[1]], axis=1), whole[1])
    # the state holds the last step's angles
    assert np.array_equal(state[:, 0, :], whole[0][:, -1, :])


def test_divergence_names_the_lane_and_step():
    tree = make_tree([-1, 0], force_absorbed=1e300)
    with pytest.raises(RunFailure, match=r"lane 1, branch #"):
        run_lanes(LaneModel.from_tree(tree), [[0.0, 0.0, 0.0], [1e3, 0.0, 0.0]], DT, 5)
    # named as the caller names its lanes (simplify: its winds; "lane 1" meant nothing to a
    # user, session 25); a single lane is not named
    with pytest.raises(RunFailure, match=r"\) in the wind of 1000 m/s toward 0°, branch #"):
        run_lanes(LaneModel.from_tree(tree), [[0.0, 0.0, 0.0], [1e3, 0.0, 0.0]], DT, 5,
                  lane_names=["the wind of 0 m/s toward 0°", "the wind of 1000 m/s toward 0°"])
    with pytest.raises(RunFailure, match=r"\(step \d+\) branch #") as failure:
        run_lanes(LaneModel.from_tree(tree), [[1e3, 0.0, 0.0]], DT, 5)
    assert "lane" not in str(failure.value)


def test_bad_shapes_are_input_errors():
    model = LaneModel.from_tree(y_tree())
    with pytest.raises(InputError):
        run_lanes(model, np.zeros((2, 7, 3)), DT, 5)
    with pytest.raises(InputError):
        run_lanes(model, [[np.nan, 0.0, 0.0]], DT, 5)
    with pytest.raises(InputError):
        model.with_lane_parameters(absorbed=np.ones((model.n_branches + 2, 2)))


def read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


@pytest.mark.parametrize("call, said", [
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 5, threads="2"), "thread count must be"),
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 5, threads=2.5), "thread count must be"),
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], "0.01", 5), "dt must be a number"),
    (lambda m, t: run_lanes(m, "x", DT, 5), "winds must be numbers"),
    (lambda m, t: run_lanes(m, [[1j, 0.0, 0.0]], DT, 5), "winds must be numbers"),
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 5, state="x"), "state must be a float64"),
    (lambda m, t: run_lanes(t, [[1.0, 0.0, 0.0]], DT, 5), "model must be a LaneModel"),
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 5.0), "steps must be a whole number"),
    (lambda m, t: LaneModel.from_tree(None), "expected a Tree"),
    # (session 43's API fuzzing: "abc" a ValueError, [0.1] a TypeError, "0.1" taken as 0.1)
    (lambda m, t: LaneModel.from_tree(t, "abc"), r"damping must be a number \(an int"),
    (lambda m, t: LaneModel.from_tree(t, [0.1]), r"damping must be a number \(an int"),
    (lambda m, t: LaneModel.from_tree(t, "0.1"), r"damping must be a number \(an int"),
    # a read-only state: numpy's "assignment destination is read-only"; a NaN state: "diverged
    # … lower force_absorbed, the wind or dt"; 10^12 steps ran on past a minute
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 5, state=read_only(new_state(m, 1))),
     "state must be a writeable array"),
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 5, state=np.full((1, 4, 3), np.nan)),
     "state must hold finite angles and velocities, got nan"),
    (lambda m, t: run_lanes(m, [[1.0, 0.0, 0.0]], DT, 10**12, every=10**12),
     "steps must be a whole number in"),
    (lambda m, t: LaneModel.from_tree(dataclasses.replace(t, length=t.length[:1])),
     "the Tree breaks its invariants: length must have shape"),
])
def test_wrong_argument_types_are_input_errors(call, said):
    # each leaked TypeError, ValueError or AttributeError from inside (an API fuzzer,
    # session 36); threads=2.5 ran on 2 threads without a word
    tree = y_tree()
    with pytest.raises(InputError, match=said):
        call(LaneModel.from_tree(tree), tree)


# --- checked as the API is (docs/api.md, "Lower levels"; session 40, a helper's first hour) ---

def test_an_unstable_lane_is_refused_before_it_runs():
    """simulate refuses dt at which s = k dt / 1000 >= 4 (model.md 4, undamped); run_lanes ran
    on to angles of 1e6 rad, and a lane of negative strength to 9,170 rad."""
    model = LaneModel.from_tree(y_tree())
    k = float(np.max(model.bend_k))                    # k_bs / 1000 of the stiffest branch
    with pytest.raises(InputError, match="time step too large"):
        run_lanes(model, np.ones((1, 3)), 4.0 / k, 10)
    run_lanes(model, np.ones((1, 3)), 0.999 * 4.0 / max(k, float(np.max(model.rot_k))), 1)
    stiff = model.with_lane_parameters(rot_k=np.stack([model.rot_k, 10 * model.rot_k], axis=1))
    with pytest.raises(InputError, match="time step too large"):   # only lane 2 is unstable
        run_lanes(stiff, np.ones((2, 3)), 0.5 * 4.0 / float(np.max(model.rot_k)), 1)


@pytest.mark.parametrize("value, message", [
    (-1.0, "must be > 0"), (np.nan, "must hold finite numbers"), ("20", "array of numbers")])
def test_lane_parameters_are_numbers_a_run_can_take(value, message):
    model = LaneModel.from_tree(y_tree())
    column = np.full((model.n_branches, 1), value, dtype=object if isinstance(value, str) else float)
    with pytest.raises(InputError, match=message):
        model.with_lane_parameters(bend_k=column.astype(str) if isinstance(value, str) else column)
    with pytest.raises(InputError, match=">= 0"):
        model.with_lane_parameters(drag=np.full((model.n_branches, 1), -1.0))


def test_a_steady_lane_wind_past_the_limit_is_refused():
    model = LaneModel.from_tree(y_tree())
    with pytest.raises(InputError, match="a wind of 1e\\+06 m/s; expected at most 1000 m/s"):
        run_lanes(model, np.array([[1e6, 0.0, 0.0]]), 0.01, 1)
    # exactly 1000 m/s toward 30° measures 1000.0000000000001 and is taken, as simulate takes it
    run_lanes(model, np.array([[1000 * np.cos(np.pi / 6), 1000 * np.sin(np.pi / 6), 0.0]]), 0.01, 1)
