"""plantlod scene (model.md 7): the scene file's checks, the pixel formula and level choice
by hand, the cache, thread-count determinism, and the verified error within the budget."""

from __future__ import annotations

import json
import math
import os
import pathlib

from dataclasses import replace

import numpy as np
import pytest

from golden_util import ROOT, run_cli
from plantlod.scene.file import Camera, read_scene
from plantlod.scene.run import run_scene
from plantlod.scene.schedule import level_schedule

STALK = str(ROOT / "examples" / "stalk8.lsys")
TWIN = str(ROOT / "examples" / "eval" / "twin_draw.lsys")


def _scene(tmp_path, body: str, name="s.toml"):
    path = tmp_path / name
    path.write_text(body)
    return str(path)


BASE = f"""dt = 0.01
duration = 2
[wind]
speed = 5
[camera]
position = [0, -40, 1.7]
target = [0, 0, 1.7]
fov_deg = 60
height_px = 1080
[[tree]]
file = "{STALK}"
position = [0, 0, 0]
[scatter]
files = ["{TWIN}"]
count = 12
seed = 3
area = [-20, -20, 20, 20]
min_spacing = 3
"""


def test_pixels_by_hand():
    cam = Camera(np.zeros(3), np.array([0.0, 1.0, 0.0]), 60.0, 1080)
    # p = e H / (2 d tan(fov/2)): 1 cm at 10 m, 60 deg, 1080 px = 0.01 * 1080 / (20 tan 30)
    assert float(cam.pixels_per_metre(10.0)) * 0.01 == pytest.approx(
        0.01 * 1080 / (2 * 10 * math.tan(math.radians(30))), rel=1e-14)


def test_levels_chosen_by_distance_behind_and_at_the_camera(tmp_path):
    scene = read_scene(_scene(tmp_path, BASE))
    errors = np.array([0.0, 0.001, 0.01, 0.1])
    from dataclasses import replace
    ppm10 = float(scene.camera.pixels_per_metre(10.0))          # 93.5 px per metre at 10 m
    trees = [replace(scene.trees[0], position=(0.0, -30.0, 1.7)),   # 10 m ahead
             replace(scene.trees[0], position=(0.0, 0.0, 1.7)),     # 40 m ahead
             replace(scene.trees[0], position=(0.0, -50.0, 1.7)),   # behind
             replace(scene.trees[0], position=(0.0, -40.0, 1.7))]   # at the camera
    scene = replace(scene, trees=trees)
    levels = level_schedule(scene, [0, 1, 2, 3], errors, np.zeros(1), 1.0)
    # at 10 m: 0.01 m -> 0.935 px <= 1 (level 2), 0.1 m -> 9.35 px; at 40 m: 0.1 m -> 2.3 px
    assert 0.01 * ppm10 <= 1.0 < 0.1 * ppm10 / 4
    assert levels[:, 0].tolist() == [2, 2, 3, 0]


@pytest.fixture(scope="module")
def chains(tmp_path_factory):
    """One chain cache for the module: each tree's levels are simplified once, not per test
    (test_report_cache_threads_and_verified_budget keeps its own, to see the cache fill)."""
    return tmp_path_factory.mktemp("chains")


def _keyed_scene(tmp_path, keys, duration=2.0, budget_px=None):
    body = BASE.replace("position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n", "").replace(
        "duration = 2", f"duration = {duration}")
    if budget_px is not None:
        body = f"budget_px = {budget_px}\n" + body
    for t, y in keys:
        body += f"[[camera.key]]\nt = {t}\nposition = [0, {y}, 1.7]\ntarget = [0, 0, 1.7]\n"
    return read_scene(_scene(tmp_path, body, "keyed.toml"))


def test_a_keyed_camera_moves_linearly_between_keys_and_holds_beyond(tmp_path):
    scene = _keyed_scene(tmp_path, [(0.5, -10), (1.5, -30)])
    pos, tgt = scene.camera.at(np.array([0.0, 0.5, 1.0, 1.25, 1.5, 9.0]))
    np.testing.assert_allclose(pos[:, 1], [-10, -10, -20, -25, -30, -30])
    np.testing.assert_allclose(tgt, np.tile([0, 0, 1.7], (6, 1)))


def test_hysteresis_stops_a_tree_at_a_boundary_from_flickering(tmp_path):
    """A camera swaying 2 cm around the distance where level 2 just fits: without
    hysteresis the tree would switch every time the camera crosses; with it, never back."""
    errors = np.array([0.0, 0.001, 0.01, 0.1])
    scene = _keyed_scene(tmp_path, [(0.0, -10.0)])
    boundary = 0.01 * float(scene.camera.pixels_per_metre(1.0))      # d where 0.01 m = 1 px
    from dataclasses import replace
    times = np.arange(60) / 30.0
    sway = boundary + 0.02 * np.sin(2 * np.pi * times)                # crosses it 3 times
    keys = np.stack([np.zeros(60), -sway, np.full(60, 1.7)], axis=1)
    cam = replace(scene.camera, key_t=times, key_position=keys,
                  key_target=np.tile([0.0, 1.0, 1.7], (60, 1)), position=keys[0],
                  target=np.array([0.0, 1.0, 1.7]))
    scene = replace(scene, camera=cam, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    levels = level_schedule(scene, [0], errors, times, 1.0)[0]
    within = errors[2] * cam.pixels_per_metre(sway) <= 1.0
    naive_switches = int(np.sum(within[1:] != within[:-1]))
    assert naive_switches >= 3
    # finer at once whenever level 2 would overspend; coarser again only at <= 0.8 px
    assert np.all(errors[levels] * cam.pixels_per_metre(sway) <= 1.0 + 1e-12)
    assert int(np.sum(levels[1:] != levels[:-1])) <= 1


def test_switching_levels_mid_run_carries_the_state_and_stays_within_budget(tmp_path, chains):
    # the camera drives away: trees switch coarser as it goes, their state carried. A 0.1 px
    # budget: twin_draw's levels keep their tips within 1 cm at 5 m/s (8 cm before session 12),
    # so at 1 px its trees start at their coarsest level and hardly switch
    scene = _keyed_scene(tmp_path, [(0.0, -22.0), (3.0, -150.0)], duration=3.0, budget_px=0.1)
    report = run_scene(scene, cache=chains, verify=True)
    assert report["camera"] == "keyed" and report["switches"] >= 10
    levels = report["_levels"]
    assert levels.shape == (13, 100) and len(np.unique(levels)) >= 3   # 3 steps a frame
    assert np.all(np.diff(levels.astype(int), axis=1) >= 0)            # only ever coarser
    assert report["max_error_px"] <= report["budget_px"] + 1e-9
    assert report["branch_steps_spent"] < report["branch_steps_full"]


def test_a_camera_driving_in_switches_finer_and_stays_within_budget(tmp_path, chains):
    """Coming nearer, trees go finer as their level passes the budget (two_way_schedule); the
    finer level's state is predicted from the wind history, so the coarser level's error
    is not carried into it. A 0.5 px budget (14 switches, verified at 0.35 px with session
    14's levels, 0.28 px with session 13's). At smaller budgets the first-order prediction's
    own error shows: at 0.1 px the verified error was 0.1005 px, at 0.2 px 0.225 px
    (docs/scene.md, "Limits"). Since session 31 a switch whose measured error
    (`switch.switch_errors`, a worst case) would overspend is not made: the tree starts at
    the finer level (here 4 switches, 0.28 px, 12.9x against a bound of 75x; the speed-up was
    the bound's before)."""
    scene = _keyed_scene(tmp_path, [(0.0, -150.0), (3.0, -22.0)], duration=3.0, budget_px=0.5)
    report = run_scene(scene, cache=chains, verify=True)
    levels = report["_levels"].astype(int)
    assert report["switches"] >= 1 and np.any(np.diff(levels, axis=1) < 0)
    assert np.all(np.diff(levels, axis=1) <= 0)                        # only ever finer
    assert report["max_error_px"] <= report["budget_px"] + 1e-9
    assert report["speedup"] <= report["speedup_bound"] + 1e-9


def test_two_way_schedule_by_hand(tmp_path):
    """Approach from 100 m to 10 m and back out: the level each frame is the coarsest within
    1 px at its current distance on the way in, and on the way out it coarsens only where
    the next level is within 0.8 px (HYSTERESIS), worked out from model.md 7. A frame is
    judged at the nearer of its two ends: it runs from its start and shows its end."""
    from plantlod.scene.constants import HYSTERESIS
    from plantlod.scene.schedule import two_way_schedule

    errors = np.array([0.0, 0.001, 0.01, 0.1])
    scene = _keyed_scene(tmp_path, [(0.0, -100.0), (1.0, -10.0), (2.0, -150.0)], duration=2.0)
    scene = replace(scene, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    times = np.arange(60) / 30.0
    got = two_way_schedule(scene, [0], errors, times, 1.0)[0]
    ends = np.append(times[1:], 2.0)

    def ppm_at(t):
        d = np.where(t <= 1.0, 100.0 - 90.0 * t, 10.0 + 140.0 * (t - 1.0))
        return 1080 / (2 * d * math.tan(math.radians(30)))

    ppm = np.maximum(ppm_at(times), ppm_at(ends))
    expect, level = [], max(k for k, e in enumerate(errors) if e * ppm[0] <= 1.0)
    for p in ppm:
        if errors[level] * p > 1.0:
            level = max(k for k, e in enumerate(errors) if e * p <= 1.0)
        else:
            level = max(level, max(k for k, e in enumerate(errors) if e * p <= HYSTERESIS))
        expect.append(level)
    assert got.tolist() == expect
    assert got[0] == 3 and got.min() == 2 and got[-1] == 3     # in, finer, and out again


def test_a_camera_jumping_nearer_within_a_frame_is_judged_at_the_frame_s_end(tmp_path):
    """Keys 1 ms apart take the camera from 300 m to 5 m inside the frame [5, 5.033) s. The
    frame runs from its start and its pose is shown (stored, verified) at its end, with the
    camera at 5 m: it must run a level within 1 px at 5 m (model.md 7: p = e H / (2 d tan
    30°)). Judged at its start (before session 43) it kept the 300 m level: 4.6 px shown, and
    verified as 0.51 px at the start's distance (a scene fuzzing round)."""
    from plantlod.scene.schedule import two_way_schedule

    errors = np.array([0.0, 0.001, 0.01, 0.1])
    scene = _keyed_scene(tmp_path, [(0.0, -300.0), (5.0, -300.0), (5.001, -5.0),
                                    (10.0, -5.0)], duration=10.0)
    scene = replace(scene, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    times = np.arange(300) / 30.0
    got = two_way_schedule(scene, [0], errors, times, 1.0)[0]
    ppm = [1080 / (2 * d * math.tan(math.radians(30))) for d in (300.0, 5.0)]
    far, near = (max(k for k, e in enumerate(errors) if e * p <= 1.0) for p in ppm)
    assert (far, near) == (3, 1)
    jump = int(np.flatnonzero(times >= 5.0)[0])                  # the frame [5, 5.033) s
    assert got[jump - 1] == far and got[jump] == near and (got[jump:] == near).all()


@pytest.mark.parametrize("away_s", [1.0, 6.0])
@pytest.mark.parametrize("switch_m, held", [(0.0, False), (0.03, False), (0.045, False),
                                             (0.06, True)])
def test_a_tree_the_camera_turns_back_to_is_held_where_its_switch_would_overspend(
        tmp_path, away_s, switch_m, held):
    """The camera 10 m from the tree looks away (the tree behind it: 0 px, any level fits)
    for ``away_s`` seconds, then back. Level 2 (1 cm) is what the tree needs in view. Where
    level 2 switched into is ``switch_m`` metres off the full tree, coming back costs
    max(0.01, switch_m) m x 93.5 px/m at 10 m (model.md 7: 1080 / (2 x 10 m x tan 30°)):
    2.8 px at 3 cm and 4.2 px at 4.5 cm against a budget of 5 px (level 3, 10 cm, is 9.35 px
    in view), so the tree goes coarse while away and switches back; 5.6 px at 6 cm, so it is
    held at level 2 for as long as it is away, however long. (At 4.5 cm session 30's sum of
    the level's error and the switch's, 5.1 px, held it.)"""
    from dataclasses import replace

    from plantlod.scene.schedule import finer_switches, schedules

    errors = np.array([0.0, 0.001, 0.01, 0.1])
    scene = _keyed_scene(tmp_path, [(0.0, -10.0)], duration=10.0)
    times = np.arange(300) / 30.0
    behind = (times >= 2.0) & (times < 2.0 + away_s)
    keys = np.zeros((300, 3))
    keys[:, 1] = -10.0
    keys[:, 2] = 1.7
    target = np.where(behind[:, None], [0.0, -20.0, 1.7], [0.0, 0.0, 1.7])
    cam = replace(scene.camera, key_t=times, key_position=keys, key_target=target,
                  position=keys[0], target=target[0])
    scene = replace(scene, camera=cam, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    free = schedules(scene, [0], errors, times, 5.0)[0][0]
    shown_behind = behind & np.append(behind[1:], behind[-1])   # (at both ends of its frame)
    assert free.tolist() == np.where(shown_behind, 3, 2).tolist()
    assert finer_switches(free[None]) == {2}
    got = schedules(scene, [0], errors, times, 5.0, np.array([0.0, 0.0, switch_m, 0.0]))[0][0]
    assert got.tolist() == ([2] * 300 if held else free.tolist())


def test_switch_errors_are_the_predicted_state_run_on_against_the_full_tree(chains):
    """switch.switch_errors against a literal recomputation: the full tree stepped from rest
    by the single-run kernel, and level 1 from `Transfer.predicted` at each switch (every
    2 s), both posed at every sample (0.05 s) of the 3 s after it, level 1's tips against
    the tips of its groups' main paths, in each of TIP_ERROR_DIRECTIONS, steady and in
    gusts. And what it measures: in a light wind (linear) level 1 switched into is about as
    near the full tree as its own tip error says, in a strong one (twin_draw at 15 m/s,
    docs/scene.md) centimetres off."""
    from plantlod.compare.groups import assign_stated_groups, main_paths
    from plantlod.scene.levels import level_chain
    from plantlod.scene.constants import TIP_ERROR_DIRECTIONS
    from plantlod.scene.switch import Transfer, switch_errors
    from plantlod.sim.kernel import KernelState, advance, prepare
    from plantlod.sim.kinematics import pose
    from plantlod.scene.levels import Gusts
    from plantlod.sim.wind import GustyWind, wind_from_speed

    chain, _ = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 2.0, chains)
    transfer = Transfer(chain.trees, chain.groups)
    level, dt, every = 1, 0.01, 5
    original, tree = chain.trees[0], chain.trees[level]
    paths = main_paths(original, assign_stated_groups(original, tree), tree.n_branches)
    group_tips = np.array([p[-1] for p in paths])

    def run(t, state, wind, steps):
        """``wind``: (steps, 3), the wind at the start of each step."""
        b, r = np.empty((steps, t.n_branches)), np.empty((steps, t.n_branches))
        advance(prepare(t), state, np.ascontiguousarray(wind), dt, 1, 1, b, r, 0)
        return b, r

    def literal(speed: float, gusts=None) -> float:
        worst = 0.0
        for direction in TIP_ERROR_DIRECTIONS:
            wind = wind_from_speed(speed, direction)
            if gusts is not None:
                wind = GustyWind(wind, seed=gusts.seed, strength=gusts.strength)
            wind = wind.sample(np.arange(700) * dt)                      # (steps, 3)
            bend, rot = run(original, KernelState(original.n_branches), wind, 400 + 300)
            for s_ in (200, 400):
                p = transfer.predicted(level, wind[:s_], dt)
                on = KernelState(tree.n_branches)
                on.bend[:], on.bend_vel[:], on.rot[:], on.rot_vel[:] = p
                b2, r2 = run(tree, on, wind[s_:s_ + 300], 300)
                got_b = np.concatenate([p[:1], b2[every - 1::every]])
                got_r = np.concatenate([p[2:3], r2[every - 1::every]])
                rows = slice(s_ - 1, s_ + 300, every)             # after steps s_, s_ + 5, ..
                gap = (pose(tree, got_b, got_r).tip
                       - pose(original, bend[rows], rot[rows]).tip[:, group_tips])
                worst = max(worst, float(np.linalg.norm(gap, axis=-1).max()))
        return worst

    for speed in (0.5, 15.0):
        got = switch_errors(chain, transfer, {level}, speed, dt, 4.0)
        assert got[level] == pytest.approx(literal(speed), rel=1e-9, abs=1e-12)
        assert np.count_nonzero(got) == 1                          # only the level asked for
        if speed == 0.5:
            # level 1's tip error at 5 m/s, scaled to 0.5 m/s as the leaf force (∝ v) is
            assert got[level] < 1.5 * chain.tip_error_m[level] * (0.5 / 5.0)
        else:
            assert got[level] > 0.01                               # metres
    # a scene shorter than the 2 s between switches is measured at its end (it was 0)
    assert switch_errors(chain, transfer, {level}, 15.0, dt, 1.0)[level] > 0.001
    # a gusty scene's: in its own gusts on its speed (the wind at the start of each step)
    gusts = Gusts(0.5, 3)
    got = switch_errors(chain, transfer, {level}, 8.0, dt, 4.0, gusts)
    assert got[level] == pytest.approx(literal(8.0, gusts), rel=1e-9, abs=1e-12)
    assert got[level] != pytest.approx(literal(8.0), rel=0.01)


def test_a_cheap_switch_back_is_not_held_because_the_tree_comes_nearer_later(tmp_path):
    """A switch's error is spent at the nearest the tree comes within the 3 s it is measured
    over, not at the nearest it ever comes: a tree the camera comes to later leaves that
    level anyway, through a new prediction (a review, session 30: judged on its whole future,
    every return was held wherever the tree came nearer later). The camera, 40 m from the
    tree, looks away for 1 s (level 4, 1 m, in view would be 23 px) and back (level 3, 0.1 m:
    2.3 px), then drives to 10 m over 6 s. Level 3 switched into 1 cm off costs no more than
    its own 0.1 m: 2.3 px at 40 m and at most 3.2 px within 3 s (31 m), not dear under a 5 px
    budget; 0.2 m off, 6.5 px there, it is. Level 3 would have been 9.35 px at 10 m, judged
    on the whole future."""
    from dataclasses import replace

    from plantlod.scene.schedule import finer_switches, schedules

    errors = np.array([0.0, 0.001, 0.01, 0.1, 1.0])
    scene = _keyed_scene(tmp_path, [(0.0, -40.0)], duration=10.0)
    times = np.arange(300) / 30.0
    y = np.where(times < 3.0, -40.0, np.minimum(-40.0 + 5.0 * (times - 3.0), -10.0))
    keys = np.stack([np.zeros(300), y, np.full(300, 1.7)], axis=1)
    away = (times >= 1.0) & (times < 2.0)
    target = np.where(away[:, None], [0.0, -80.0, 1.7], [0.0, 0.0, 1.7])
    cam = replace(scene.camera, key_t=times, key_position=keys, key_target=target,
                  position=keys[0], target=target[0])
    scene = replace(scene, camera=cam, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    free = schedules(scene, [0], errors, times, 5.0)[0]
    assert finer_switches(free) == {3, 2} and free[0, 45] == 4 and free[0, -1] == 2
    cheap = schedules(scene, [0], errors, times, 5.0, np.array([0, 0, 0, 0.01, 0]))[0]
    assert cheap.tolist() == free.tolist()
    dear = schedules(scene, [0], errors, times, 5.0, np.array([0, 0, 0, 0.2, 0]))[0]
    assert dear[0, 30:60].tolist() == [3] * 30                # held while away


def test_finer_switches_are_the_levels_a_row_switches_into_from_a_coarser_one():
    from plantlod.scene.schedule import finer_switches

    assert finer_switches(np.array([[3, 3, 2, 2, 1, 1]])) == {2, 1}       # only ever finer
    assert finer_switches(np.array([[1, 1, 2, 3, 3, 4]])) == set()        # only ever coarser
    assert finer_switches(np.array([[2, 3, 3, 2, 4, 1]])) == {2, 1}
    assert finer_switches(np.array([[3, 2, 4, 3, 3], [1, 1, 1, 1, 1]])) == {2, 3}
    assert finer_switches(np.zeros((2, 1), dtype=np.int16)) == set()


@pytest.mark.parametrize("switch_m, held", [(0.02, False), (0.06, True)])
def test_a_tree_whose_first_switch_finer_would_overspend_starts_at_that_level(
        tmp_path, switch_m, held):
    """A camera that only comes nearer, in a strong wind (a helper's scenes, session 30:
    3.8 px against 1 px). It stands 40 m from the tree for 3 s (level 3, 0.1 m: 2.3 px at
    23.4 px/m, model.md 7), then drives to 10 m over 6 s; level 3 passes the 5 px budget at
    18.7 m (t = 7.3 s) and the tree goes to level 2 (1 cm). Level 2 switched into
    ``switch_m`` metres off the full tree costs switch_m x 93.5 px/m at 10 m, the nearest
    within 3 s of the switch: 1.9 px at 2 cm, so the tree switches; 5.6 px at 6 cm, so it
    runs level 2 from its first frame (from rest, no prediction) and never switches."""
    from dataclasses import replace

    from plantlod.scene.schedule import schedules

    errors = np.array([0.0, 0.001, 0.01, 0.1, 1.0])
    scene = _keyed_scene(tmp_path, [(0.0, -40.0)], duration=10.0)
    times = np.arange(300) / 30.0
    y = np.where(times < 3.0, -40.0, np.minimum(-40.0 + 5.0 * (times - 3.0), -10.0))
    keys = np.stack([np.zeros(300), y, np.full(300, 1.7)], axis=1)
    target = np.tile([0.0, 0.0, 1.7], (300, 1))
    cam = replace(scene.camera, key_t=times, key_position=keys, key_target=target,
                  position=keys[0], target=target[0])
    scene = replace(scene, camera=cam, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    free = schedules(scene, [0], errors, times, 5.0)[0][0]
    switch = int(np.argmax(free < 3))
    assert free[0] == 3 and 7.2 < times[switch] < 7.4 and set(free[switch:].tolist()) == {2}
    asked = []

    def measured(levels):
        asked.append(set(levels))
        return np.array([0.0, 0.0, switch_m, 0.0, 0.0])

    got = schedules(scene, [0], errors, times, 5.0, measured)[0][0]
    assert asked == [{2}]
    assert got.tolist() == ([2] * 300 if held else free.tolist())


def test_the_predicted_state_is_the_level_run_from_rest(tmp_path, chains):
    """switch.Transfer.predicted against the level itself simulated from rest in a gusty
    wind of one direction: at small angles the linear theory puts every tip within 1 % of
    the largest tip displacement of the run (what a camera sees), at any switch time."""
    from plantlod.scene.levels import level_chain
    from plantlod.scene.switch import Transfer
    from plantlod.sim.kinematics import pose
    from plantlod.sim.lanes import run_lanes
    from plantlod.sim.wind import GustyWind, wind_from_speed

    chain, _ = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 2.0, chains)
    transfer = Transfer(chain.trees, chain.groups)
    steps = 1000
    history = GustyWind(wind_from_speed(3.0, 40.0), seed=2, strength=0.3).sample(
        np.arange(steps) * 0.01)
    for level in (0, 1, 3):
        tree = chain.trees[level]
        bend, rot = run_lanes(chain.lane_model(level), history[None], 0.01, steps)
        tips = pose(tree, bend[0], rot[0]).tip                                # (T, B, 3)
        rest = pose(tree, np.zeros((1, tree.n_branches)), np.zeros((1, tree.n_branches))).tip[0]
        largest = np.linalg.norm(tips - rest, axis=-1).max()
        for s_ in (100, 400, 1000):
            got = transfer.predicted(level, history[:s_], 0.01)
            guess = pose(tree, got[0][None], got[2][None]).tip[0]
            assert np.linalg.norm(guess - tips[s_ - 1], axis=-1).max() <= 0.01 * largest
    turned = history.copy()
    turned[200:, 1] += 1.0                                 # the direction changes: no prediction
    assert transfer.predicted(1, turned, 0.01) is None


def test_a_tree_the_camera_will_pass_starts_at_the_level_its_nearest_point_allows(tmp_path):
    """A state carried into a finer level keeps the coarser level's error (the model is
    undamped), so the schedule judges every frame by the nearest the tree comes from then
    on: approaching it from 100 m to 10 m, the tree runs from the first frame at the level
    that fits at 10 m, computed here by hand from model.md 7."""
    errors = np.array([0.0, 0.001, 0.01, 0.1])
    scene = _keyed_scene(tmp_path, [(0.0, -100.0), (2.0, -10.0)])
    scene = replace(scene, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    times = np.arange(60) / 30.0
    levels = level_schedule(scene, [0], errors, times, 1.0)[0]
    ppm_nearest = 1080 / (2 * 10.0 * math.tan(math.radians(30)))           # 93.5 px per m
    expected = max(k for k, e in enumerate(errors) if e * ppm_nearest <= 1.0)
    assert expected == 2 and np.all(levels == expected)
    # driving away instead, it starts there and coarsens, never finer
    away = _keyed_scene(tmp_path, [(0.0, -10.0), (2.0, -150.0)])
    away = replace(away, trees=[replace(away.trees[0], position=(0.0, 0.0, 1.7))])
    levels = level_schedule(away, [0], errors, times, 1.0)[0]
    assert levels[0] == 2 and levels[-1] == 3 and np.all(np.diff(levels) >= 0)


def test_the_bound_uses_each_frames_current_distance(tmp_path):
    """speedup_bound's levels (`coarsest_levels`): approaching from 100 m to 10 m, each frame
    at the coarsest level its own distance allows (by hand, model.md 7), never finer than
    the look-ahead schedule's."""
    from plantlod.scene.schedule import coarsest_levels

    errors = np.array([0.0, 0.001, 0.01, 0.1])
    scene = _keyed_scene(tmp_path, [(0.0, -100.0), (2.0, -10.0)])
    scene = replace(scene, trees=[replace(scene.trees[0], position=(0.0, 0.0, 1.7))])
    times = np.arange(60) / 30.0
    bound = coarsest_levels(scene, [0], errors, times, 1.0)[0]
    d = 100.0 - 90.0 * np.minimum(times / 2.0, 1.0)
    ppm = 1080 / (2 * d * math.tan(math.radians(30)))     # camera and base both at z = 1.7
    expect = [max(k for k, e in enumerate(errors) if e * p <= 1.0) for p in ppm]
    assert bound[0] == 3 and bound[-1] == 2
    assert np.sum(bound != np.array(expect)) <= 1          # a frame at a boundary may round
    assert np.all(bound >= level_schedule(scene, [0], errors, times, 1.0)[0])


@pytest.mark.parametrize("body, message", [
    (BASE + "colour = 3\n", "unknown key 'colour'"),
    (BASE + '"x\\u0001y" = 3\n', "unknown key 'x\\x01y'"),     # found by its escapes read
    (BASE + "'x y' = 3\n", "unknown key 'x y'"),
    (BASE.replace("fov_deg = 60", "fov_deg = 200"), "'fov_deg' must be below 180"),
    (BASE.replace("speed = 5", "speed = -1"), "'speed' must be >= 0"),
    (BASE.replace(STALK, "missing.lsys"), "not found"),
    (BASE.replace("target = [0, 0, 1.7]", "target = [0, -40, 1.7]"), "target is its position"),
    (BASE + "[[camera.key]]\nt = 0\nposition = [0, 1, 1]\ntarget = [0, 0, 1]\n",
     "both position/target and [[camera.key]]"),
    (BASE.replace("position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n", "")
     + "[[camera.key]]\nt = 1\nposition = [0, 1, 1]\ntarget = [0, 0, 1]\n"
     + "[[camera.key]]\nt = 1\nposition = [0, 2, 1]\ntarget = [0, 0, 1]\n", "increasing times"),
    (BASE.replace("position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n", "")
     + "[[camera.key]]\nt = 0\nposition = [0, 1, 1]\nlook = [0, 0, 1]\n", "unknown key 'look'"),
    # a near miss is named (a new user's `fov`, session 33)
    (BASE + "min_spacng = 3\n", "unknown key 'min_spacng' in [scatter] (did you mean "
     "'min_spacing'?)"),
    ("budget_px = 0\n" + BASE, "'budget_px' is 0"),
    ("budget_px = -1\n" + BASE, "'budget_px' must be > 0, got -1"),   # (">= 0" while 0 is refused)
    ("budget_px = 0.0\n" + BASE, "'budget_px' is 0"),
    (BASE.replace("count = 12", "count = 5000"), "cannot place"),
    ("dt = [\n", "not valid TOML"),
    # (session 40, a helper's fuzzing: tomllib's "Cannot overwrite a value" named no key, its
    # column past the line's end; other complaints said nothing of what was expected)
    ("dt = 0.01\ndt = 0.02\n" + BASE, "s.toml:2:1: error: the key 'dt' is given twice in its "
                                       "table (first on line 1); expected it once"),
    (BASE.replace("speed = 5", "speed = 5\nspeed = 6"), "the key 'speed' is given twice in its "
                                                        "table (first on line"),
    ('name = "open\n' + BASE, "s.toml:1:13: error: not valid TOML: Illegal character '\\n': a "
                              "string runs to the end of its line; expected its closing quote"),
    ("b\u00fcdget_px = 1\n" + BASE, "expected key = value; a key without quotes holds only"),
    ("dt =\n" + BASE, "Invalid value: expected a value after ="),
])
def test_bad_scenes_exit_2_with_the_line(tmp_path, body, message):
    path = _scene(tmp_path, body)
    out = tmp_path / "r.json"
    result = run_cli("scene", path, "--report", str(out), "--no-cache", exit_code=2)
    assert message in result.stderr and not out.exists()
    if "unknown key" in message:
        assert f"{path}:{body.count(chr(10))}:" in result.stderr      # the line of the key


def test_report_cache_threads_and_verified_budget(tmp_path):
    path = _scene(tmp_path, BASE)
    cache = tmp_path / "cache"
    first = json.loads(run_cli("scene", path, "--verify", "--cache", str(cache),
                               "--run-info").stdout)
    assert first["trees"] == 13 and first["run"]["chains_from_cache"] == 0
    assert first["branch_steps_full"] == 200 * first["branches_full"]
    assert first["speedup"] == pytest.approx(first["branch_steps_full"] / first["branch_steps_spent"])
    assert first["max_error_px"] <= first["budget_px"] + 1e-9           # what --verify measured
    assert sum(first["level_share"].values()) == pytest.approx(1.0)
    # chain_levels: what each chain's choice was made from; its shares pooled over the trees
    # give level_share, and its branches the branches spent
    chains = first["chain_levels"]
    assert sum(c["trees"] for c in chains) == first["trees"] and len(chains) == first["chains"]
    assert sorted(os.path.normpath(os.path.join(os.path.dirname(path), c["file"]))
                  for c in chains) == sorted(str(p) for p in (STALK, TWIN))
    assert [c["seed"] for c in chains] == [None, None]
    for k, pooled in first["level_share"].items():
        assert pooled == pytest.approx(sum(c["trees"] * level["share"] for c in chains
                                           for level in c["levels"] if level["level"] == int(k))
                                       / first["trees"])
    assert first["branches_spent"] == pytest.approx(sum(
        c["trees"] * level["share"] * level["branches"] for c in chains for level in c["levels"]),
        abs=1e-3)
    for c in chains:
        branches = [level["branches"] for level in c["levels"]]
        tips = [level["tip_error_m"] for level in c["levels"]]
        assert branches == sorted(branches, reverse=True) and tips[0] == 0.0
    second = json.loads(run_cli("scene", path, "--cache", str(cache), "--threads", "1",
                                "--run-info").stdout)
    assert second["run"]["chains_from_cache"] == 2                       # nothing simplified again
    assert second["run"]["wall_s"] > 0
    # without --run-info the report holds no fact of the run: the same bytes, cold cache or
    # warm, one thread or two (a helper, session 35: wall seconds made every report differ)
    plain = [run_cli("scene", path, "--cache", str(tmp_path / f"c{k}"), "--threads", k).stdout
             for k in ("1", "2")]
    plain.append(run_cli("scene", path, "--cache", str(tmp_path / "c1")).stdout)
    assert plain[0] == plain[1] == plain[2] and '"wall_s"' not in plain[0]
    for key in ("branch_steps_spent", "level_share", "branches_spent"):
        assert second[key] == first[key]


def test_a_verified_sample_covers_every_level_and_measures_what_full_verify_does(tmp_path, chains):
    """--verify-sample N: each sampled tree's error is the one --verify measures for it (the
    same full-detail run), the sample's maximum at most the whole scene's, and every level a
    tree starts at is in the sample (`verify_sample`'s strata)."""
    from plantlod.scene.run import run_scene, verify_sample
    from plantlod.scene.file import read_scene as read

    scene = read(_scene(tmp_path, BASE))
    full = run_scene(scene, cache=chains, verify=True)
    part = run_scene(scene, cache=chains, verify=True, sample=4)
    levels = full["_levels"]
    chosen = verify_sample(scene, levels, 3, 4)
    assert part["verify_sample"]["trees"] == int(chosen.sum()) >= 1
    assert set(part["verify_sample"]["levels"]) == {int(v) for v in levels.min(axis=1)}
    assert part["verified_trees"] == int(chosen.sum())
    assert part["max_error_px"] <= full["max_error_px"] + 1e-12
    assert part["branch_steps_spent"] == full["branch_steps_spent"]
    run_cli("scene", _scene(tmp_path, BASE), "--verify-sample", "3", exit_code=2)


def test_angles_do_not_depend_on_threads(tmp_path, chains):
    from plantlod.scene.run import tree_winds

    body = BASE.replace("speed = 5", "speed = 5\nfront_speed = 4").replace(
        "[scatter]", f'[[tree]]\nfile = "{STALK}"\nposition = [4, 0, 0]\n[scatter]')
    scene = read_scene(_scene(tmp_path, body))
    w = tree_winds(scene, scene.steps)
    # a front at 4 m/s along +x reaches the tree at x = 4 m after 1 s (100 steps)
    assert scene.trees[1].position[0] == 4.0
    assert np.all(w[1, :100] == 0.0) and np.all(w[1, 101:, 0] == 5.0) and np.all(w[0, :, 0] == 5.0)
    one = run_scene(scene, cache=chains, threads=1)
    two = run_scene(scene, cache=chains, threads=2)
    assert one["branch_steps_spent"] == two["branch_steps_spent"]


def test_angles_store_holds_every_tree_at_its_level(tmp_path, chains):
    import zarr

    from plantlod.scene.levels import level_chain
    from plantlod.scene.run import tree_winds
    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import KeyframeWind

    path = _scene(tmp_path, BASE)
    store = tmp_path / "a.zarr"
    report = json.loads(run_cli("scene", path, "--cache", str(chains), "--angles",
                                str(store)).stdout)
    group = zarr.open_group(str(store), mode="r")
    levels = group["levels"][:]
    assert levels.shape == (report["trees"], report["frames"]) and "_levels" not in report
    seen = []
    scene = read_scene(path)
    winds = tree_winds(scene, scene.steps)
    every = int(round(1 / (30 * scene.dt)))
    for name in group.group_keys():
        trees = group[name]["trees"][:].tolist()
        seen += trees
        for row, k in enumerate(trees[:3]):
            level = int(levels[k, 0])
            assert np.all(levels[k] == level)                 # a fixed camera: one level
            # the tree's rows hold numbers at its level and NaN at every other
            for other in group[name].group_keys():
                values = group[name][other]["bend"][row]
                assert np.isnan(values).all() != (other == f"level_{level}")
            # against a single run of that tree in its own wind (model.md 4)
            chain, _ = level_chain(scene.trees[k].file, report["level_wind_speed"], scene.dt,
                                   scene.duration, chains)
            times = np.arange(scene.steps) * scene.dt
            single = simulate_arrays(chain.trees[level], scene.dt, scene.steps,
                                     KeyframeWind(times, winds[k]), every=every)
            np.testing.assert_array_equal(group[name][f"level_{level}"]["bend"][row],
                                          single.bend[1:].astype(np.float32))
    assert sorted(seen) == list(range(report["trees"]))
    # an existing store is never overwritten
    again = run_cli("scene", path, "--cache", str(chains), "--angles", str(store), exit_code=2)
    assert "exists" in again.stderr


def _store_arrays(group):
    out = {"levels": group["levels"][:]}
    for name in group.group_keys():
        out[name + "/trees"] = group[name]["trees"][:]
        for level in group[name].group_keys():
            for array in ("bend", "rotation"):
                out[f"{name}/{level}/{array}"] = group[name][level][array][:]
    return out


def test_a_moving_camera_gives_the_same_store_for_any_thread_count(tmp_path, chains):
    import zarr

    body = BASE.replace("position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n", "") + (
        "[[camera.key]]\nt = 0\nposition = [0, -22, 1.7]\ntarget = [0, 0, 1.7]\n"
        "[[camera.key]]\nt = 2\nposition = [0, -120, 1.7]\ntarget = [0, 0, 1.7]\n")
    path = _scene(tmp_path, body)
    stores = []
    for threads in ("1", "2"):
        out = tmp_path / f"t{threads}.zarr"
        run_cli("scene", path, "--cache", str(chains), "--angles", str(out),
                "--threads", threads)
        stores.append(_store_arrays(zarr.open_group(str(out), mode="r")))
    assert stores[0].keys() == stores[1].keys()
    for key in stores[0]:
        np.testing.assert_array_equal(stores[0][key], stores[1][key])
    levels = stores[0]["levels"]
    assert np.any(levels[:, 1:] != levels[:, :-1])           # it did switch


def test_a_workers_store_stays_removed_once_a_signal_removed_it(tmp_path):
    """A Dask worker's task runs on after `scene --scheduler` ends on a signal, whose handler
    removes the temporary store (`remove_folder`: renamed away, then removed). The worker's
    later chunks (`RootedStore`) then fail and make no folder; zarr's own LocalStore makes
    the whole path again (the store came back, partly filled, beside the output)."""
    import zarr
    from zarr.storage import LocalStore

    from plantlod.formats.atomic import remove_folder
    from plantlod.scene.rooted_store import RootedStore

    for kind, comes_back in ((LocalStore, True), (RootedStore, False)):
        root = tmp_path / f"{kind.__name__}.zarr"
        made = zarr.open_group(str(root), mode="w-")
        made.create_array("x", shape=(4, 4), chunks=(2, 2), dtype="float32", fill_value=np.nan)
        worker = zarr.open_group(kind(str(root)), mode="r+")["x"]
        worker[0:2, 0:2] = 1.0                  # a chunk written while the store is there
        assert (root / "x" / "c" / "0" / "0").is_file()
        remove_folder(str(root))
        assert not root.exists() and not list(tmp_path.glob(f"{root.name}*"))
        if comes_back:
            worker[2:4, 2:4] = 2.0
        else:
            with pytest.raises(FileNotFoundError):
                worker[2:4, 2:4] = 2.0
            with pytest.raises(FileNotFoundError):       # nor does opening it again
                zarr.open_group(RootedStore(str(root)), mode="r+")
        assert root.exists() == comes_back


def test_a_local_dask_cluster_gives_the_same_store(tmp_path, chains):
    """Two worker processes write their own batches; the store equals the in-process one."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    import zarr

    path = _scene(tmp_path, BASE)
    cache = str(chains)
    run_cli("scene", path, "--cache", cache, "--angles", str(tmp_path / "here.zarr"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        far = json.loads(run_cli("scene", path, "--cache", cache, "--angles",
                                 str(tmp_path / "there.zarr"), "--scheduler",
                                 cluster.scheduler_address).stdout)
    here = _store_arrays(zarr.open_group(str(tmp_path / "here.zarr"), mode="r"))
    there = _store_arrays(zarr.open_group(str(tmp_path / "there.zarr"), mode="r"))
    assert here.keys() == there.keys()
    for key in here:
        np.testing.assert_array_equal(here[key], there[key])
    assert far["branch_steps_spent"] < far["branch_steps_full"]


def test_plot_is_a_png_and_refused_before_anything_runs_when_unwritable(tmp_path, chains):
    path = _scene(tmp_path, BASE)
    png = tmp_path / "s.png"
    run_cli("scene", path, "--cache", str(chains), "--plot", str(png), "--report",
            str(tmp_path / "r.json"))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = run_cli("scene", path, "--cache", str(chains), "--plot",
                  str(tmp_path / "no" / "such" / "dir" / "s.png"), exit_code=None)
    assert bad.exit_code in (1, 2) and len(bad.stderr.strip().splitlines()) >= 1


def test_a_camera_looking_straight_down_draws_no_view_cone(tmp_path, chains, monkeypatch):
    """Its view has no heading in the plan: the cone was drawn along +x (atan2(0, 0) = 0; a
    scene fuzzing round). Every line the plot draws from the camera is recorded: a camera
    looking along y draws two (the cone's sides, toward +y), one looking down none."""
    import matplotlib.axes

    drawn = []
    plot = matplotlib.axes.Axes.plot
    monkeypatch.setattr(matplotlib.axes.Axes, "plot",
                        lambda self, *a, **k: drawn.append(a) or plot(self, *a, **k))
    for target, cone in (("[0, 0, 1.7]", 2), ("[0, -40, 0]", 0)):
        body = BASE.replace("target = [0, 0, 1.7]", f"target = {target}").replace(
            "position = [0, -40, 1.7]", "position = [0, -40, 30]")
        drawn.clear()
        run_cli("scene", _scene(tmp_path, body), "--cache", str(chains), "--plot",
                str(tmp_path / "s.png"), "--report", str(tmp_path / "r.json"))
        sides = [a for a in drawn if len(a) == 2 and np.size(a[0]) == 2 and a[0][0] == 0
                 and a[1][0] == -40]
        assert len(sides) == cone
        assert all(a[1][1] > -40 for a in sides)             # (toward +y, the target)


@pytest.mark.parametrize("module", ["simplify/explicit.py", "simplify/constants.py",
                                    "compare/measures.py", "sim/lanes_kernel.py"])
def test_a_chain_cache_key_changes_with_the_fitting_code(monkeypatch, module):
    """The cache key covers the source of the fit: one changed byte in any module of lsys,
    sim, compare or simplify gives another key (no version to bump by hand)."""
    import pathlib

    from plantlod.scene import levels

    levels.fit_code_digest.cache_clear()
    before = levels.cache_key(b"tree", 5.0, 0.01, 20.0)
    real = pathlib.Path.read_bytes

    def edited(path):
        data = real(path)
        return data + b"#" if path.as_posix().endswith(module) else data

    monkeypatch.setattr(pathlib.Path, "read_bytes", edited)
    levels.fit_code_digest.cache_clear()
    try:
        assert levels.cache_key(b"tree", 5.0, 0.01, 20.0) != before
    finally:
        monkeypatch.undo()
        levels.fit_code_digest.cache_clear()
    assert levels.cache_key(b"tree", 5.0, 0.01, 20.0) == before


def test_the_tip_error_directions_are_part_of_a_chains_cache_key(monkeypatch):
    """A cached chain's tip errors are the worst over TIP_ERROR_DIRECTIONS (scene/constants.py,
    outside the fitting packages the code digest covers): other directions, another key, so a
    chain measured over four sides is not read back as measured over eight."""
    from plantlod.scene import levels

    before = levels.cache_key(b"tree", 5.0, 0.01, 20.0)
    monkeypatch.setattr(levels, "TIP_ERROR_DIRECTIONS", (0.0, 90.0, 180.0, 270.0))
    assert levels.cache_key(b"tree", 5.0, 0.01, 20.0) != before


def test_the_gusts_are_part_of_a_chains_cache_key():
    """A gusty scene's chain is measured in its gusts (`levels.Gusts`): another strength or
    seed, another key; a steady scene's key is the one it had before gusts were measured."""
    from plantlod.scene import levels

    steady = levels.cache_key(b"tree", 5.0, 0.01, 20.0)
    keys = {steady, levels.cache_key(b"tree", 5.0, 0.01, 20.0, gusts=levels.Gusts(0.3, 1)),
            levels.cache_key(b"tree", 5.0, 0.01, 20.0, gusts=levels.Gusts(0.5, 1)),
            levels.cache_key(b"tree", 5.0, 0.01, 20.0, gusts=levels.Gusts(0.3, 2))}
    assert len(keys) == 4
    assert levels.cache_key(b"tree", 5.0, 0.01, 20.0, gusts=None) == steady


def test_a_gusty_chains_tip_errors_are_measured_in_its_gusts(tmp_path, chains):
    """`level_chain(..., gusts=)`: each level's tip error (max) against a literal
    recomputation: the original and the level stepped by the single-run kernel from rest in
    `GustyWind` on the base speed (the wind at the start of each step, as `tree_winds` gives
    a scene's trees), toward each of TIP_ERROR_DIRECTIONS, every step posed, the level's
    tips against its groups' tips (`Chain.tips`); made non-decreasing along the chain. And
    what it changes: the errors are not the steady ones at the same speed."""
    from plantlod.scene.constants import TIP_ERROR_DIRECTIONS
    from plantlod.scene.levels import Gusts, level_chain
    from plantlod.sim.kinematics import pose
    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import GustyWind, KeyframeWind, wind_from_speed

    dt, duration, speed = 0.01, 2.0, 8.0
    gusts = Gusts(0.5, 4)
    chain, _ = level_chain(pathlib.Path(TWIN), speed, dt, duration, chains, gusts=gusts)
    steady, _ = level_chain(pathlib.Path(TWIN), speed, dt, duration, chains)
    steps = int(round(duration / dt))
    times = np.arange(steps) * dt
    worst = np.zeros(len(chain.trees))
    for direction in TIP_ERROR_DIRECTIONS:
        gusty = GustyWind(wind_from_speed(speed, direction), seed=gusts.seed,
                          strength=gusts.strength)
        wind = KeyframeWind(times, gusty.sample(times))
        runs = [simulate_arrays(tree, dt, steps, wind) for tree in chain.trees]
        full = pose(chain.trees[0], runs[0].bend, runs[0].rot).tip
        for level in range(1, len(chain.trees)):
            tips = pose(chain.trees[level], runs[level].bend, runs[level].rot).tip
            gap = np.linalg.norm(tips - full[:, chain.tips[level]], axis=-1).max()
            worst[level] = max(worst[level], gap)
    # (the original's tips are kept as float32 moves from rest: about 1e-7 m of rounding)
    np.testing.assert_allclose(chain.tip_error_m, np.maximum.accumulate(worst), rtol=0, atol=1e-7)
    assert not np.allclose(chain.tip_error_m, steady.tip_error_m, rtol=0.01)


def test_a_gusty_scenes_report_names_the_wind_its_levels_were_measured_in(tmp_path, chains):
    """The report's level wind: a steady scene's strongest wind and no gusts; a gusty one's
    own speed and gusts (not the strongest gust), so its chains can be looked up again."""
    steady = json.loads(run_cli("scene", _scene(tmp_path, BASE), "--cache", str(chains)).stdout)
    assert steady["level_wind_speed"] == 5.0 and steady["level_wind_gusts"] is None
    body = BASE.replace("speed = 5\n", "speed = 5\ngust_strength = 0.4\ngust_seed = 7\n")
    gusty = json.loads(run_cli("scene", _scene(tmp_path, body), "--cache", str(chains)).stdout)
    assert gusty["level_wind_speed"] == 5.0
    assert gusty["level_wind_gusts"] == {"strength": 0.4, "seed": 7}


def test_a_cached_chain_reads_its_built_levels_as_its_texts_give_them(tmp_path):
    """The levels kept built in the cache (KEY.trees.zip) are the trees the level texts
    build, field by field; a damaged archive is read past (the texts again) and rewritten."""
    import dataclasses

    from plantlod.scene.levels import level_chain

    cache = tmp_path / "cache"
    first, hit = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 1.0, cache)
    assert not hit
    (archive,) = cache.glob("*.trees.zip")
    again, hit = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 1.0, cache)
    assert hit and len(again.trees) == len(first.trees) > 2

    def same(a, b) -> bool:
        for f in dataclasses.fields(a):
            if not f.compare:              # group_line: where a text put each group
                continue
            x, y = getattr(a, f.name), getattr(b, f.name)
            if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
                if x is None or y is None or not np.array_equal(x, y):
                    return False
            elif x != y:
                return False
        return True

    assert all(same(a, b) for a, b in zip(first.trees, again.trees))
    assert all(np.array_equal(a, b) for a, b in zip(first.groups, again.groups))
    archive.write_bytes(archive.read_bytes()[:100])            # damaged
    third, hit = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 1.0, cache)
    assert hit and all(same(a, b) for a, b in zip(first.trees, third.trees))
    assert len(archive.read_bytes()) > 100                     # written again
    # a level archive whose compressed data is damaged (zlib's error was an internal error,
    # session 28's fuzzing) is read past as well
    import io
    import zipfile

    from plantlod.formats.npz import tree_bytes

    member = io.BytesIO()
    with zipfile.ZipFile(member, "w", zipfile.ZIP_DEFLATED) as z:
        with zipfile.ZipFile(io.BytesIO(tree_bytes(first.trees[1]))) as plain:
            for name in plain.namelist():
                z.writestr(name, plain.read(name))
    import zlib

    good = member.getvalue()
    with zipfile.ZipFile(io.BytesIO(good)) as z:
        info = z.getinfo("length.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    for at in range(start, start + info.compress_size - 2):   # the first flip zlib refuses
        damaged = bytearray(good)
        damaged[at:at + 3] = bytes(b ^ 0xFF for b in damaged[at:at + 3])
        try:
            with zipfile.ZipFile(io.BytesIO(bytes(damaged))) as z:
                z.read("length.npy")
        except zlib.error:
            break
        except zipfile.BadZipFile:
            continue
    else:
        raise AssertionError("no flip made zlib refuse the data")
    out = io.BytesIO()
    with zipfile.ZipFile(archive) as old, zipfile.ZipFile(out, "w") as new:
        new.comment = old.comment
        for name in old.namelist():
            new.writestr(name, bytes(damaged) if name == "level1.npz" else old.read(name))
    archive.write_bytes(out.getvalue())
    fourth, hit = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 1.0, cache)
    assert hit and all(same(a, b) for a, b in zip(first.trees, fourth.trees))
    assert not [p for p in cache.iterdir() if p.name.startswith(".plantlod-")]


def test_a_damaged_cache_entry_is_a_miss_fitted_again(tmp_path):
    """A cache entry (KEY.json) that is not one the scene wrote whole (not JSON, another
    shape, tip errors that no fit gives, a level text that no longer reads) is a miss, not
    an error: the chain is fitted again, equal to the first, and the entry written anew."""
    from plantlod.scene.levels import level_chain

    cache = tmp_path / "cache"
    first, _ = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    (entry,) = cache.glob("*.json")
    good = json.loads(entry.read_text())
    archive = entry.with_suffix(".trees.zip")                  # (removed: the texts are read)
    damaged = ["", "[1, 2]", "null", '{"levels": "abc"}', json.dumps(good)[:200],
               json.dumps({**good, "tip_error_m": good["tip_error_m"][:1]}),
               json.dumps({**good, "tip_error_m": [0.0] + [-1.0] * len(good["levels"])}),
               json.dumps({**good, "tip_error_m": [0.0] + [10 ** 400] * len(good["levels"])}),
               json.dumps({**good, "levels": ["axiom: {"] + good["levels"][1:]}),
               # NaN tip errors were a hit, a nesting 10^5 deep an error naming no file
               json.dumps({**good, "tip_error_m": [0.0] + [math.nan] * len(good["levels"])}),
               "[" * 100_000 + "]" * 100_000]
    for text in damaged:
        archive.unlink()
        entry.write_text(text)
        again, hit = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
        assert not hit, text
        assert again.texts == first.texts and np.array_equal(again.tip_error_m, first.tip_error_m)
        assert json.loads(entry.read_text()) == good              # written again, whole
    assert level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)[1]


def test_a_cache_entry_that_is_no_file_or_whose_texts_changed_is_a_miss(tmp_path):
    """An entry that is a FIFO (a hang) or /dev/zero (24 GB read) is never opened, and a
    level text changed beside a good archive is read, not passed over for the archive: each
    is a miss, fitted again (session 23, found by fuzzing)."""
    from plantlod.scene.levels import level_chain

    cache = tmp_path / "cache"
    first, _ = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    (entry,) = cache.glob("*.json")
    good = entry.read_text()
    for make in (lambda: os.mkfifo(entry), lambda: entry.symlink_to("/dev/zero")):
        entry.unlink()
        make()
        again, hit = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
        assert not hit and again.texts == first.texts
        assert entry.is_file() and entry.read_text() == good        # written again, whole
    stored = json.loads(good)
    entry.write_text(json.dumps({**stored, "levels": ["garbage {"] + stored["levels"][1:]}))
    again, hit = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    assert not hit and again.texts == first.texts and entry.read_text() == good


def test_a_cache_entry_that_is_a_folder_is_a_miss_and_left(tmp_path):
    """A folder where KEY.json goes was exit 1, "Is a directory", after the chain was fitted
    (session 30, found by fuzzing): it is a miss, the chain fitted and used, the folder left
    as it is (nothing the scene wrote) and the entry not kept."""
    from plantlod.scene.levels import level_chain

    cache = tmp_path / "cache"
    first, _ = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    (entry,) = cache.glob("*.json")
    entry.unlink()
    entry.mkdir()
    (entry / "mine").write_text("x")
    again, hit = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    assert not hit and again.texts == first.texts
    assert (entry / "mine").read_text() == "x"


def test_a_cache_archive_whose_members_were_swapped_is_read_past(tmp_path):
    """The archive's comment is a digest of the level texts and of its members: members
    swapped by hand, the comment kept, ran a 4-branch tree as level 3 (session 30)."""
    import zipfile

    from plantlod.scene.levels import level_chain

    cache = tmp_path / "cache"
    first, _ = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    (archive,) = cache.glob("*.trees.zip")
    with zipfile.ZipFile(archive) as old:
        names, comment = old.namelist(), old.comment
        members = [old.read(n) for n in names]
    assert len(names) >= 3
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_STORED) as new:
        new.comment = comment
        for name, data in zip(names, [members[2], members[1], members[0], *members[3:]]):
            new.writestr(name, data)
    again, hit = level_chain(pathlib.Path(STALK), 5.0, 0.01, 1.0, cache)
    assert hit and [t.n_branches for t in again.trees] == [t.n_branches for t in first.trees]
    with zipfile.ZipFile(archive) as rewritten:            # written again from the texts
        assert rewritten.read(names[0]) == members[0]


def test_a_cache_entry_of_more_than_a_million_bytes_is_a_hit(tmp_path):
    """A tree of about 1,000 branches writes an entry over 1 MB on one line (json.dumps): the
    entry was read with the 1,000,000-byte line cap of other text, so it was always a miss
    and the chain fitted anew every run (session 23, found in review)."""
    from plantlod.scene.levels import _stored_entry

    entry = tmp_path / "key.json"
    texts = ["# level\n" + "x" * 1_200_000, "# level 2\n"]
    entry.write_text(json.dumps({"file": "t.lsys", "levels": texts, "tip_error_m": [0.0, 0.1, 0.2]}))
    assert entry.stat().st_size > 1_200_000 and entry.read_text().count("\n") == 0
    stored = _stored_entry(entry)
    assert stored is not None and stored[0] == texts


def test_a_worker_reads_each_chain_once(tmp_path, chains):
    """`chain_from_texts` (what a Dask worker's batch calls) reads a chain once per process:
    the second batch of the same file gets the same chain, equal to the one read from the
    cache; another file's texts get their own."""
    from plantlod.scene.levels import _remembered_chain, chain_from_texts, level_chain

    chain, _ = level_chain(pathlib.Path(TWIN), 5.0, 0.01, 2.0, chains)
    _remembered_chain.cache_clear()
    first = chain_from_texts(TWIN, chain.texts, chain.tip_error_m)
    again = chain_from_texts(TWIN, list(chain.texts), chain.tip_error_m.tolist())
    assert again is first and _remembered_chain.cache_info().hits == 1
    assert [t.n_branches for t in first.trees] == [t.n_branches for t in chain.trees]
    for a, b in zip(first.groups, chain.groups):
        np.testing.assert_array_equal(a, b)
    other = chain_from_texts(TWIN, chain.texts[:-1], chain.tip_error_m[:-1])
    assert other is not first and len(other.trees) == len(first.trees) - 1


@pytest.mark.parametrize("budget", ["0.2", "0.5"])
def test_a_verified_error_above_the_budget_is_warned_of(tmp_path, chains, budget):
    """`--verify` printed a max error above the budget (0.231 px at 0.2 px) without a word
    (session 25, a scene user's first hour). The warning is there exactly when the report's
    figure is above the budget."""
    path = _keyed_scene(tmp_path, [(0.0, -150.0), (3.0, -22.0)], duration=3.0,
                        budget_px=float(budget)).source
    assert path.endswith("keyed.toml")
    result = run_cli("scene", path, "--cache", str(chains), "--verify")
    report = json.loads(result.stdout)
    above = report["max_error_px"] > report["budget_px"]
    assert ("is above the budget of" in result.stderr) == above, (report["max_error_px"], budget)


def test_a_scene_without_wind_is_warned_of(tmp_path):
    """A scene without [wind] is a still forest: it ran without a word (session 25)."""
    body = BASE.replace("[wind]\nspeed = 5\n", "").split("[scatter]")[0]
    assert "[wind]" not in body and "[[tree]]" in body
    result = run_cli("scene", _scene(tmp_path, body), "--no-cache")
    assert "warning: the wind is zero, so the trees stay at rest" in result.stderr
    assert "warning" not in run_cli("scene", _scene(tmp_path, BASE.split("[scatter]")[0], "w.toml"),
                                    "--no-cache").stderr


def test_verify_measures_each_row_at_its_frame_s_end(tmp_path, monkeypatch):
    """The teleport of `test_a_camera_jumping_nearer_within_a_frame_is_judged_at_the_frame_s_end`
    run whole with one stalk: with the schedule judging frames at their start (the rule before
    session 43, restored here), --verify must find the frame shown near at the far level, over
    the 1 px budget (it measured at the start too, and said 0.51 px; a scene fuzzing round);
    with frames judged at both ends, the scene is within it."""
    import plantlod.scene.schedule as schedule
    from plantlod.scene.run import run_scene

    body = ("dt = 0.01\nduration = 10\n[wind]\nspeed = 5\n[camera]\n" + "".join(
        f"[[camera.key]]\nt = {t}\nposition = [0, {y}, 1.7]\ntarget = [0, 0, 1.7]\n"
        for t, y in ((0, -300), (5, -300), (5.001, -5), (10, -5)))
        + f'[[tree]]\nfile = "{STALK}"\nposition = [0, 0, 0]\n')
    scene = read_scene(_scene(tmp_path, body, "jump.toml"))
    cache = tmp_path / "cache"
    assert run_scene(scene, cache=cache, verify=True)["max_error_px"] <= 1.0
    monkeypatch.setattr(schedule, "seen_scale", _seen_at_starts)
    assert run_scene(scene, cache=cache, verify=True)["max_error_px"] > 2.0


def test_a_scene_far_below_its_bound_says_why(tmp_path, chains):
    """A camera driving from 60 m up to two trees: they start finer than 60 m needs, since
    the switches the drive would make later overspend (docs/scene.md, "Switching"), and the
    scene ran at a fraction of its speedup_bound with no word of why (a newcomer's first
    hour: 1.0x against 1.74x). A scene within HELD_NOTE_RATIO of its bound says nothing."""
    from plantlod.scene.constants import HELD_NOTE_RATIO

    keys = "".join(f"[[camera.key]]\nt = {t}\nposition = [0, {y}, 1.6]\ntarget = [0, 0, 1.6]\n"
                   for t, y in ((0, -60), (8, -4)))
    body = (f"dt = 0.01\nduration = 8\n[wind]\nspeed = 5\ndirection = 45\n[camera]\n"
            f"fov_deg = 50\n{keys}[[tree]]\nfile = \"{STALK}\"\nposition = [-2, 0, 0]\n"
            f"[[tree]]\nfile = \"{TWIN}\"\nposition = [2, 3, 0]\nheading = 40\n")
    result = run_cli("scene", _scene(tmp_path, body, "drive.toml"), "--cache", str(chains))
    report = json.loads(result.stdout)
    assert report["speedup"] < HELD_NOTE_RATIO * report["speedup_bound"]
    notes = [x for x in result.stderr.splitlines() if "if switching were free" in x]
    assert notes == [f"scene: {report['speedup_bound']:.1f}x if switching were free "
                     "(speedup_bound): trees start or stay finer than their distance needs "
                     "where a later switch to a finer level would overspend the budget "
                     "(docs/scene.md, \"Switching\")"]
    plain = run_cli("scene", _scene(tmp_path, BASE), "--cache", str(chains))
    report = json.loads(plain.stdout)
    assert report["speedup"] >= HELD_NOTE_RATIO * report["speedup_bound"]
    assert "if switching were free" not in plain.stderr



def _seen_at_starts(scene, members, times, look_ahead=False):
    """`schedule.seen_scale` under the rule before session 43: each frame judged at its start
    alone (model.md 7's pixels per metre at that distance, 0 behind the camera)."""
    from plantlod.scene.schedule import distances

    d, ahead = distances(scene, members, times)
    scale = np.array([scene.trees[k].scale for k in members])[:, None]
    seen = np.where(ahead | (d == 0.0), scene.camera.pixels_per_metre(d), 0.0) * scale
    return np.maximum.accumulate(seen[:, ::-1], axis=1)[:, ::-1] if look_ahead else seen
