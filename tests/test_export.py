"""plantlod export: glTF and OpenUSD files read back, their transforms composed here (not by
the exporter's code), put every branch tip where the model's pose puts it; glTF passes the
Khronos validator."""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import plantlod
from golden_util import ROOT, run_cli
from plantlod.sim.kinematics import pose

FPS = 30.0


def _quat_matrix(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    tree = plantlod.derive(plantlod.read_lsystem(ROOT / "examples" / "abop_2_6.lsys"), 5)
    angles = plantlod.simulate(tree, wind=(9.0, 2.0, 0.0), dt=0.01, steps=150)
    plantlod.write_tree(tree, folder / "t.jsonl")
    plantlod.write_angles(angles, folder / "a.csv")
    for ext in ("glb", "usda"):
        run_cli("export", str(folder / "t.jsonl"), str(folder / "a.csv"), "-o", str(folder / f"t.{ext}"))
    return folder, tree, angles


def _expected_tips(tree, angles, k):
    """The model's tips at frame k: angles interpolated linearly to t = k / FPS (as the file's
    frames are resampled from the run's samples), posed by the model."""
    t = k / FPS
    bend = np.array([np.interp(t, angles.time, angles.bend[:, b]) for b in range(tree.n_branches)])
    rot = np.array([np.interp(t, angles.time, angles.rotation[:, b]) for b in range(tree.n_branches)])
    return pose(tree, bend, rot).tip


def _gltf_tips(path, tree, k):
    """Tips (B, 3) at frame k of a .glb, its node transforms composed here (Y up)."""
    import pygltflib

    doc = pygltflib.GLTF2().load(str(path))
    blob = doc.binary_blob()

    def read(accessor):
        acc = doc.accessors[accessor]
        view = doc.bufferViews[acc.bufferView]
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc.type]
        return np.frombuffer(blob, np.float32, acc.count * width, view.byteOffset).reshape(acc.count, -1)

    animated = {}
    for ch in doc.animations[0].channels:
        sampler = doc.animations[0].samplers[ch.sampler]
        animated[ch.target.node] = read(sampler.output)
    world = {}

    def walk(n, m, t):
        node = doc.nodes[n]
        q = animated[n][k] if n in animated else (node.rotation or [0, 0, 0, 1])
        r_local = _quat_matrix(np.asarray(q, dtype=np.float64))
        t_world = t + m @ np.asarray(node.translation or [0, 0, 0], dtype=np.float64)
        m_world = m @ r_local
        world[n] = (m_world, t_world)
        for c in node.children or []:
            walk(c, m_world, t_world)

    walk(0, np.eye(3), np.zeros(3))
    names = {doc.nodes[n].name: n for n in world}
    return np.array([world[names[a]][1] + world[names[a]][0] @ [0, 0, tree.length[i]]
                     for i, a in enumerate(tree.address)])


def _y_up(model):
    return np.stack([model[:, 0], model[:, 2], -model[:, 1]], axis=1)   # Z up -> Y up


def test_gltf_tips_follow_the_model(run):
    folder, tree, angles = run
    for k in (0, 17, 45):
        tips = _gltf_tips(folder / "t.glb", tree, k)
        np.testing.assert_allclose(tips, _y_up(_expected_tips(tree, angles, k)), atol=1e-5)


def test_a_level_file_exports_the_same_way(tmp_path):
    """A simplified tree (explicit form: chords as rest geometry, groups) is a TREE like any."""
    system = plantlod.read_lsystem(ROOT / "examples" / "stalk8.lsys")
    level = plantlod.simplify(system, level=1, form="explicit", duration=5.0)
    plantlod.write_lsystem(level, tmp_path / "level1.lsys")
    tree = plantlod.derive(level)
    angles = plantlod.simulate(tree, wind=(0.0, 7.0, 0.0), dt=0.01, steps=200)
    plantlod.write_angles(angles, tmp_path / "level1.csv")
    run_cli("export", str(tmp_path / "level1.lsys"), str(tmp_path / "level1.csv"), "-o",
            str(tmp_path / "level1.glb"))
    assert tree.n_branches == 4
    for k in (0, 30, 60):
        tips = _gltf_tips(tmp_path / "level1.glb", tree, k)
        np.testing.assert_allclose(tips, _y_up(_expected_tips(tree, angles, k)), atol=1e-5)


def test_usd_tips_follow_the_model(run):
    from pxr import Usd, UsdGeom

    folder, tree, angles = run
    stage = Usd.Stage.Open(str(folder / "t.usda"))
    assert UsdGeom.GetStageUpAxis(stage) == "Z" and stage.GetTimeCodesPerSecond() == FPS
    cache_tips = {}
    for k in (0, 30):
        cache = UsdGeom.XformCache(Usd.TimeCode(k))
        for prim in stage.Traverse():
            if prim.GetTypeName() == "Xform" and prim.HasAttribute("plantlod:address"):
                address = prim.GetAttribute("plantlod:address").Get()
                m = np.array(cache.GetLocalToWorldTransform(prim))          # row-vector convention
                i = tree.address.index(address)
                cache_tips[address] = np.array([0, 0, tree.length[i], 1.0]) @ m
        tips = np.array([cache_tips[a][:3] for a in tree.address])
        np.testing.assert_allclose(tips, _expected_tips(tree, angles, k), atol=1e-5)


def test_gltf_passes_the_khronos_validator(run, tmp_path):
    folder, _, _ = run
    if not shutil.which("node") or not shutil.which("npm"):
        pytest.skip("node/npm not installed: the glTF validator (npm gltf-validator) cannot run")
    cache = pathlib.Path(os.environ.get("XDG_CACHE_HOME", pathlib.Path.home() / ".cache")) / "plantlod-test"
    module = cache / "node_modules" / "gltf-validator"
    if not module.is_dir():
        cache.mkdir(parents=True, exist_ok=True)
        done = subprocess.run(["npm", "install", "--silent", "--prefix", str(cache),
                               "gltf-validator@2.0.0-dev.3.10"], capture_output=True, timeout=300)
        if done.returncode != 0 or not module.is_dir():
            pytest.skip("npm could not install gltf-validator into " + str(cache))
    script = tmp_path / "validate.js"
    script.write_text(
        "const v = require(process.argv[2]); const fs = require('fs');\n"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[3])))"
        ".then(r => console.log(JSON.stringify(r.issues)));\n")
    for name in ("t.glb",):
        out = subprocess.run(["node", str(script), str(module), str(folder / name)],
                             capture_output=True, text=True, timeout=120, check=True)
        issues = json.loads(out.stdout)
        assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"][:5]


def test_unknown_extension_is_exit_2(run, tmp_path):
    folder, _, _ = run
    result = run_cli("export", str(folder / "t.jsonl"), str(folder / "a.csv"), "-o",
                     str(tmp_path / "x.fbx"), exit_code=2)
    assert "cannot tell the format" in result.stderr and not (tmp_path / "x.fbx").exists()
    assert "compare --obj" not in result.stderr
    # an OBJ is compare's (a new user's, session 33)
    result = run_cli("export", str(folder / "t.jsonl"), str(folder / "a.csv"), "-o",
                     str(tmp_path / "x.obj"), exit_code=2)
    assert result.stderr.rstrip().endswith("(OBJ frames of a tree: `plantlod compare --obj`)")


def test_frames_outside_the_run_and_a_missing_folder_are_exit_2(run, tmp_path):
    folder, _, _ = run
    args = ["export", str(folder / "t.jsonl"), str(folder / "a.csv")]
    result = run_cli(*args, "-o", str(tmp_path / "x.glb"), "--frames", "100:200", exit_code=2)
    assert "outside the run's 46 frames" in result.stderr and not (tmp_path / "x.glb").exists()
    result = run_cli(*args, "-o", str(tmp_path / "no" / "x.glb"), exit_code=2)
    assert "output directory does not exist" in result.stderr
    assert not list(tmp_path.glob(".plantlod-*"))


@pytest.mark.parametrize("old, new", [('"length": 0.6', '"length": 1e308'),
                                      ('"offset": [0.0, 0.0, 0.0]', '"offset": [1e308, 0.0, 0.0]')])
def test_a_tree_past_the_measured_extent_is_refused_as_compare_refuses_it(run, tmp_path, old,
                                                                         new):
    """Lengths or offsets of 1e308 m were written as glTF translations of 1e308 (infinite in
    its float32), exit 0, where compare and scene refuse the tree (session 36, fuzzing)."""
    folder, _, _ = run
    lines = (folder / "t.jsonl").read_text().splitlines(keepends=True)
    assert old in lines[1]
    edited = tmp_path / "t.jsonl"
    edited.write_text("".join([lines[0], lines[1].replace(old, new, 1), *lines[2:]]))
    result = run_cli("export", str(edited), str(folder / "a.csv"), "-o", str(tmp_path / "x.glb"),
                     exit_code=2)
    assert result.stderr.startswith(f"{edited}: error: the tree reaches ")
    assert "beyond the 1e+09 m" in result.stderr and result.stderr.count("\n") == 1
    assert not (tmp_path / "x.glb").exists()


@pytest.mark.parametrize("edit, message", [
    (lambda t, a: (t * 1e298, a), "frames than the limit of 10,000,000 frames x branches"),
    (lambda t, a: (t, a * 1e300), "the angles give branch frames that are not finite numbers"),
    (lambda t, a: (t - 100.0, a), "s, before 0 s: frames are at k / fps from 0 s"),   # session 22
])
def test_angles_past_what_an_export_holds_are_bad_input_in_the_angles_file(run, tmp_path, edit,
                                                                           message):
    """Times of 1e298 s made numpy allocate 3e299 frames (an internal error) and angles of
    1e300 rad wrote NaN rotations with exit 0 (session 21, found by fuzzing)."""
    folder, _, _ = run
    lines = (folder / "a.csv").read_text().splitlines()
    rows = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    t, a = edit(rows[:, 0], rows[:, 1:])
    edited = tmp_path / "e.csv"
    edited.write_text("\n".join([lines[0]] + [",".join(repr(float(x)) for x in [ti, *ai])
                                              for ti, ai in zip(t, a)]) + "\n")
    result = run_cli("export", str(folder / "t.jsonl"), str(edited), "-o", str(tmp_path / "x.glb"),
                     exit_code=2)
    assert result.stderr.startswith(f"{edited}: error:") or result.stderr.startswith("e.csv")
    assert message in result.stderr and result.stderr.count("\n") == 1
    assert not (tmp_path / "x.glb").exists()


def test_frame_times_past_float32_are_bad_input_in_the_angles_file(run, tmp_path):
    """A run to 1e39 s at 1e-38 fps wrote glTF times of inf: json's 'Out of range float
    values', an internal error (session 23, found by fuzzing)."""
    folder, _, _ = run
    lines = (folder / "a.csv").read_text().splitlines()
    edited = tmp_path / "e.csv"
    edited.write_text("\n".join([lines[0], lines[1], "1e39," + lines[2].split(",", 1)[1]]) + "\n")
    result = run_cli("export", str(folder / "t.jsonl"), str(edited), "-o", str(tmp_path / "x.glb"),
                     "--fps", "1e-38", exit_code=2)
    assert result.stderr.startswith(f"{edited}: error: the angles run to 1e+39 s, past")
    assert result.stderr.count("\n") == 1 and not (tmp_path / "x.glb").exists()


def test_a_tree_deeper_than_openusd_export_nests_is_refused(tmp_path, monkeypatch):
    # a chain of N branches nested [&F[&F...]]: its .usda grew with N² (4,000 deep: 579 MB;
    # 50,001 deep, which the other commands take, about 90 GB): refused past MAX_USD_DEPTH
    # with exit 2 and no file, while .glb (a flat node list) takes it
    from plantlod.export import constants, files

    depth = 12
    text = ("derivation_length: 1\nbranching_angle: 30\nforce_absorbed: 0.005\n"
            "force_propagated: 0.7\nbranch F: length=1 radius=0.02 bend_strength=20 "
            "rotation_strength=20\naxiom: F" + "[&F" * (depth - 1) + "]" * (depth - 1) + "\n")
    tree = plantlod.derive(text)
    assert tree.depth() == depth
    angles = plantlod.simulate(tree, wind=(5, 0, 0), dt=0.01, steps=5)
    monkeypatch.setattr(files, "MAX_USD_DEPTH", depth - 1)
    for ext in ("usda", "usdc"):
        with pytest.raises(plantlod.InputError, match=f"the tree is {depth} branches deep, "
                                                      f"more than the {depth - 1}"):
            plantlod.export_animation(tree, angles, tmp_path / f"t.{ext}")
    plantlod.export_animation(tree, angles, tmp_path / "t.glb")
    assert sorted(os.listdir(tmp_path)) == ["t.glb"]
    monkeypatch.setattr(files, "MAX_USD_DEPTH", depth)          # at the limit: written
    plantlod.export_animation(tree, angles, tmp_path / "t.usda")
    assert constants.MAX_USD_DEPTH == 2_000


def test_angles_beyond_the_models_range_warn_and_name_degrees(tmp_path):
    """An angle CSV written with `simulate --degrees` and exported without --degrees swings
    57 times too far and the file cannot say its unit (docs/angles-csv.md): export warns
    where a branch tilts beyond 1 rad, as simulate does, and names --degrees (a new user's
    report, session 33). The same run in radians, or read with --degrees, is quiet."""
    stalk = str(ROOT / "examples" / "stalk8.lsys")
    for flag in ("--degrees", ""):
        run_cli("simulate", stalk, "--dt", "0.01", "--duration", "5", "--wind-speed", "8",
                *([flag] if flag else []), "-o", str(tmp_path / f"a{flag}.csv"))
    # the radian run's largest tilt, independently: under 1 rad, above 1/57 of it
    csv = np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1)
    bend, rot = csv[:, 1::2], csv[:, 2::2]
    assert 1 / 57.3 < np.hypot(bend, rot).max() < 1.0
    cases = (("a--degrees.csv", [], True), ("a--degrees.csv", ["--degrees"], False),
             ("a.csv", [], False))
    for name, extra, warned in cases:
        result = run_cli("export", stalk, str(tmp_path / name), *extra, "-o", str(tmp_path / "t.glb"))
        lines = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
        assert len(lines) == warned
        if warned:
            assert "beyond 1 rad" in lines[0] and lines[0].endswith(
                "if the file holds degrees (simulate --degrees), give --degrees")


def test_an_export_of_one_frame_says_it_holds_no_animation(tmp_path):
    """A run shorter than one frame, or --frames A:A+1, wrote a glTF with one pose and no
    animation, said to run "0.01 s at 30 fps" (a scene fuzzing round): now a warning. Two
    frames are an animation, and say nothing."""
    stalk = str(ROOT / "examples" / "stalk8.lsys")
    for steps, frames, warned in ((1, None, "the run, 0.01 s, is shorter than one frame"),
                                  (300, "60:61", "frames 60:61"), (300, "60:62", None)):
        csv = tmp_path / f"a{steps}.csv"
        run_cli("simulate", stalk, "--dt", "0.01", "--steps", str(steps), "--wind-speed", "5",
                "-o", str(csv))
        out = tmp_path / "x.glb"
        result = run_cli("export", stalk, str(csv), "-o", str(out),
                         *(("--frames", frames) if frames else ()))
        doc = json.loads(out.read_bytes()[20:20 + int.from_bytes(out.read_bytes()[12:16],
                                                                   "little")])
        assert bool(doc.get("animations")) == (warned is None)
        lines = [x for x in result.stderr.splitlines() if x.startswith("warning:")]
        assert lines == ([] if warned is None else
                         [f"warning: one frame: {warned} at 30 fps, so the file holds one pose "
                          "and no animation; expected a longer run, a higher fps or more frames"])
