"""Hardening of `plantlod scene` (issue 24): declared caps refused before anything is
allocated (trees, time steps, tree-steps of wind, branch-steps), folders removed on every
way out, and random scene files that may only ever end in exit 0, 1 or 2 with one line."""

from __future__ import annotations

import json
import os
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from golden_util import ROOT, run_cli
from test_hardening_cli import one_line

STALK = str(ROOT / "examples" / "stalk8.lsys")

HEAD = """dt = 0.01
duration = {duration}
[wind]
speed = 5
[camera]
position = [0, -40, 1.7]
target = [0, 0, 1.7]
"""


def scene_file(tmp_path, body: str, duration="1") -> str:
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration=duration) + body)
    return str(path)


def test_a_billion_scattered_trees_are_refused_at_once(tmp_path):
    path = scene_file(tmp_path, f'[scatter]\nfiles = ["{STALK}"]\ncount = 1000000000\n'
                                'area = [0, 0, 10, 10]\n')
    start = time.perf_counter()
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
                    "trees, more than the limit of 100,000")
    assert time.perf_counter() - start < 5
    assert line.startswith(f"{path}:10:1: error:")


def test_scatter_after_tree_entries_counts_them_too(tmp_path, monkeypatch):
    import plantlod.scene.file as scene_file_module

    monkeypatch.setattr(scene_file_module, "MAX_TREES", 3)
    body = (f'[[tree]]\nfile = "{STALK}"\n[[tree]]\nfile = "{STALK}"\n'
            f'[scatter]\nfiles = ["{STALK}"]\ncount = 2\narea = [0, 0, 10, 10]\n')
    one_line(run_cli("scene", scene_file(tmp_path, body), "--no-cache", exit_code=None), 2,
             "[scatter] count 2 and the 2 [[tree]] entries make 4 trees, more than the limit "
             "of 3; expected a count of at most 1")


@pytest.mark.parametrize("duration", ["1e12", "1e308"])
def test_a_scene_too_long_is_a_usage_error(tmp_path, duration):
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n', duration=duration)
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
                    "more than the limit of 1,000,000")
    assert line.startswith(f"{path}:2:1: error: duration")


def test_tree_steps_cap(tmp_path, monkeypatch):
    import plantlod.scene.run as scene_run

    monkeypatch.setattr(scene_run, "MAX_SCENE_TREE_STEPS", 150)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
             "2 trees x 100 steps is 200 tree-steps of wind, more than the limit of 150")


def test_branch_steps_cap(tmp_path, monkeypatch):
    import plantlod.scene.run as scene_run

    monkeypatch.setattr(scene_run, "MAX_SCENE_BRANCH_STEPS", 1000)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n[[tree]]\nfile = "{STALK}"\n')
    # stalk8 has 8 branches: 2 x 8 x 100
    one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
             "1,600 branch-steps at full detail", "more than the limit of 1,000")


def test_tree_entries_that_are_not_tables(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("tree = [1, 2]\n" + HEAD.format(duration=1))
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             "trees are [[tree]] entries")


# --- folders a command creates: removed on every signal and error ------------------------

SLOWED = """import sys, time
import {module} as m
real = m.{name}
def slow(*a, **k):
    time.sleep(0.5)
    return real(*a, **k)
m.{name} = slow
{extra}
from plantlod.cli.main import main
sys.argv[0] = "plantlod"
main()
"""


def default_signals() -> None:
    """In the child: SIGINT at its default, even when this test runs in the background of a
    shell (which starts it ignored, and plantlod keeps an ignored signal ignored)."""
    import signal as _signal

    _signal.signal(_signal.SIGINT, _signal.SIG_DFL)


def _signal_when_a_temporary_appears(tmp_path, script: str, args: list[str], signum: int):
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", script, *args], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_signals)
    deadline = time.monotonic() + 120
    while not any(p.startswith(".plantlod-") for p in os.listdir(tmp_path)):
        assert proc.poll() is None, proc.communicate()[1]
        assert time.monotonic() < deadline
        time.sleep(0.05)
    time.sleep(0.3)
    proc.send_signal(signum)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, stderr
    assert len(stderr.strip().splitlines()) == 1 and "Traceback" not in stderr, stderr


@pytest.mark.parametrize("signum", [2, 15, 1])
def test_a_signal_during_scene_angles_leaves_no_store(tmp_path, signum):
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD.format(duration=1) + f'[scatter]\nfiles = ["{STALK}"]\ncount = 200\n'
                     'area = [-20, -20, 20, 20]\n')
    out = tmp_path / "out"
    out.mkdir()
    script = SLOWED.format(module="plantlod.scene.run", name="run_batch", extra="")
    _signal_when_a_temporary_appears(out, script, ["scene", str(scene), "--cache",
                                                   str(tmp_path / "cache"), "--angles",
                                                   str(out / "a.zarr"), "--report", os.devnull],
                                     signum)
    assert os.listdir(out) == []


def test_a_failure_after_the_store_leaves_no_store(tmp_path):
    scene = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    out = tmp_path / "out"
    out.mkdir()
    result = run_cli("scene", scene, "--cache", str(tmp_path / "cache"), "--angles",
                     str(out / "a.zarr"), "--report", "/dev/full", exit_code=None)
    one_line(result, 1, "No space left on device")
    assert os.listdir(out) == []


# command that fills a folder: (module, function slowed down, arguments for the folder)
FOLDER_COMMANDS = {
    "simplify --levels": ("plantlod.simplify.pipeline", "simplify_explicit",
                          lambda t: ["simplify", STALK, "--levels", t, "--duration", "1"]),
    "compare --obj": ("plantlod.export.obj", "obj_text",
                      lambda t: ["compare", STALK, STALK, "--dt", "0.01", "--steps", "200",
                                 "--wind-speed", "3", "--obj", t, "--every", "10",
                                 "-o", os.devnull]),
}


@pytest.mark.parametrize("command", sorted(FOLDER_COMMANDS))
@pytest.mark.parametrize("existing", [False, True, "nested"])
def test_a_signal_while_filling_a_folder_leaves_it_as_it_was(tmp_path, command, existing):
    out = tmp_path / "out"
    out.mkdir()
    target = out / "new" / "folder" if existing == "nested" else out / "folder"
    existing = existing is True
    if existing:
        target.mkdir()
        (target / "mine.txt").write_text("keep")
    module, name, args = FOLDER_COMMANDS[command]
    script = SLOWED.format(module=module, name=name, extra="")
    # (an existing folder is filled from a temporary inside it, since session 42: the moves
    # stay on its file system where it is a mount point)
    _signal_when_a_temporary_appears(target if existing else out, script, args(str(target)), 2)
    assert os.listdir(out) == (["folder"] if existing else [])
    if existing:
        assert os.listdir(target) == ["mine.txt"]


def test_simplify_levels_fills_an_existing_folder_or_makes_a_new_one(tmp_path):
    target = tmp_path / "lv"
    target.mkdir()
    (target / "mine.txt").write_text("keep")
    run_cli("simplify", STALK, "--levels", str(target), "--duration", "1")
    names = sorted(os.listdir(target))
    assert "mine.txt" in names and "level1.lsys" in names
    umask = os.umask(0)
    os.umask(umask)
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".plantlod-")]
    run_cli("simplify", STALK, "--levels", str(tmp_path / "new" / "lv"), "--duration", "1")
    assert "level1.lsys" in os.listdir(tmp_path / "new" / "lv")
    assert (tmp_path / "new" / "lv").stat().st_mode & 0o777 == 0o777 & ~umask   # as mkdir
    assert sorted(os.listdir(tmp_path)) == ["lv", "new"]
    (tmp_path / "afile").write_text("x")
    one_line(run_cli("simplify", STALK, "--levels", str(tmp_path / "afile" / "lv"),
                     exit_code=None), 2, "afile is not a folder")


# --- random scene files: exit 0, 1 or 2 with one line, never an internal error -----------

def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if value != value:
            return "nan"
        if value in (float("inf"), float("-inf")):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


SCALARS = st.one_of(
    st.sampled_from([0, 1, -1, 2, 10**9, 10**30, 0.0, 0.01, -0.5, 1e-300, 1e308, float("nan"),
                     float("inf"), True, "x", "", STALK, "no-such.lsys", ROOT.name]),
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**63, 2**63 - 1))
VALUES = st.one_of(SCALARS, st.lists(SCALARS, max_size=5), st.dictionaries(
    st.sampled_from(["t", "position", "target", "file", "x"]), SCALARS, max_size=3))
KEYS = {
    "": ["dt", "duration", "budget_px", "tree", "wind", "camera", "scatter", "x"],
    "wind": ["speed", "direction", "gust_strength", "gust_seed", "front_speed", "x"],
    "camera": ["position", "target", "fov_deg", "height_px", "key", "x"],
    "scatter": ["files", "count", "seed", "area", "min_spacing", "scale", "tree_seeds", "x"],
    "tree": ["file", "seed", "position", "heading", "scale", "x"],
}


@st.composite
def scene_texts(draw) -> str:
    top = {k: draw(VALUES) for k in draw(st.lists(st.sampled_from(["dt", "duration", "budget_px"]),
                                                   unique=True))}
    lines = [f"{k} = {_toml_value(v)}" for k, v in top.items()]
    for table in ("wind", "camera", "scatter"):
        if draw(st.booleans()):
            lines.append(f"[{table}]")
            base = {"camera": {"position": [0, -40, 1.7], "target": [0, 0, 1.7]},
                    "scatter": {"files": [STALK], "count": 3, "area": [0, 0, 10, 10]}}.get(table, {})
            values = dict(base) if draw(st.booleans()) else {}
            for key in draw(st.lists(st.sampled_from(KEYS[table]), unique=True, max_size=3)):
                values[key] = draw(VALUES)
            lines += [f"{k} = {_toml_value(v)}" for k, v in values.items()]
    for _ in range(draw(st.integers(0, 2))):
        lines.append("[[tree]]")
        values = {"file": STALK} if draw(st.booleans()) else {}
        for key in draw(st.lists(st.sampled_from(KEYS["tree"]), unique=True, max_size=3)):
            values[key] = draw(VALUES)
        lines += [f"{k} = {_toml_value(v)}" for k, v in values.items()]
    return "\n".join(lines) + "\n"


def _check_scene_text(tmp_path, text: str) -> None:
    from plantlod.lsys.errors import InputError
    from plantlod.scene.file import read_scene
    from plantlod.scene.run import check_scene

    path = tmp_path / "f.toml"
    path.write_text(text)
    try:
        check_scene(read_scene(str(path)))
    except InputError:
        pass


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(scene_texts())
def test_random_scene_files_raise_only_input_error(tmp_path, text):
    _check_scene_text(tmp_path, text)


VALID = HEAD.format(duration=1) + f'[scatter]\nfiles = ["{STALK}"]\ncount = 3\narea = [0, 0, 9, 9]\n'


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.data())
def test_random_edits_of_a_scene_file_raise_only_input_error(tmp_path, data):
    text = list(VALID)
    for _ in range(data.draw(st.integers(1, 4))):
        at = data.draw(st.integers(0, len(text) - 1))
        text[at] = data.draw(st.sampled_from(list("0123456789.-=[]{}\"'#\n ,eanifx")))
    _check_scene_text(tmp_path, "".join(text))


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.lists(st.sampled_from(["--budget", "0", "-1", "nan", "1", "--frame-rate", "1e9", "30", "1e-300",
                                 "--threads", "0", "2", "--report", "/dev/full", "-",
                                 "--plot", "/no/such/p.png", "--angles", "/no/such/a.zarr",
                                 "--no-cache", "--cache", "/dev/null", "--verify",
                                 "--scheduler", "tcp://"]), max_size=5))
def test_random_scene_options_follow_the_discipline(tmp_path, options):
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n', duration="0.05")
    work = tmp_path / "work"            # an option taken as a file name lands here
    work.mkdir(exist_ok=True)
    result = run_cli("scene", path, "--cache", str(tmp_path / "c"), *options, exit_code=None,
                     cwd=work)
    assert result.exit_code in (0, 1, 2), (options, result.exit_code, result.stderr)
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, options
    if result.exit_code:
        assert "error:" in result.stderr.strip().splitlines()[-1], (options, result.stderr)


@pytest.mark.parametrize("address, said", [
    ("--budget", "is not a scheduler address"), ("foo", "is not a scheduler address"),
    ("tcp://", "is not a scheduler address"), ("tcp://host", "is not a scheduler address"),
    ("http://h:1 x", "is not a scheduler address"),
    # (waited 30 s for the connection to fail, then exit 1: session 28's fuzzing)
    ("tcp://256.1.1.1:8786", "has host 256.1.1.1, not an IPv4 address"),
    ("tcp://127.0.0.1:99999", "has port 99999, outside 1-65535"),
    ("tcp://localhost:0", "has port 0, outside 1-65535"),
    # (each failed after the work, with an internal error or int()'s message: a cluster
    # fuzzing round; plantlod connects to tcp:// schedulers only)
    ("tls://127.0.0.1:8786", "is not a scheduler address"),
    ("ucx://127.0.0.1:8786", "is not a scheduler address"),
    ("inproc://127.0.0.1:8786", "is not a scheduler address"),
    ("tcp://127.0.0.1:8786/", "is not a scheduler address")])
def test_a_bad_scheduler_address_is_bad_input_before_any_work(tmp_path, address, said):
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--no-cache", "--scheduler", address, exit_code=None), 2,
             said, "; expected tcp://HOST:PORT")


def test_an_empty_cache_name_is_refused(tmp_path):
    """`--cache ''` fell back to the default cache without a word (session 29's fuzzing)."""
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--cache", "", exit_code=None), 2,
             "--cache needs a folder name; got an empty one")


def test_a_scene_shorter_than_a_default_frame_names_its_duration(tmp_path):
    """Without --frame-rate, the message blamed "--frame-rate 30", an option nobody gave
    (session 28's fuzzing); it names the scene file and its duration."""
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration=0.02).replace("dt = 0.01", "dt = 0.001")
                    + f'[[tree]]\nfile = "{STALK}"\n')
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
                    f"{path}: error: the scene's duration 0.02 s is shorter than one frame "
                    "(0.0333 s at the default --frame-rate 30); expected a duration of at least "
                    "0.0333 s, or a --frame-rate of at least 50")
    assert line


@pytest.mark.parametrize("rate", ["1e-300", "0.5"])
def test_a_frame_longer_than_the_scene_is_bad_input(tmp_path, rate):
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--no-cache", "--frame-rate", rate, exit_code=None), 2,
             f"--frame-rate {rate} gives frames of", "longer than the scene's 1 s")


def test_an_impossible_spacing_is_refused_without_drawing(tmp_path):
    path = scene_file(tmp_path, f'[scatter]\nfiles = ["{STALK}"]\ncount = 100000\n'
                                'area = [0, 0, 10, 10]\nmin_spacing = 5\n')
    start = time.perf_counter()
    one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
             "cannot place 100,000 trees 5 m apart in the area: at most 10 fit")
    assert time.perf_counter() - start < 5


def test_a_scene_file_is_read_as_every_text_input(tmp_path):
    path = tmp_path / "s.toml"
    path.write_bytes(b"dt = 0.01\nduration = \xff\n")
    one_line(run_cli("scene", str(path), exit_code=None), 2,
             f"{path}:2:12: error: not UTF-8 text")
    one_line(run_cli("scene", str(tmp_path), exit_code=None), 2, "is a directory, not a file")
    one_line(run_cli("scene", str(tmp_path / "none.toml"), exit_code=None), 2, "no such file")


def test_a_scene_of_trees_without_branches_warns_and_writes_valid_json(tmp_path):
    import json

    lsys = tmp_path / "nb.lsys"
    lsys.write_text("derivation_length: 1\nbranching_angle: 30\nforce_absorbed: 0.005\n"
                    "force_propagated: 0.7\naxiom: A\n")
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{lsys}"\n', duration="0.5")
    result = run_cli("scene", path, "--no-cache")
    assert "warning: " in result.stderr and "no branch symbol declared" in result.stderr
    assert "(no branches)" in result.stderr
    assert json.loads(result.stdout, parse_constant=lambda c: pytest.fail(c))["speedup"] is None


@pytest.mark.parametrize("body, message", [
    (f'[[tree]]\nfile = "{STALK}"\n', "'damping_ratio' must be <= 100, got 1e+300"),
    (f'[scatter]\nfiles = ["{STALK}"]\ncount = 3\narea = [-1e308, -1e308, 1e308, 1e308]\n',
     "'area' must lie within 1e+09 m of the origin in each coordinate"),   # (since session 38)
    (f'[scatter]\nfiles = ["{STALK}"]\ncount = 3\narea = [-1e9, -1e9, 1e9, 1e9]\nscale = 1e7\n',
     "'scale' must be <= 1e+06, got 10000000.0"),
    (f'[[tree]]\nfile = "{STALK}"\nposition = [1e308, 0, 0]\n',
     "'position' must lie within 1e+09 m of the origin in each coordinate, got [1e+308, 0, 0]"),
    (f'[scatter]\nfiles = ["{STALK}"]\ncount = 3\narea = [0, 0, 10, 10]\nmin_spacing = 1e300\n',
     "cannot place 3 trees 1e+300 m apart in the area: at most 1 fit"),
    ('[[tree]]\nfile = "a\\u0000b"\n', "'file' must name an .lsys file"),
    (f'[[tree]]\nfile = "{"a" * 5000}.lsys"\n', "File name too long"),
])
def test_values_past_what_numbers_and_paths_hold_are_located_bad_input(tmp_path, body, message):
    """Found by fuzzing (session 21): each of these was an internal error (a math domain
    error, numpy's range, float ** overflow, an embedded null byte) or exit 1."""
    path = tmp_path / "s.toml"
    top = "damping_ratio = 1e300\n" if "damping" in message else ""
    path.write_text(top + HEAD.format(duration="1") + body)
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    assert line.startswith(f"{path}:")                          # located in the scene file


def test_a_spacing_below_the_smallest_normal_double_still_places_trees(tmp_path):
    """min_spacing 5e-324 (its square is 0: a division by zero before session 21)."""
    path = scene_file(tmp_path, f'[scatter]\nfiles = ["{STALK}"]\ncount = 3\n'
                                'area = [0, 0, 10, 10]\nmin_spacing = 5e-324\n')
    assert run_cli("scene", path, "--no-cache", exit_code=None).exit_code == 0


@pytest.mark.parametrize("edit, message, where", [
    # speed = 1e300 overflowed to inf inside the run, reported without the file (session 21)
    (("speed = 5", "speed = 1e300"), "'speed' must be <= 1000, got 1e+300", 4),
    # '[wind.extra]' was named without a line (session 22)
    (("speed = 5\n", "speed = 5\n[wind.extra]\nx = 1\n"), "unknown key 'extra' in [wind]", 5),
    # gusts of 2e7 m/s were refused inside the levels' fit, with no file or line (session 23)
    (("speed = 5\n", "speed = 5\ngust_strength = 1e6\n"), "lets a 5 m/s wind gust to 2e+07 m/s", 5),
])
def test_a_bad_wind_is_located_bad_input(tmp_path, edit, message, where):
    """All found by fuzzing."""
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration="1").replace(*edit) + f'[[tree]]\nfile = "{STALK}"\n')
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    assert line.startswith(f"{path}:{where}:")


@pytest.mark.parametrize("options", [("--angles", "x.zarr", "--report", "x.zarr"),
                                     ("--report", "z.png", "--plot", "./z.png")])
def test_two_outputs_at_one_path_are_refused_before_any_work(tmp_path, options, monkeypatch):
    """The report written into --angles' path made the store fail and stay as a file; the
    plot over the report was silent (session 21, found by fuzzing)."""
    monkeypatch.chdir(tmp_path)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--no-cache", *options, exit_code=None), 2,
             "name the same file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_simplify_levels_into_a_folder_holding_a_folder_of_a_level_name_moves_nothing(tmp_path):
    """level2.lsys a folder in DIR: refused before the fit, DIR as it was (level 1 was moved
    in and the rest dropped before session 21, found by fuzzing); and the merge itself
    checks every name before its first move (`cli.io.check_merge_targets`)."""
    from plantlod.cli.io import output_folder
    from plantlod.lsys.errors import InputError

    target = tmp_path / "lv"
    (target / "level2.lsys").mkdir(parents=True)
    one_line(run_cli("simplify", STALK, "--levels", str(target), "--duration", "1",
                     exit_code=None), 2, "level2.lsys in it is a folder")
    assert sorted(os.listdir(target)) == ["level2.lsys"]
    with pytest.raises(InputError, match="level2.lsys in it is a folder"):
        with output_folder(str(target), merge=True) as tmp:
            for name in ("level1.lsys", "level2.lsys"):
                (tmp_path / tmp / name).write_text("x")
    assert sorted(os.listdir(target)) == ["level2.lsys"]
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".plantlod-")]


@pytest.mark.parametrize("head, deep, where", [
    ("", "a = " + "[" * 5000 + "]" * 5000, (1, 105)),
    ("", "a = " + "{b=" * 3000 + "1" + "}" * 3000, (1, 305)),
    # a comment, a string and a table header hold brackets that open nothing
    ('# [[[[\n[camera]\nfov_deg = 60\n\n[[tree]]\nfile = "[[[["\n', "x = " + "[" * 3000 + "]" * 3000,
     (7, 105)),
])
def test_toml_nested_thousands_deep_names_the_file_and_the_place(tmp_path, head, deep, where):
    """tomllib's RecursionError reached the command as "input nested too deeply" with no
    file (session 21, found by fuzzing), then with no line (session 32, fuzzing): the first
    bracket past MAX_SCENE_NESTING is named."""
    path = tmp_path / "s.toml"
    path.write_text(head + deep + "\n")
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
                    "nested too deeply")
    assert line.startswith(f"{path}:{where[0]}:{where[1]}: error:")


@pytest.mark.parametrize("spacing", ["0", "1e-300"])
def test_a_scatter_over_the_largest_area_places_its_trees(tmp_path, spacing):
    """Grid cells of 1e-9 m (or the spacing) across 1e300 m overflowed int(): an internal
    error (session 22, found by fuzzing). The spacing grid now has at most MAX_SCATTER_CELLS
    cells a side, and no grid without a spacing. (Since session 38 an area lies within
    MAX_SCENE_COORDINATE_M, 1e9 m, of the origin: 1e9 / 1e-300 cells a side is as many.)"""
    path = scene_file(tmp_path, f'[scatter]\nfiles = ["{STALK}"]\ncount = 2\nseed = 1\n'
                                f'area = [0, 0, 1e9, 1e9]\nmin_spacing = {spacing}\n')
    result = run_cli("scene", path, "--no-cache", "--report", "-", exit_code=None)
    assert result.exit_code == 0 and "internal error" not in result.stderr
    assert json.loads(result.stdout)["trees"] == 2


def test_a_scene_too_short_to_fit_levels_in_is_located_bad_input(tmp_path):
    """3 steps: the levels' motion fit raised compare's 'expected times (K,) matching a
    signal', exit 2 without a place (session 22, found by fuzzing)."""
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n', duration="0.034")
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
                    "is fewer than 8 steps, too short to fit levels in")
    assert line.startswith(f"{path}:2:")


def test_a_camera_near_1e308_m_is_one_line_and_leaves_nothing(tmp_path):
    """matplotlib's 'Axis limits cannot be NaN or Inf' was an internal error (session 22),
    then a runtime failure; since session 38 such a camera is bad input, at its key's line
    (every scene coordinate lies within 1e9 m of the origin)."""
    path = tmp_path / "s.toml"
    path.write_text("dt = 0.01\nduration = 1\n[wind]\nspeed = 5\n[camera]\n"
                    "[[camera.key]]\nt = 0\nposition = [0, -1e308, 1]\ntarget = [0, 0, 1]\n"
                    "[[camera.key]]\nt = 1\nposition = [0, 1e308, 1]\ntarget = [0, 1e308, 2]\n"
                    f'[[tree]]\nfile = "{STALK}"\n')
    report, plot = tmp_path / "r.json", tmp_path / "p.png"
    line = one_line(run_cli("scene", str(path), "--no-cache", "--report", str(report),
                            "--plot", str(plot), exit_code=None), 2,
                    "'position' must lie within 1e+09 m of the origin")
    assert line.startswith(f"{path}:8:")
    assert not report.exists() and not plot.exists()


@pytest.mark.parametrize("second, line, message", [
    ('file = "{stalk}"\nposition = [5, 0, 0]\nscale = -2\n', 14, "'scale' must be > 0, got -2"),
    ('file = "{stalk}"\nposition = [5, 0]\n', 13, "'position' must be a list of 3 finite"),
    ('file = "nope.lsys"\n', 12, "tree file 'nope.lsys' not found"),
])
def test_a_bad_value_in_a_second_table_is_located_at_its_own_line(tmp_path, second, line, message):
    """The line was that of the key's first appearance in the file (another tree's, or the
    camera's position) before session 22 (found by fuzzing)."""
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration="1") + f'[[tree]]\nfile = "{STALK}"\nscale = 2\n'
                    + "[[tree]]\n" + second.format(stalk=STALK))
    result = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    assert result.startswith(f"{path}:{line}:1:")


@pytest.mark.parametrize("make", ["file", "loop"])
def test_a_cache_that_is_a_regular_file_is_bad_input(tmp_path, make):
    """It was exit 1, 'File exists', once the chain was fitted (session 22, found by fuzzing;
    a loop of links in session 23)."""
    cache = tmp_path / "cache"
    if make == "file":
        cache.write_text("not a folder\n")
    else:
        cache.symlink_to(tmp_path / "other")
        (tmp_path / "other").symlink_to(cache)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    line = one_line(run_cli("scene", path, "--cache", str(cache), exit_code=None), 2,
                    "not a folder; expected a folder for the cached level chains")
    assert line.startswith(f"{cache}:")
    if make == "file":
        assert cache.read_text() == "not a folder\n"


@pytest.mark.parametrize("below", ["file/sub", "file/a/b"])
def test_a_cache_below_a_regular_file_is_bad_input_before_any_work(tmp_path, below,
                                                                   monkeypatch):
    """A cache path through a regular file (--cache, $PLANTLOD_CACHE, HOME=/dev/null) was
    exit 1, 'Not a directory', once the chain was fitted (session 30, found by fuzzing)."""
    (tmp_path / "file").write_text("x\n")
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    start = time.perf_counter()
    line = one_line(run_cli("scene", path, "--cache", str(tmp_path / below), exit_code=None), 2,
                    f"{tmp_path / 'file'} is not a folder, so no cache can be made in it")
    assert line.startswith(f"{tmp_path / below}:") and time.perf_counter() - start < 10
    monkeypatch.setenv("PLANTLOD_CACHE", str(tmp_path / below))
    one_line(run_cli("scene", path, exit_code=None), 2, "is not a folder, so no cache")


@pytest.mark.parametrize("output", ["--report", "--plot"])
def test_a_scene_output_over_one_of_its_tree_files_is_refused(tmp_path, output):
    """The tree files a scene reads are inputs (session 30: `--report treeA` replaced the tree
    file with the report, exit 0, and the next run failed on it)."""
    tree = tmp_path / ("tree.png" if output == "--plot" else "tree.json")
    tree.write_text(open(STALK).read())
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{tree}"\n')
    one_line(run_cli("scene", path, "--no-cache", output, str(tree), exit_code=None), 2,
             f"{output} would write over the input {tree} (tree file 1 of {path})")
    assert tree.read_text() == open(STALK).read()


def test_a_tree_file_with_a_byte_order_mark_runs_in_a_scene_as_derive_reads_it(tmp_path):
    """derive and simplify read a UTF-8 byte order mark; the scene decoded the file's bytes
    itself and refused it ("unexpected '\\ufeff' outside a section", session 30)."""
    tree = tmp_path / "bom.lsys"
    tree.write_bytes(b"\xef\xbb\xbf" + open(STALK, "rb").read())
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{tree}"\n')
    report = json.loads(run_cli("scene", path, "--no-cache", "--report", "-").stdout)
    plain = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    same = json.loads(run_cli("scene", plain, "--no-cache", "--report", "-").stdout)
    for key in ("branch_steps_spent", "branch_steps_full", "switches"):
        assert report[key] == same[key]


@pytest.mark.parametrize("edit, tail, message, where", [
    # an integer past a float's range overflowed math.isfinite: an internal error
    (("dt = 0.01", "dt = 0.01\nbudget_px = 1" + "0" * 400), "", "'budget_px' must be a finite number", 2),
    (("position = [0, -40, 1.7]", "position = [0, -40, 1" + "0" * 400 + "]"), "",
     "'position' must be a list of 3 finite numbers", 6),
    # [[tree]] seed was accepted and never used (session 23 refused it; session 24 grows the
    # tree from it, tests/test_scene_seeds.py), so its checks are those of a seed
    (("", ""), "seed = -3\n", "'seed' must be a whole number >= 0", 10),
])
def test_scene_values_found_by_fuzzing_in_session_23(tmp_path, edit, tail, message, where):
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration="1").replace(*edit) + f'[[tree]]\nfile = "{STALK}"\n'
                    + tail)
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    assert line.startswith(f"{path}:{where}:")


def test_a_tree_file_that_is_a_loop_of_links_is_located_bad_input(tmp_path):
    """Path.resolve raised RuntimeError ('Symlink loop'): an internal error (fuzzing)."""
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration="1") + '[[tree]]\nfile = "a"\n')
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, "tree file 'a'")
    assert line.startswith(f"{path}:9:")


def test_a_camera_far_from_the_origin_looks_where_it_is_told(tmp_path):
    """np.allclose's relative tolerance took a target 30 m ahead of a camera at UTM-like
    coordinates (4.6e6 m) for the camera's own position (found by fuzzing)."""
    from plantlod.scene.file import read_scene

    path = tmp_path / "s.toml"
    path.write_text(HEAD.format(duration="1").replace("position = [0, -40, 1.7]",
                                                     "position = [500000, 4649700, 1.7]")
                    .replace("target = [0, 0, 1.7]", "target = [500000, 4649730, 1.7]")
                    + f'[[tree]]\nfile = "{STALK}"\nposition = [500000, 4649760, 0]\n')
    scene = read_scene(str(path))
    assert scene.camera.target[1] - scene.camera.position[1] == 30.0


def test_the_report_gives_the_frame_rate_run(tmp_path):
    """A frame is whole steps: --frame-rate 10000 at dt 0.01 runs one-step frames (100 a
    second), and the report said 10000 (session 23, found by fuzzing)."""
    import json

    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    for asked, run in (("10000", 100.0), ("30", 33.333333333)):
        out = run_cli("scene", path, "--no-cache", "--frame-rate", asked, "--report", "-").stdout
        assert json.loads(out)["frame_rate"] == run


TWO_TABLES = {
    # a [[tree]]'s seed named at the [scatter]'s line, which set the same bad value first
    "tree seed after a scatter's": (
        '[scatter]\nfiles = ["S"]\ncount = 2\nseed = -1\narea = [0, 0, 9, 9]\n'
        '[[tree]]\nfile = "S"\nseed = -1\n', "'seed' must be a whole number >= 0", "seed = -1", 2),
    "tree scale after a scatter's": (
        '[scatter]\nfiles = ["S"]\ncount = 2\nscale = 0\narea = [0, 0, 9, 9]\n'
        '[[tree]]\nfile = "S"\n[[tree]]\nfile = "S"\nscale = 0\n', "'scale' must be > 0",
        "scale = 0", 2),
    "second tree without a file": (
        '[[tree]]\nfile = "S"\n[[tree]]\nposition = [1, 0, 0]\n', "missing 'file'",
        "[[tree]]", 2),
    "a camera key's time not after the one before": (
        '[[tree]]\nfile = "S"\n', "camera keys must have increasing times", "t = 1", 2),
    "a camera key without a target": (
        '[[tree]]\nfile = "S"\n', "missing 'target'", "[[camera.key]]", 2),
}


@pytest.mark.parametrize("case", sorted(TWO_TABLES))
def test_a_key_several_tables_set_is_named_in_the_table_being_read(tmp_path, case):
    """Values were located by the first line setting the key (or holding the same value)
    anywhere in the file; a table's missing key had no line. Each error now names a line of
    the section being read: the key's, or the section's header where the key is missing
    (session 25). The expected line is found in the text, not reprinted: the ``nth``
    occurrence of ``marker``."""
    body, message, marker, nth = TWO_TABLES[case]
    body = body.replace('"S"', f'"{STALK}"')
    head = HEAD.format(duration="1")
    if "camera key" in case:
        second = "target = [0, 0, 1.7]\n" if "time" in case else ""
        head = head.replace("position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n",
                            "[[camera.key]]\nt = 1\nposition = [0, -40, 1.7]\n"
                            "target = [0, 0, 1.7]\n[[camera.key]]\nt = 1\n"
                            "position = [0, -30, 1.7]\n" + second)
    text = head + body
    lines = [k + 1 for k, line in enumerate(text.splitlines()) if line.strip() == marker]
    assert len(lines) >= nth, (text, marker)
    path = tmp_path / "s.toml"
    path.write_text(text)
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    assert line.startswith(f"{path}:{lines[nth - 1]}:1: error:"), (line, text)


@pytest.mark.parametrize("array, bad, message", [
    ('tree_seeds = [\n  1, 2,   # two "good, ones" [x]\n  -3,\n]\n', "-3", "got -3"),
    ("tree_seeds = [1, 2, 'a,]b', 4]\n", "'a,]b'", "got 'a,]b'"),
    ('tree_seeds = [[1], 2]\n', "[1]", "got [1]"),
    ('files = ["S",\n         "nothere.lsys"]\n', '"nothere.lsys"', "'nothere.lsys' not found"),
])
def test_a_bad_element_of_an_array_is_named_at_its_line_and_column(tmp_path, array, bad, message):
    """An element of `tree_seeds` or `files` was named at its key's line, column 1, however
    many lines the array ran over (session 25). The expected place is the element's text
    found in the file, past the comment that holds look-alike commas and brackets."""
    body = f'[scatter]\ncount = 2\narea = [0, 0, 9, 9]\n'
    if not array.startswith("files"):
        body += 'files = ["S"]\n'
    text = HEAD.format(duration="1") + (body + array).replace('"S"', f'"{STALK}"')
    path = tmp_path / "s.toml"
    path.write_text(text)
    offset = text.index(bad, text.index(array.split("=")[0]) if not array.startswith("files")
                        else text.index("files ="))
    if "#" in array:
        offset = text.index("\n  " + bad) + 3
    line = text.count("\n", 0, offset) + 1
    column = offset - (text.rfind("\n", 0, offset) + 1) + 1
    got = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    assert got.startswith(f"{path}:{line}:{column}: error:"), (got, line, column)


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_tables_are_found_at_the_file_start_and_with_crlf(tmp_path, newline):
    """A file opening with its first table header took that table for "no header" (a missing
    key named no line), and CRLF line ends hid every header (the old whole-file search named
    a [scatter]'s seed for a [[tree]]'s); review of session 25."""
    lines = ["[[tree]]", f'file = "{STALK}"', "[[tree]]", "position = [1, 0, 0]",
             "[camera]", "position = [0, -40, 1.7]", "target = [0, 0, 1.7]"]
    path = tmp_path / "s.toml"
    path.write_bytes(newline.join(lines).encode() + newline.encode())
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             f"{path}:3:1: error: missing 'file'")
    lines = ["[scatter]", f'files = ["{STALK}"]', "count = 2", "seed = -1", "area = [0, 0, 9, 9]",
             "[[tree]]", f'file = "{STALK}"', "seed = -1",
             "[camera]", "position = [0, -40, 1.7]", "target = [0, 0, 1.7]"]
    path.write_bytes(newline.join(lines).encode() + newline.encode())
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             f"{path}:8:1: error: 'seed' must be a whole number >= 0")


@pytest.mark.parametrize("options, message", [
    (["--plot", "-"], "the report (no --report) and --plot both write to standard output"),
    (["--report", "r.json", "--angles", "-"], "--angles writes a Zarr store, a folder: standard output"),
    (["--angles", ""], "--angles writes a Zarr store, a folder: an empty name"),
])
def test_outputs_that_cannot_share_standard_output_are_refused(tmp_path, options, message,
                                                                monkeypatch):
    """`--plot -` wrote the PNG and the JSON report into one stream, exit 0; `--angles -` made
    a folder named '-' (session 25, a scene user's first hour)."""
    monkeypatch.chdir(tmp_path)
    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", path, "--no-cache", *options, exit_code=None), 2, message)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


@pytest.mark.parametrize("body, marker, message", [
    ('wind = { speed = -5, direction = 0 }\n', "wind = {", "'speed' must be >= 0"),
    ('wind.speed = -5\n', "wind.speed", "'speed' must be >= 0"),
    (f'[[tree]]\nfile = "{STALK}"\n"scale" = -2\n', '"scale"', "'scale' must be > 0"),
    ('[wind]\nspeed = 3\ngust_seed = 4\n', "gust_seed", "'gust_seed' applies to gusts"),
])
def test_inline_dotted_and_quoted_keys_are_located(tmp_path, body, marker, message):
    """Errors in an inline or dotted [wind], or a quoted key, named no line, or the table's
    header (session 25); a gust seed without gusts ran (simulate refuses it)."""
    head = "dt = 0.01\nduration = 1\n"
    tail = '[camera]\nposition = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n'
    if "[[tree]]" not in body:
        tail += f'[[tree]]\nfile = "{STALK}"\n'
    text = head + (body + tail if not body.startswith("[[tree]]") else tail + body)
    line = next(k + 1 for k, t in enumerate(text.splitlines()) if t.startswith(marker))
    path = tmp_path / "s.toml"
    path.write_text(text)
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             f"{path}:{line}:1: error: {message}")


def test_a_tree_file_that_is_a_folder_says_so(tmp_path):
    (tmp_path / "eval").mkdir()
    path = scene_file(tmp_path, '[[tree]]\nfile = "eval"\n')
    one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2,
             "tree file 'eval' is a folder")


def test_inline_tables_are_located_by_the_value_they_hold(tmp_path):
    """`tree = [{…}, {…, seed = -1}]` was named at a later [scatter]'s `seed = 42`, and an
    inline wind under a comment holding the same key at the comment (regression fuzz)."""
    text = (f'dt = 0.01\nduration = 1\n# wind = {{speed = 5}} is what we want\n'
            f'wind = {{speed = -5}}\n'
            f'[camera]\nposition = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n')
    path = tmp_path / "s.toml"
    path.write_text(text + f'[[tree]]\nfile = "{STALK}"\n')
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             f"{path}:4:1: error: 'speed' must be >= 0")
    text = (f'dt = 0.01\nduration = 1\ntree = [{{file = "{STALK}", seed = 3}}, '
            f'{{file = "{STALK}", seed = -1}}]\n'
            f'[camera]\nposition = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n'
            f'[scatter]\nfiles = ["{STALK}"]\ncount = 2\nseed = 42\narea = [0, 0, 9, 9]\n')
    path.write_text(text)
    one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
             f"{path}:3:1: error: 'seed' must be a whole number >= 0, got -1")


def test_a_scene_without_a_camera_says_which_keys_it_needs(tmp_path):
    # fov_deg and height_px have defaults (60°, 1080 px): the message lists them as optional
    path = tmp_path / "s.toml"
    path.write_text(f'dt = 0.01\nduration = 1\n[wind]\nspeed = 5\n[[tree]]\nfile = "{STALK}"\n')
    run = run_cli("scene", str(path), "--no-cache", exit_code=2)
    one_line(run, 2, "missing [camera]", "position and target",
             "optionally fov_deg (default 60) and height_px (default 1080)")
    path.write_text(f'dt = 0.01\nduration = 1\n[wind]\nspeed = 5\n[camera]\n'
                    f'position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n[[tree]]\nfile = "{STALK}"\n'
                    f'position = [0, 0, 0]\n')
    from plantlod.scene.file import read_scene
    camera = read_scene(str(path)).camera
    assert (camera.fov_deg, camera.height_px) == (60.0, 1080)


def test_a_tree_file_that_is_not_regular_is_named_so(tmp_path):
    # /dev/null exists: it was said to be "not found"
    path = scene_file(tmp_path, '[[tree]]\nfile = "/dev/null"\n')
    run = run_cli("scene", path, "--no-cache", exit_code=2)
    one_line(run, 2, "tree file '/dev/null' is not a regular file")


@pytest.mark.parametrize("camera, where, message", [
    # (session 30, found by fuzzing: the first said "missing [camera]", the second "both
    # position/target and [[camera.key]] entries")
    ('camera = "front"\n', 1, "[camera] must be a table"),
    ("[camera]\nposition = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\nkey = [1, 2]\n", 4,
     "camera keys are [[camera.key]] tables"),
])
def test_camera_tables_of_the_wrong_shape_are_named_at_their_line(tmp_path, camera, where,
                                                                 message):
    path = tmp_path / "s.toml"
    path.write_text(camera + f'dt = 0.01\nduration = 1\n[[tree]]\nfile = "{STALK}"\n'
                    if camera.startswith("camera") else
                    f'dt = 0.01\nduration = 1\n[[tree]]\nfile = "{STALK}"\n' + camera)
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2, message)
    first = 1 if camera.startswith("camera") else 5
    assert line.startswith(f"{path}:{first + where - 1}:"), line


@pytest.mark.parametrize("dt, count", [("5e-324", "more than 1e308"), ("1e-300", "1e+300")])
def test_a_time_step_too_small_to_count_its_steps_says_so_in_words(tmp_path, dt, count):
    """duration / dt overflows for a subnormal dt: the message read "is inf steps" (a
    helper's fuzzing, session 32)."""
    path = tmp_path / "s.toml"
    path.write_text(f"dt = {dt}\nduration = 1\n[[tree]]\nfile = \"{STALK}\"\n")
    line = one_line(run_cli("scene", str(path), "--no-cache", exit_code=None), 2,
                    f"is {count} steps, more than the limit of 1,000,000")
    assert "inf" not in line


@pytest.mark.parametrize("body, where, hint", [
    # two trees written [tree]: the list's entries are [[tree]] (a new user's, session 33)
    (f'[tree]\nfile = "{STALK}"\nposition = [0, 0, 0]\n  [tree]\nfile = "{STALK}"\n'
     'position = [3, 0, 0]\n', (11, 3), "the table [tree] is declared twice; several of them are "
     "written [[tree]] each (double brackets)"),
    (f'[[tree]]\nfile = "{STALK}"\nposition = [0, 0, 0]\n[camera.key]\nt = 0\n[camera.key]\n',
     (13, 1), "[[camera.key]] each"),
    # a table that is one, declared twice: no list to suggest
    (f'[[tree]]\nfile = "{STALK}"\nposition = [0, 0, 0]\n[wind]\nspeed = 2\n',
     (11, 1), "the table [wind] is declared twice; expected it once"),
])
def test_a_table_declared_twice_names_its_header_and_the_double_brackets(tmp_path, body, where,
                                                                          hint):
    path = scene_file(tmp_path, body)
    line = one_line(run_cli("scene", path, "--no-cache", exit_code=None), 2, hint)
    assert line.startswith(f"{path}:{where[0]}:{where[1]}: error: "), line


REST = "dt = 0.01\nduration = 1\n[wind]\nspeed = 5\n"
CAMERA = "[camera]\nposition = [0, -20, 1.7]\ntarget = [0, 0, 1]\n"


@pytest.mark.parametrize("text, where, said", [
    # a missing key of a table written inline: at that table (session 38's fuzzing; the
    # [[tree]] form always said its header's line)
    ('tree = [{file="t.lsys"}, {}]\n' + REST + CAMERA, (1, 26), "missing 'file'"),
    ("tree = [\n  {file='t.lsys'},\n  {seed = 3},\n]\n" + REST + CAMERA, (3, 3), "missing 'file'"),
    ('scatter = {files=["t.lsys"], area=[0,0,1,1]}\n' + REST + CAMERA, (1, 1), "missing 'count'"),
    ('tree = [{file="t.lsys"}]\n' + REST + "[camera]\nkey = [{t=0, position=[0,-20,1.7]}]\n",
     (7, 8), "missing 'target'"),
    ('tree = [{file="t.lsys"}]\ncamera.key = [{t=0, position=[0,-20,1.7]}]\n' + REST,
     (2, 15), "missing 'target'"),
    # TOML that ends inside a string, an array or a table: where the text ends
    ('tree = [{file="t.lsys"}]\n' + REST + 'x = """abc\n', (6, 11), "Unterminated string"),
    ("dt = ", (1, 6), "Invalid value"),
    ("x = [1, 2\n\n", (1, 10), "Unclosed array"),
])
def test_scene_errors_name_the_place_of_inline_tables_and_of_the_end(tmp_path, text, where, said):
    from plantlod.lsys.errors import InputError
    from plantlod.scene.file import read_scene

    (tmp_path / "t.lsys").write_text(open(STALK, encoding="utf-8").read())
    path = tmp_path / "q.toml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        read_scene(str(path))
    assert (info.value.line, info.value.col) == where
    assert said in info.value.message


def test_a_missing_tree_file_says_where_it_was_looked_for_only_when_relative(tmp_path):
    from plantlod.lsys.errors import InputError
    from plantlod.scene.file import read_scene

    for name, said in (("nope.lsys", f"not found (looked in {tmp_path})"),
                       (str(tmp_path / "abs" / "nope.lsys"), "not found")):
        path = tmp_path / "q.toml"
        path.write_text(REST + f"[[tree]]\nfile = {name!r}\n" + CAMERA)
        with pytest.raises(InputError) as info:
            read_scene(str(path))
        assert info.value.message.endswith(said) and (info.value.line, info.value.col) == (6, 1)


def test_a_dt_too_large_for_a_tree_names_the_scene_that_set_it(tmp_path):
    """The stability error named the tree file only; the dt is the scene's (session 40, a
    helper's fuzzing). k_bs 100,000 at dt 0.05 s: s = 5 >= 4 (model.md 4)."""
    tree = tmp_path / "stiff.lsys"
    tree.write_text("derivation_length: 2\nbranching_angle: 30\nforce_absorbed: 0.002\n"
                    "force_propagated: 0.7\nbranch F: length=0.5 radius=0.01 "
                    "bend_strength=100000 rotation_strength=30\nleaf L: area=0.01\naxiom: A\n"
                    "productions:\n  A -> F [+A L] [-A L]\n")
    scene = tmp_path / "s.toml"
    scene.write_text('dt = 0.05\nduration = 2\n[camera]\nposition = [0, -20, 1.7]\n'
                     'target = [0, 0, 1]\n[[tree]]\nfile = "stiff.lsys"\n')
    one_line(run_cli("scene", str(scene), "--no-cache", exit_code=None), 2,
             "stiff.lsys: error: time step too large", "s = k*dt/1000 = 5 >= 4",
             f"(dt 0.05 s is the scene's: {scene})")


def test_a_camera_key_time_written_as_a_huge_whole_number_is_a_time(tmp_path):
    """A key time of 10^23 written as digits reached numpy as an object array (an internal
    error; 1e23 written as a float ran): a number where the scene asks for one is a float
    (session 42, fuzzing)."""
    stalk = str(ROOT / "examples" / "stalk8.lsys")
    text = ("dt = 0.01\nduration = 0.1\n[wind]\nspeed = 5\n"
            "[[camera.key]]\nt = 0\nposition = [0, -20, 1]\ntarget = [0, 0, 1]\n"
            "[[camera.key]]\nt = {t}\nposition = [0, 20, 1]\ntarget = [0, 0, 1]\n"
            f'[[tree]]\nfile = "{stalk}"\n')
    reports = []
    for t in ("99999999999999999999999", "1e23"):
        path = tmp_path / "k.toml"
        path.write_text(text.format(t=t))
        reports.append(json.loads(run_cli("scene", str(path), "--no-cache").stdout))
    assert reports[0] == reports[1]


def test_what_answers_at_the_scheduler_address_is_said_in_one_line(tmp_path):
    """A cluster fuzzing round: a port answering with another service's bytes ended in "out of
    memory" (dask read them as a frame length); a scheduler without workers waited for ever.
    Each is one line, exit 1. (The scheduler lost mid-run, about 30 lines of dask's logging
    before, was checked by hand: one line.)"""
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    import socket
    import threading

    import plantlod.scene.run as scene_run

    path = scene_file(tmp_path, f'[[tree]]\nfile = "{STALK}"\n')
    cache = str(tmp_path / "cache")
    run_cli("scene", path, "--cache", cache)                  # (the chain, before the clusters)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def answer():
        conn, _ = server.accept()
        conn.sendall(b"HTTP/1.0 200 OK\r\n\r\nhello" * 100)

    threading.Thread(target=answer, daemon=True).start()
    other = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    one_line(run_cli("scene", path, "--cache", cache, "--scheduler", other, exit_code=None), 1,
             f"plantlod scene: error: the scheduler at {other} answered with what no Dask "
             "scheduler sends")
    server.close()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(scene_run, "CLUSTER_TIMEOUT_S", 2.0)
        with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp://",
                                      dashboard_address=None) as cluster:
            address = cluster.scheduler_address
            one_line(run_cli("scene", path, "--cache", cache, "--scheduler", address,
                             exit_code=None), 1,
                     f"plantlod scene: error: the scheduler at {address} has no workers (waited "
                     "2 s)")
