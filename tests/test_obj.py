"""OBJ meshes of posed trees (export/obj.py) and `plantlod compare --obj`.

Vertex positions are checked against kinematics worked out by hand (a straight
stalk at rest, one bent branch), and the written files are read back with
trimesh.
"""

from __future__ import annotations

import math
import pathlib
import shutil

import numpy as np
import pytest

from plantlod.cli.main import cli
from plantlod.export.obj import (
    OBJ_LAYOUT_MARGIN, OBJ_SIDES, OBJ_TIP_TAPER, Mesh, obj_text, rest_layout, top_radius, tree_mesh,
)
from treegen import make_tree, stalk

ROOT = pathlib.Path(__file__).resolve().parent.parent
S = OBJ_SIDES


def rings(mesh: Mesh, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Base and top ring vertices (S, 3) of branch i (layout of export/obj.py)."""
    v = mesh.vertices[2 * S * i: 2 * S * (i + 1)]
    return v[:S], v[S:]


def test_straight_stalk_at_rest_lies_on_known_circles():
    tree = stalk(3, length=1.5, radius=0.02, leaf_area=0.04)
    mesh = tree_mesh(tree, np.zeros(3), np.zeros(3))
    assert mesh.vertices.shape == (3 * 2 * S + 4, 3) and mesh.faces.shape == (3 * 2 * S + 2, 3)
    for i in range(3):
        base, top = rings(mesh, i)
        top_r = 0.02 if i < 2 else 0.02 * OBJ_TIP_TAPER          # the top branch narrows
        np.testing.assert_allclose(np.hypot(base[:, 0], base[:, 1]), 0.02, rtol=1e-12)
        np.testing.assert_allclose(np.hypot(top[:, 0], top[:, 1]), top_r, rtol=1e-12)
        np.testing.assert_allclose(base[:, 2], 1.5 * i, atol=1e-12)
        np.testing.assert_allclose(top[:, 2], 1.5 * (i + 1), atol=1e-12)
        # vertex j at angle 2 pi j / S from the branch's x axis (world x at rest)
        angles = np.arctan2(base[:, 1], base[:, 0]) % (2 * math.pi)
        np.testing.assert_allclose(angles, 2 * math.pi * np.arange(S) / S, atol=1e-12)
    # the leaf: a 0.2 m square with normal e_x (its plane x = 0) standing on the top tip
    leaf = mesh.vertices[-4:]
    np.testing.assert_allclose(leaf, [[0, 0.1, 4.5], [0, -0.1, 4.5], [0, -0.1, 4.7], [0, 0.1, 4.7]],
                               atol=1e-12)


def test_one_bent_branch_tip_and_leaf_by_hand():
    theta, length = 0.3, 2.0
    tree = make_tree([-1], length=length, radius=0.05, leaf_branch=[0], leaf_area=0.01,
                     leaf_normal=[[1.0, 0.0, 0.0]])
    mesh = tree_mesh(tree, np.array([theta]), np.array([0.0]))
    base, top = rings(mesh, 0)
    tip = np.array([length * math.sin(theta), 0.0, length * math.cos(theta)])
    axis = tip / length
    np.testing.assert_allclose(top.mean(axis=0), tip, atol=1e-12)        # ring centred on the tip
    np.testing.assert_allclose(base.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose((top - tip) @ axis, 0.0, atol=1e-12)       # ring across the axis
    np.testing.assert_allclose(np.linalg.norm(top - tip, axis=1), 0.05 * OBJ_TIP_TAPER, rtol=1e-12)
    # ring vertex 0 lies along the bent branch's x axis (cos t, 0, -sin t)
    np.testing.assert_allclose(base[0], 0.05 * np.array([math.cos(theta), 0, -math.sin(theta)]),
                               atol=1e-12)
    # the leaf (area 0.01: a 0.1 m square) turns with the branch: normal (cos t, 0, -sin t)
    leaf = mesh.vertices[-4:]
    normal = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    np.testing.assert_allclose((leaf - tip) @ normal, 0.0, atol=1e-12)
    area = 0.0
    for face in mesh.faces[-2:]:
        a, b, c = mesh.vertices[face]
        n = np.cross(b - a, c - a)
        area += np.linalg.norm(n) / 2
        assert n @ normal > 0                                               # wound along the normal
    assert area == pytest.approx(0.01, rel=1e-12)


def test_tube_faces_point_outward():
    tree = stalk(2)
    mesh = tree_mesh(tree, np.array([0.2, -0.1]), np.array([0.05, 0.3]))
    from plantlod.sim.kinematics import pose
    posed = pose(tree, np.array([0.2, -0.1]), np.array([0.05, 0.3]))
    for f, face in enumerate(mesh.faces[: 2 * S * 2]):
        i = f // (2 * S)
        a, b, c = mesh.vertices[face]
        n = np.cross(b - a, c - a)
        centre = (a + b + c) / 3
        axis = posed.tip[i] - posed.base[i]
        radial = centre - posed.base[i] - ((centre - posed.base[i]) @ axis) / (axis @ axis) * axis
        assert n @ radial > 0


def test_top_radius_follows_the_widest_child():
    # branch 0 (r 0.1) has children of radius 0.04 and 0.06; branch 1 (r 0.04) has a child of
    # radius 0.08, wider than itself; branches 2 and 3 have no children
    tree = make_tree([-1, 0, 0, 1], radius=np.array([0.1, 0.04, 0.06, 0.08]))
    np.testing.assert_allclose(top_radius(tree), [0.06, 0.04, 0.06 * OBJ_TIP_TAPER, 0.08 * OBJ_TIP_TAPER])


def test_side_by_side_layout():
    a, b = stalk(2), stalk(1, length=2.0, radius=0.05)
    offsets = rest_layout([a, b], [2.0, 2.0])
    # a spans x in [-0.02, 0.02] (and its leaf, in the plane x = 0); b's rest mesh starts
    # at x = -0.05: moved so that it starts OBJ_LAYOUT_MARGIN * 2 m to the right of 0.02
    assert offsets[0] == 0.0
    assert offsets[1] == pytest.approx(0.02 + OBJ_LAYOUT_MARGIN * 2.0 + 0.05, abs=1e-12)


def test_obj_text_is_deterministic_and_has_no_negative_zero():
    tree = stalk(2)
    mesh = tree_mesh(tree, np.array([0.0, 0.0]), np.array([0.0, 0.0]), "original")
    other = Mesh("simplified_1", mesh.vertices, mesh.faces).moved(1.0)
    text = obj_text([mesh, other])
    assert text == obj_text([mesh, other])
    assert "-0.000000" not in text and "vn" not in text and "#" not in text
    assert [line for line in text.splitlines() if line.startswith("o ")] == ["o original", "o simplified_1"]
    with pytest.raises(ValueError, match="unique"):
        obj_text([mesh, mesh])


@pytest.fixture
def stalks(tmp_path, monkeypatch):
    from test_compare_cli import STALK8_LEVEL1

    shutil.copy(ROOT / "examples" / "stalk8.lsys", tmp_path / "stalk8.lsys")
    (tmp_path / "l1.lsys").write_text(STALK8_LEVEL1)
    (tmp_path / "l2.lsys").write_text(STALK8_LEVEL1.replace("derivation_length: 2", "derivation_length: 1")
                                      .replace("length=2", "length=4"))
    (tmp_path / "frames").mkdir()
    monkeypatch.chdir(tmp_path)
    return tmp_path


RUN = ["--dt", "0.01", "--steps", "600", "--wind-speed", "20"]


def load_objects(path):
    """The OBJ file read back by trimesh as a scene of its objects, each with its own vertices."""
    import trimesh

    scene = trimesh.load_scene(path, process=False, split_objects=True, group_material=False,
                               maintain_order=True)
    for geometry in scene.geometry.values():
        geometry.remove_unreferenced_vertices()     # trimesh hands every object the whole file's
    return scene


def test_compare_writes_the_thesis_figure_and_trimesh_reads_it(runner, stalks):
    result = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", "l2.lsys", *RUN,
                                 "--obj", "frames", "--at", "4,5.5"])
    assert result.exit_code == 0, result.stderr
    assert sorted(p.name for p in (stalks / "frames").iterdir()) == ["frame_t4.obj", "frame_t5.5.obj"]
    scene = load_objects(stalks / "frames" / "frame_t4.obj")
    counts = {name: (len(g.vertices), len(g.faces)) for name, g in scene.geometry.items()}
    # branches x 2 rings of S vertices + 4 per leaf; branches x 2S side triangles + 2 per leaf
    assert counts == {"original": (8 * 2 * S + 4, 8 * 2 * S + 2),
                      "simplified_1": (4 * 2 * S + 4, 4 * 2 * S + 2),
                      "simplified_2": (2 * 2 * S + 4, 2 * 2 * S + 2)}
    # the three trees stand apart, left to right, all 8 m tall at rest
    xs = [scene.geometry[n].vertices[:, 0] for n in ("original", "simplified_1", "simplified_2")]
    assert xs[0].max() < xs[1].min() and xs[1].max() < xs[2].min()
    again = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", "l2.lsys", *RUN,
                                "--obj", "frames", "--at", "4"])
    assert again.exit_code == 0
    assert "wrote 1 OBJ file to frames" in again.stderr


def test_compare_obj_positions_match_the_angles(runner, stalks):
    """The posed original in frame_t4.obj is the pose of the simulated angles at t = 4 s."""
    from plantlod.formats.angles_csv import read_angles_csv

    assert runner.invoke(cli, ["simulate", "stalk8.lsys", *RUN, "-o", "a.csv"]).exit_code == 0
    result = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--obj", "frames",
                                 "--at", "4"])
    assert result.exit_code == 0
    times, _addresses, bend, rot = read_angles_csv(open("a.csv"), "a.csv")
    k = int(np.flatnonzero(np.isclose(times, 4.0))[0])
    # straight stalk, wind along x, no rotation: branch i's tip direction is at the summed
    # bend of branches 0..i; the top tip of the mesh's top ring centre
    assert np.all(rot[k] == 0)
    cumulative = np.cumsum(bend[k])
    top_tip = np.array([np.sum(np.sin(cumulative)), 0.0, np.sum(np.cos(cumulative))])
    scene = load_objects("frames/frame_t4.obj")
    original = scene.geometry["original"].vertices
    top_ring = original[2 * S * 7 + S: 2 * S * 8]
    np.testing.assert_allclose(top_ring.mean(axis=0), top_tip, atol=2e-6)   # 6 decimals in the file


def test_every_writes_a_numbered_sequence(runner, stalks):
    result = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", "--dt", "0.01", "--steps", "20",
                                 "--wind-speed", "20", "--obj", "frames", "--every", "5"])
    assert result.exit_code == 0, result.stderr
    # 21 samples: 0, 5, 10, 15, 20
    assert sorted(p.name for p in (stalks / "frames").iterdir()) == [f"frame_{n:05d}.obj" for n in range(5)]
    first = (stalks / "frames" / "frame_00000.obj").read_bytes()
    rerun = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", "--dt", "0.01", "--steps", "20",
                                "--wind-speed", "20", "--obj", "frames", "--every", "5"])
    assert rerun.exit_code == 0 and (stalks / "frames" / "frame_00000.obj").read_bytes() == first
    outside = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--obj", "frames",
                                  "--at", "99"])
    assert outside.exit_code == 2 and "--at 99 s is outside the run" in outside.stderr
    made = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--obj", "new/dir", "--at", "1"])
    assert made.exit_code == 0 and (stalks / "new" / "dir" / "frame_t1.obj").is_file()
    (stalks / "afile").write_text("x")
    notdir = runner.invoke(cli, ["compare", "stalk8.lsys", "l1.lsys", *RUN, "--obj", "afile", "--at", "1"])
    assert notdir.exit_code == 2 and "afile: error: --obj needs a directory" in notdir.stderr
