"""A scene tree's seed (model.md 7: every tree has a file, a seed, a position, a heading and
a scale): [[tree]] seed and [scatter] tree_seeds grow a stochastic file from another seed,
each (file, seed) with a chain of its own; a seed that grows what the file grows anyway
shares the file's chain."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from plantlod.formats.lsys_file import parse_lsys_text
from plantlod.lsys.build import build
from plantlod.lsys.errors import InputError
from plantlod.scene.file import read_scene

STOCHASTIC = """name: st
derivation_length: 4
branching_angle: 25.7
rotation_angle: 90
seed: 7
force_absorbed: 0.0008
force_propagated: 0.7
branch F: length=0.15 radius=0.006 bend_strength=40 rotation_strength=40
leaf L: area=0.003
axiom: X
productions:
  X -> (0.34) F [+X L] F X
  X -> (0.33) F [-X L] / F X
  X -> (0.33) F [&X] [^X L] F X
"""

DETERMINISTIC = """name: det
derivation_length: 3
branching_angle: 30
rotation_angle: 90
force_absorbed: 0.001
force_propagated: 0.7
branch F: length=0.2 radius=0.01 bend_strength=40 rotation_strength=40
axiom: F X
productions:
  X -> F [+X] [-X]
"""

HEAD = """dt = 0.01
duration = 2
[wind]
speed = 5
[camera]
position = [0, -30, 2]
target = [0, 0, 2]
"""


def _scene(tmp_path, body: str) -> pathlib.Path:
    (tmp_path / "st.lsys").write_text(STOCHASTIC)
    (tmp_path / "det.lsys").write_text(DETERMINISTIC)
    path = tmp_path / "s.toml"
    path.write_text(HEAD + body)
    return path


def _tree(file: str, x: float, seed: int | None = None) -> str:
    return (f'[[tree]]\nfile = "{file}"\nposition = [{x}, 0, 0]\n'
            + ("" if seed is None else f"seed = {seed}\n"))


def _grown_by_text(seed: int):
    """The stochastic file's tree with its ``seed:`` line rewritten: the independent route
    to what a tree of that seed must be."""
    text = STOCHASTIC.replace("seed: 7", f"seed: {seed}")
    return build(parse_lsys_text(text, "st.lsys")).tree


def test_a_seed_is_kept_only_where_it_grows_another_tree(tmp_path):
    scene = read_scene(str(_scene(tmp_path, _tree("st.lsys", 0) + _tree("st.lsys", 3, 3)
                                  + _tree("st.lsys", 6, 7) + _tree("det.lsys", 9, 5))))
    # the file's own seed (7) and a seed on a file without stochastic productions are dropped
    assert [t.seed for t in scene.trees] == [None, 3, None, None]
    assert len({t.source for t in scene.trees}) == 3


def test_seeds_grow_different_trees_and_the_seeded_one_is_the_rewritten_file(tmp_path):
    """The chain of (st.lsys, seed 3) starts from the tree the file grows with `seed: 3`
    written in it, which is not the tree of its own seed 7 (else this test shows nothing)."""
    from plantlod.scene.levels import level_chain

    _scene(tmp_path, "")
    path = tmp_path / "st.lsys"
    seeded, _hit = level_chain(path, 5.0, 0.01, 2.0, None, seed=3)
    own, _hit = level_chain(path, 5.0, 0.01, 2.0, None)
    want = _grown_by_text(3)
    assert seeded.trees[0].address == want.address
    assert np.array_equal(seeded.trees[0].length, want.length)
    assert own.trees[0].address == _grown_by_text(7).address
    assert own.trees[0].address != seeded.trees[0].address
    # every level of the seeded chain stands for the seeded original's branches
    assert all(len(g) == want.n_branches for g in seeded.groups)


def test_a_seeded_tree_is_cached_under_its_own_key(tmp_path):
    from plantlod.scene.levels import cache_key

    data = STOCHASTIC.encode()
    keys = {cache_key(data, 5.0, 0.01, 2.0), cache_key(data, 5.0, 0.01, 2.0, seed=3),
            cache_key(data, 5.0, 0.01, 2.0, seed=4)}
    assert len(keys) == 3


def test_a_scene_of_seeded_trees_runs_each_from_its_own_chain(tmp_path):
    from plantlod.scene.run import check_scene, run_scene

    path = _scene(tmp_path, _tree("st.lsys", 0) + _tree("st.lsys", 3, 3) + _tree("st.lsys", 6, 3))
    scene = read_scene(str(path))
    check_scene(scene)
    store = tmp_path / "a.zarr"
    report = run_scene(scene, cache=tmp_path / "cache", verify=True, store_path=str(store))
    assert (report["files"], report["chains"]) == (1, 2)
    assert report["max_error_px"] <= scene.budget_px
    # full detail counts each tree's own branches: the seeded trees' are the rewritten file's
    want = _grown_by_text(7).n_branches + 2 * _grown_by_text(3).n_branches
    assert report["branches_full"] == want
    import zarr

    group = zarr.open_group(str(store), mode="r")
    attrs = sorted((k, dict(group[k].attrs).get("seed"), group[k]["trees"][:].tolist())
                   for k in group.group_keys())
    assert attrs == [("file_0", None, [0]), ("file_1", 3, [1, 2])]
    again = run_scene(read_scene(str(path)), cache=tmp_path / "cache")
    assert again["chains_from_cache"] == 2


def test_a_scatter_draws_tree_seeds_without_moving_a_tree(tmp_path):
    scatter = ('[scatter]\nfiles = ["st.lsys", "det.lsys"]\ncount = 40\nseed = 2\n'
               'area = [0, 0, 50, 50]\nmin_spacing = 2\n')
    plain = read_scene(str(_scene(tmp_path, scatter)))
    seeded = read_scene(str(_scene(tmp_path, scatter + "tree_seeds = [1, 2, 7]\n")))
    assert [(t.file, t.position, t.heading) for t in plain.trees] == \
        [(t.file, t.position, t.heading) for t in seeded.trees]
    got = {t.seed for t in seeded.trees if t.file.name == "st.lsys"}
    assert got == {None, 1, 2}               # (7 is the file's own: None)
    assert {t.seed for t in seeded.trees if t.file.name == "det.lsys"} == {None}


@pytest.mark.parametrize("body, line, words", [
    (_tree("st.lsys", 0, -1), 11, "'seed' must be a whole number >= 0, got -1"),
    ('[[tree]]\nfile = "st.lsys"\nseed = 1.5\n', 10, "'seed' must be a whole number >= 0"),
    ('[scatter]\nfiles = ["st.lsys"]\ncount = 3\narea = [0, 0, 9, 9]\ntree_seeds = []\n', 12,
     "'tree_seeds' must be a non-empty list"),
    ('[scatter]\nfiles = ["st.lsys"]\ncount = 3\narea = [0, 0, 9, 9]\ntree_seeds = [1, "a"]\n', 12,
     "'tree_seeds' must be a whole number"),
    ('[scatter]\nfiles = ["st.lsys"]\ncount = 3\narea = [0, 0, 9, 9]\ntree_seeds = 4\n', 12,
     "'tree_seeds' must be a non-empty list"),
])
def test_bad_seeds_are_refused_at_their_line(tmp_path, body, line, words):
    with pytest.raises(InputError) as err:
        read_scene(str(_scene(tmp_path, body)))
    assert err.value.line == line and words in str(err.value), str(err.value)


def test_the_cli_reports_chains(tmp_path):
    from click.testing import CliRunner

    from plantlod.cli.main import cli

    path = _scene(tmp_path, _tree("st.lsys", 0) + _tree("st.lsys", 3, 3))
    out = tmp_path / "r.json"
    result = CliRunner().invoke(cli, ["scene", str(path), "--no-cache", "--report", str(out)])
    assert result.exit_code == 0, result.output
    report = json.loads(out.read_text())
    assert (report["trees"], report["files"], report["chains"]) == (2, 1, 2)


def test_a_dask_cluster_grows_each_batch_from_its_seed(tmp_path):
    """A cluster's workers rebuild each chain from its texts and the batch's seed
    (`run.simulate_batch`): the store equals the one written in this process, and the
    seeded trees' level-0 arrays have the seeded tree's branch count."""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    import zarr

    from plantlod.scene.run import run_scene

    path = _scene(tmp_path, _tree("st.lsys", 0) + _tree("st.lsys", 3, 3))
    cache = tmp_path / "cache"
    run_scene(read_scene(str(path)), cache=cache, store_path=str(tmp_path / "here.zarr"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        run_scene(read_scene(str(path)), cache=cache, store_path=str(tmp_path / "there.zarr"),
                  scheduler=cluster.scheduler_address)
    here = zarr.open_group(str(tmp_path / "here.zarr"), mode="r")
    there = zarr.open_group(str(tmp_path / "there.zarr"), mode="r")
    assert here["file_1"].attrs["seed"] == 3
    assert here["file_1/level_0/bend"].shape[2] == _grown_by_text(3).n_branches
    for name in ("levels", "file_0/level_0/bend", "file_1/level_0/bend", "file_1/level_1/rotation"):
        np.testing.assert_array_equal(here[name][:], there[name][:])


def test_a_seed_that_grows_the_same_tree_shares_the_chain(tmp_path):
    """Found by fuzzing (session 24): a stochastic file whose productions cannot differ by
    seed (one production of probability 1; a derivation length of 0) gave each seed a chain
    of its own, fitting the same tree again."""
    one = STOCHASTIC.split("productions:")[0] + "productions:\n  X -> (1) F [+X L] F X\n"
    (tmp_path / "one.lsys").write_text(one)
    (tmp_path / "zero.lsys").write_text(STOCHASTIC.replace("derivation_length: 4",
                                                           "derivation_length: 0"))
    scene = read_scene(str(_scene(tmp_path, _tree("one.lsys", 0, 5) + _tree("zero.lsys", 3, 5)
                                  + _tree("st.lsys", 6, 5))))
    assert [t.seed for t in scene.trees] == [None, None, 5]


def test_a_seed_of_any_size_grows_its_tree_and_past_the_digit_limit_is_refused(tmp_path):
    """Found by fuzzing (session 24): a seed past a float's range was refused as 'not a whole
    number' (an .lsys seed may be any size), one of 400 digits then failed inside the fit
    (the level's header wrote the seed as a float), and one of 5,000 digits was an internal
    error (tomllib's int() past Python's 4,300-digit limit)."""
    from plantlod.lsys.parse import parse_lsys
    from plantlod.scene.levels import level_chain

    big = int("9" * 400)
    scene = read_scene(str(_scene(tmp_path, _tree("st.lsys", 0, big))))
    assert scene.trees[0].seed == big
    chain, _hit = level_chain(tmp_path / "st.lsys", 5.0, 0.01, 2.0, None, seed=big)
    assert chain.trees[0].address == _grown_by_text(big).address
    assert parse_lsys(chain.texts[1], "level 1").seed == big       # the level reads back
    path = _scene(tmp_path, _tree("st.lsys", 0) + "seed = " + "9" * 5000 + "\n")
    with pytest.raises(InputError) as err:
        read_scene(str(path))
    assert (err.value.line, err.value.col) == (11, 8)
    assert "a whole number of 5000 digits; expected at most 4300" in str(err.value)
    with pytest.raises(InputError) as err:
        read_scene(str(_scene(tmp_path, _tree("st.lsys", 0) + 'seed = "' + "9" * 500 + '"\n')))
    assert len(str(err.value)) < 200


@pytest.mark.parametrize("body, line", [
    ('[[tree]]\nfile = "st.lsys"\n\nscale = -1\n', 11),      # a blank line before the key
    ('[[tree]]\nfile = "st.lsys"\n\ntree.seed = 3\n', 11),   # a dotted key
])
def test_a_bad_key_is_named_at_its_own_line(tmp_path, body, line):
    """Found by fuzzing (session 24): the key's line was found with ^\\s*, which ran over
    blank lines before it (the blank line was named), and a dotted key fell back to its
    table's header."""
    with pytest.raises(InputError) as err:
        read_scene(str(_scene(tmp_path, body)))
    assert err.value.line == line, str(err.value)


def test_an_unseeded_trees_cache_key_is_the_one_before_seeds(tmp_path):
    """Seeds join the key only where given: the key of an unseeded tree is the formula it had
    before seeds, with the tip errors' directions after the settings (session 32), computed
    here independently."""
    import hashlib
    from importlib.metadata import version

    from plantlod.scene.levels import cache_key, fit_code_digest

    data = STOCHASTIC.encode()
    h = hashlib.sha256()
    directions = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)
    for part in (data, version("plantlod").encode(), fit_code_digest(),
                 repr((5.0, 0.01, 2.0, 0.0, directions)).encode()):
        h.update(len(part).to_bytes(8, "little"))
        h.update(part)
    assert cache_key(data, 5.0, 0.01, 2.0) == h.hexdigest()[:32]


def test_more_chains_than_the_limit_are_refused_before_any_tree_is_built(tmp_path, monkeypatch):
    from plantlod.scene import file as scene_file

    monkeypatch.setattr(scene_file, "MAX_SCENE_CHAINS", 3)
    def no_build(*_a, **_k):
        raise AssertionError("built a tree before the limit was checked")
    monkeypatch.setattr(scene_file, "shared_seeds", no_build)
    body = "".join(_tree("st.lsys", 3 * k, k) for k in range(4))
    with pytest.raises(InputError) as err:
        read_scene(str(_scene(tmp_path, body)))
    assert "4 distinct (file, seed) pairs, more than the limit of 3" in str(err.value)
    assert err.value.line == 11                       # the first 'seed =' line


def test_bad_input_in_a_seeded_tree_names_the_seed(tmp_path):
    """A stochastic file whose stiff symbol S only grows for some seeds: the time step is too
    large for S, so a scene tree of such a seed is refused, and the message says which seed
    (the file on its own seed is fine)."""
    from plantlod.scene.run import check_scene

    text = STOCHASTIC.replace(
        "productions:\n", "branch S: length=0.15 radius=0.006 bend_strength=900000 "
        "rotation_strength=40\nproductions:\n").replace("derivation_length: 4", "derivation_length: 3")
    text = text.split("productions:")[0] + "productions:\n  X -> (0.5) F X\n  X -> (0.5) S X\n"
    system = parse_lsys_text(text, "stiff.lsys")

    def has_s(seed):
        return "S" in build(system.grown_from(seed)).tree.symbol
    own = next(k for k in range(100) if not has_s(k))
    bad = next(k for k in range(100) if has_s(k))
    (tmp_path / "stiff.lsys").write_text(text.replace("seed: 7", f"seed: {own}"))
    check_scene(read_scene(str(_scene(tmp_path, _tree("stiff.lsys", 0)))))    # its own: fine
    with pytest.raises(InputError) as err:
        check_scene(read_scene(str(_scene(tmp_path, _tree("stiff.lsys", 0, bad)))))
    assert f"(the tree grown from seed {bad}, given in the scene)" in str(err.value)


def test_a_long_number_in_a_comment_is_not_the_one_named(tmp_path):
    body = "# " + "1" * 5000 + "\n" + _tree("st.lsys", 0) + "seed = " + "9" * 5000 + "\n"
    with pytest.raises(InputError) as err:
        read_scene(str(_scene(tmp_path, body)))
    assert (err.value.line, err.value.col) == (12, 8), str(err.value)[:120]


def test_seeds_that_grow_one_tree_share_one_chain(tmp_path):
    """A file of derivation length 1 grows one of three trees: among ten seeds, each distinct
    tree gets one chain (the smallest seed growing it; None where it is the file's own),
    counted here from the files rewritten with each seed."""
    (tmp_path / "one_step.lsys").write_text(STOCHASTIC.replace("derivation_length: 4",
                                                               "derivation_length: 1"))
    scene = read_scene(str(_scene(tmp_path, "".join(_tree("one_step.lsys", 3 * k, k)
                                                    for k in range(10)))))

    def key(seed):
        text = STOCHASTIC.replace("derivation_length: 4", "derivation_length: 1")
        t = build(parse_lsys_text(text.replace("seed: 7", f"seed: {seed}"), "x")).tree
        return tuple(t.address), tuple(t.symbol), t.euler.tobytes(), t.leaf_normal.tobytes()

    want = {}
    for k in [7] + list(range(10)):              # the file's own first: it is None
        want.setdefault(key(k), None if k == 7 else k)
    assert 1 < len(want) <= 3
    assert [t.seed for t in scene.trees] == [want[key(k)] for k in range(10)]
