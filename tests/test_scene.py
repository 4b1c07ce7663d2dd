"""plantlod scene (model.md 7): the scene file's checks, the pixel formula and level choice
by hand, the cache, thread-count determinism, and the verified error within the budget."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from golden_util import ROOT, run_cli
from plantlod.lsys.errors import InputError
from plantlod.scene.file import Camera, read_scene
from plantlod.scene.levels import Chain
from plantlod.scene.run import choose_levels, run_scene

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
    chain = Chain(trees=[None] * 4, texts=[""] * 4, tip_error_m=np.array([0.0, 0.001, 0.01, 0.1]), groups=[], tips=[])
    chains = {t.file: chain for t in scene.trees}
    from dataclasses import replace
    ppm10 = float(scene.camera.pixels_per_metre(10.0))          # 93.5 px per metre at 10 m
    trees = [replace(scene.trees[0], position=(0.0, -30.0, 1.7)),   # 10 m ahead
             replace(scene.trees[0], position=(0.0, 0.0, 1.7)),     # 40 m ahead
             replace(scene.trees[0], position=(0.0, -50.0, 1.7)),   # behind
             replace(scene.trees[0], position=(0.0, -40.0, 1.7))]   # at the camera
    scene = replace(scene, trees=trees)
    runs = choose_levels(scene, chains, 1.0)
    # at 10 m: 0.01 m -> 0.935 px <= 1 (level 2), 0.1 m -> 9.35 px; at 40 m: 0.1 m -> 2.3 px
    assert 0.01 * ppm10 <= 1.0 < 0.1 * ppm10 / 4
    assert [r.level for r in runs] == [2, 2, 3, 0]


@pytest.mark.parametrize("body, message", [
    (BASE + "colour = 3\n", "unknown key 'colour'"),
    (BASE.replace("fov_deg = 60", "fov_deg = 200"), "'fov_deg' must be below 180"),
    (BASE.replace("speed = 5", "speed = -1"), "'speed' must be >= 0"),
    (BASE.replace(STALK, "missing.lsys"), "not found"),
    (BASE.replace("target = [0, 0, 1.7]", "target = [0, -40, 1.7]"), "target is its position"),
    ("budget_px = 0\n" + BASE, "'budget_px' is 0"),
    (BASE.replace("count = 12", "count = 5000"), "cannot place"),
    ("dt = [\n", "not valid TOML"),
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
    first = json.loads(run_cli("scene", path, "--verify", "--cache", str(cache)).stdout)
    assert first["trees"] == 13 and first["chains_from_cache"] == 0
    assert first["branch_steps_full"] == 200 * first["branches_full"]
    assert first["speedup"] == pytest.approx(first["branch_steps_full"] / first["branch_steps_spent"])
    assert first["max_error_px"] <= first["budget_px"] + 1e-9           # what --verify measured
    assert sum(first["level_share"].values()) == pytest.approx(1.0)
    second = json.loads(run_cli("scene", path, "--cache", str(cache), "--threads", "1").stdout)
    assert second["chains_from_cache"] == 2                              # nothing simplified again
    for key in ("branch_steps_spent", "level_share", "branches_spent"):
        assert second[key] == first[key]


def test_angles_do_not_depend_on_threads(tmp_path):
    from plantlod.scene.run import tree_winds

    body = BASE.replace("speed = 5", "speed = 5\nfront_speed = 4").replace(
        "[scatter]", f'[[tree]]\nfile = "{STALK}"\nposition = [4, 0, 0]\n[scatter]')
    scene = read_scene(_scene(tmp_path, body))
    w = tree_winds(scene, scene.steps)
    # a front at 4 m/s along +x reaches the tree at x = 4 m after 1 s (100 steps)
    assert scene.trees[1].position[0] == 4.0
    assert np.all(w[1, :100] == 0.0) and np.all(w[1, 101:, 0] == 5.0) and np.all(w[0, :, 0] == 5.0)
    one = run_scene(scene, cache=tmp_path / "c", threads=1)
    two = run_scene(scene, cache=tmp_path / "c", threads=2)
    assert one["branch_steps_spent"] == two["branch_steps_spent"]


def test_angles_store_holds_every_tree_at_its_level(tmp_path):
    import zarr

    from plantlod.scene.levels import level_chain
    from plantlod.scene.run import tree_winds
    from plantlod.sim.run import simulate_arrays
    from plantlod.sim.wind import KeyframeWind

    path = _scene(tmp_path, BASE)
    store = tmp_path / "a.zarr"
    report = json.loads(run_cli("scene", path, "--cache", str(tmp_path / "c"), "--angles",
                                str(store)).stdout)
    group = zarr.open_group(str(store), mode="r")
    levels = group["levels"][:]
    assert len(levels) == report["trees"] and "_levels" not in report
    seen = []
    scene = read_scene(path)
    winds = tree_winds(scene, scene.steps)
    for name in group.group_keys():
        batch = group[name]
        trees = batch["trees"][:].tolist()
        seen += trees
        assert all(levels[k] == batch.attrs["level"] for k in trees)
        # one lane against a single run of that tree in its own wind (model.md 4: step k uses V(t_{k-1}))
        k = trees[0]
        chain, _ = level_chain(scene.trees[k].file, report["level_wind_speed"], scene.dt,
                               scene.duration, tmp_path / "c")
        tree = chain.trees[int(levels[k])]
        times = np.arange(scene.steps) * scene.dt
        single = simulate_arrays(tree, scene.dt, scene.steps, KeyframeWind(times, winds[k]),
                                 every=int(round(1 / (30 * scene.dt))))
        np.testing.assert_array_equal(batch["bend"][0], single.bend[1:].astype(np.float32))
    assert sorted(seen) == list(range(report["trees"]))
    # an existing store is never overwritten
    again = run_cli("scene", path, "--cache", str(tmp_path / "c"), "--angles", str(store), exit_code=2)
    assert "exists" in again.stderr


def test_a_local_dask_cluster_gives_the_same_store(tmp_path):
    """Two worker processes write their own batches; the store equals the in-process one."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    import zarr

    path = _scene(tmp_path, BASE)
    cache = str(tmp_path / "c")
    run_cli("scene", path, "--cache", cache, "--angles", str(tmp_path / "here.zarr"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        far = json.loads(run_cli("scene", path, "--cache", cache, "--angles",
                                 str(tmp_path / "there.zarr"), "--scheduler",
                                 cluster.scheduler_address).stdout)
    here = zarr.open_group(str(tmp_path / "here.zarr"), mode="r")
    there = zarr.open_group(str(tmp_path / "there.zarr"), mode="r")
    assert sorted(here.group_keys()) == sorted(there.group_keys())
    for name in here.group_keys():
        for array in ("bend", "rotation", "trees"):
            np.testing.assert_array_equal(here[name][array][:], there[name][array][:])
    assert np.array_equal(here["levels"][:], there["levels"][:])
    assert far["branch_steps_spent"] < far["branch_steps_full"]


def test_plot_is_a_png_and_refused_before_anything_runs_when_unwritable(tmp_path):
    path = _scene(tmp_path, BASE)
    png = tmp_path / "s.png"
    run_cli("scene", path, "--cache", str(tmp_path / "c"), "--plot", str(png), "--report",
            str(tmp_path / "r.json"))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = run_cli("scene", path, "--cache", str(tmp_path / "c"), "--plot",
                  str(tmp_path / "no" / "such" / "dir" / "s.png"), exit_code=None)
    assert bad.exit_code in (1, 2) and len(bad.stderr.strip().splitlines()) >= 1
