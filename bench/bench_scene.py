"""The forest (examples/forest.toml, 1,000 trees): speedup, verified error, wall time against
full detail, and full detail's throughput on 2 cores against 1; the same forest seen from a
moving camera (examples/forest_walk.toml: levels switch per frame); and 10,000 trees
(examples/forest10k.toml): peak memory and simulated seconds per wall second.

    .venv/bin/python bench/run.py scene        (level chains cached in ~/.cache/plantlod)
"""

from __future__ import annotations

import dataclasses
import json
import pathlib
import sys
import time

from peak_memory import run_with_peak

ROOT = pathlib.Path(__file__).resolve().parents[1]
COMMAND = "plantlod scene examples/forest.toml --verify --report -"


def run(report) -> None:
    from plantlod.scene.file import read_scene
    from plantlod.scene.levels import default_cache
    from plantlod.scene.run import run_scene

    scene = read_scene(str(ROOT / "examples" / "forest.toml"))
    run_scene(dataclasses.replace(scene, duration=0.05), cache=default_cache())   # fill the cache
    doc = run_scene(scene, cache=default_cache(), verify=True)
    report("forest: speedup (branch-steps full / spent)", doc["speedup"], "x", ">= 20", COMMAND)
    report("forest: verified max error", doc["max_error_px"], "px", "<= 1", COMMAND)
    report("forest: speedup_bound", doc["speedup_bound"], "x", "", COMMAND)
    report("forest: simulated s per wall s (at its levels)", doc["simulated_seconds_per_wall_second"],
           "s/s", "> 1", COMMAND)
    # full detail: every tree at level 0 (a budget no level meets), on 1 core and on 2
    full = dataclasses.replace(scene, budget_px=1e-12)
    times = {}
    for threads in (1, 2):
        begin = time.perf_counter()
        run_scene(full, cache=default_cache(), threads=threads)
        times[threads] = time.perf_counter() - begin
    begin = time.perf_counter()
    plain = run_scene(scene, cache=default_cache())
    levels_wall = time.perf_counter() - begin
    report("forest: full detail wall s (2 cores)", times[2], "s", "", COMMAND + " --budget 1e-12")
    report("forest: levels wall s (cached chains, no --verify)", levels_wall, "s", "",
           COMMAND.replace(" --verify", ""))
    report("forest: full detail wall s / levels wall s", times[2] / levels_wall, "x", "",
           COMMAND.replace(" --verify", ""))
    report("forest: simulation alone, full detail / levels",
           times[2] / (plain["duration"] / plain["simulated_seconds_per_wall_second"]), "x", "",
           COMMAND.replace(" --verify", ""))
    report("forest: full detail 2 cores / 1 core", times[1] / times[2], "x", ">= 1.7",
           COMMAND + " --budget 1e-12 --threads 1|2")

    walk = read_scene(str(ROOT / "examples" / "forest_walk.toml"))
    doc = run_scene(walk, cache=default_cache(), verify=True)
    command = "plantlod scene examples/forest_walk.toml --verify --report -"
    report("forest, moving camera: speedup", doc["speedup"], "x", ">= 20", command)
    report("forest, moving camera: verified max error", doc["max_error_px"], "px", "<= 1", command)
    report("forest, moving camera: verified mean error", doc["mean_error_px"], "px", "", command)
    report("forest, moving camera: level switches", doc["switches"], "", "", command)
    report("forest, moving camera: speedup_bound (coarsest level per frame, switching free)",
           doc["speedup_bound"], "x", "", command)
    report("forest, moving camera: speedup / speedup_bound", doc["speedup"] / doc["speedup_bound"],
           "", ">= 0.8", command)
    # 10,000 trees in a process of its own, for its peak memory (VmHWM, bench/peak_memory.py)
    command = ("plantlod scene examples/forest10k.toml --verify --verify-sample 100 --report - "
               "--run-info")
    stdout, _, _, peak_mb = run_with_peak([str(pathlib.Path(sys.executable).with_name("plantlod")),
                                           "scene", str(ROOT / "examples" / "forest10k.toml"),
                                           "--verify", "--verify-sample", "100", "--report", "-",
                                           "--run-info"])
    doc = json.loads(stdout)
    doc.update(doc.pop("run"))
    report("forest 10,000 trees: peak memory", peak_mb / 1024, "GiB", "<= 8", command)
    report("forest 10,000 trees: simulated s per wall s", doc["simulated_seconds_per_wall_second"],
           "s/s", "> 1", command)
    report("forest 10,000 trees: wall s (levels cached)", doc["wall_s"], "s", "", command)
    report("forest 10,000 trees: speedup", doc["speedup"], "x", "", command)
    report("forest 10,000 trees: speedup_bound", doc["speedup_bound"], "x", "", command)
    report("forest 10,000 trees: verified max error over the sample", doc["max_error_px"], "px",
           "<= 1", command)
    report("forest 10,000 trees: trees verified (stratified sample)", doc["verified_trees"], "",
           "", command)
    _scene_reading(report)


def _scene_reading(report) -> None:
    """Reading a scene of 20,000 [[tree]] entries (each its own table): linear in the entries
    since session 43 (49 s before, 1.1 s after, a fuzzing round's finding)."""
    import tempfile

    from plantlod.scene.file import read_scene

    count = 20_000
    body = ("dt = 0.01\nduration = 1\n\n[camera]\nposition = [0, -20, 1.7]\ntarget = [0, 0, 1.7]"
            "\n\n[wind]\nspeed = 5\n")
    body += "".join(f"\n[[tree]]\nfile = \"{ROOT / 'examples' / 'stalk8.lsys'}\"\n"
                    f"position = [{k % 200}, {k // 200}, 0]\n" for k in range(count))
    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / "trees.toml"
        path.write_text(body)
        begin = time.perf_counter()
        read_scene(str(path))
        wall = time.perf_counter() - begin
    report(f"scene file of {count:,} [[tree]] tables: read", wall, "s", "",
           "read_scene on a generated file (bench/bench_scene.py _scene_reading)")
