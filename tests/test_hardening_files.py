"""What lies around a file's content (session 43's file-level fuzzing round, about 750 cases
over every command): byte-order marks, names with control characters, standard input,
folders the user cannot write in, unreadable tree files of a scene, one FIFO given twice.
Each case failed on the code before: a message naming the wrong thing, no place, a wrong
exit code or a run that went on."""

from __future__ import annotations

import os
import shutil
import subprocess

import pytest

from golden_util import ROOT, run_cli
from test_hardening_cli import one_line

STALK = ROOT / "examples" / "stalk8.lsys"
PLANTLOD = str(ROOT / ".venv" / "bin" / "plantlod")
BOM = b"\xef\xbb\xbf"
SCENE = ("dt = 0.01\nduration = 1\n\n[camera]\nposition = [0, -20, 1.7]\ntarget = [0, 0, 1.7]\n"
         "\n[wind]\nspeed = 5\n\n[[tree]]\nfile = \"s.lsys\"\nposition = [0, 0, 0]\n")


def without_root(*args: str) -> list[str]:
    """``plantlod ARGS`` run so that file permissions apply: as root, without the capability
    that overrides them (setpriv); skipped where neither is possible."""
    if os.geteuid() != 0:
        return [PLANTLOD, *args]
    if shutil.which("setpriv") is None:
        pytest.skip("running as root without setpriv: file permissions do not apply")
    return ["setpriv", "--bounding-set=-dac_override,-dac_read_search", PLANTLOD, *args]


def run(command: list[str], cwd) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300)


def test_a_second_byte_order_mark_is_placed_in_a_tree_file(tmp_path):
    """Two BOMs before a tree file's first record: it was taken for an .lsys, whose parser
    then said it was "a tree file (JSON Lines), not an L-system", with no place."""
    tree = tmp_path / "t.jsonl"
    run_cli("derive", str(STALK), "-o", str(tree))
    doubled = tmp_path / "t2.jsonl"
    doubled.write_bytes(BOM * 2 + tree.read_bytes())
    for args in (("simulate", str(doubled), "--dt", "0.01", "--steps", "3", "--wind-speed", "1"),
                 ("compare", str(doubled), str(doubled), "--dt", "0.01", "--steps", "3",
                  "--wind-speed", "1")):
        one_line(run_cli(*args, exit_code=None), 2, f"{doubled}:1:1: error: not valid JSON")


def test_a_second_byte_order_mark_is_placed_by_the_api_too(tmp_path):
    import plantlod

    tree = tmp_path / "t.jsonl"
    run_cli("derive", str(STALK), "-o", str(tree))
    doubled = tmp_path / "t2.jsonl"
    doubled.write_bytes(BOM * 2 + tree.read_bytes())
    with pytest.raises(plantlod.InputError) as info:
        plantlod.simulate(str(doubled), wind=(1, 0, 0), dt=0.01, steps=3)
    assert (info.value.line, info.value.col) == (1, 1)
    assert info.value.message.startswith("not valid JSON")


def test_a_long_path_is_named_whole(tmp_path):
    """A path of more than 200 characters was cut in its middle in FILE:LINE:COL (a name no
    editor can open; a review); the line is cut to 1,000 characters as a whole."""
    folder = tmp_path / ("a" * 120) / ("b" * 120)
    folder.mkdir(parents=True)
    bad = folder / "x.lsys"
    bad.write_text("axiom: Q(\n")
    one_line(run_cli("derive", str(bad), "-o", str(tmp_path / "x.jsonl"), exit_code=None), 2,
             f"{bad}:1:10: error:")


def test_a_second_byte_order_mark_in_a_wind_file_is_no_header(tmp_path):
    """The wind file's first row was taken for a header where its first field alone was no
    number (a BOM left before it), and dropped: the run went on with another wind, exit 0.
    A header is a row of which no field is a number."""
    doubled = tmp_path / "w.csv"
    doubled.write_bytes(BOM * 2 + b"0,5,0,0\n10,5,0,0\n")
    one_line(run_cli("simulate", str(STALK), "--dt", "0.01", "--steps", "3", "--wind-file",
                     str(doubled), exit_code=None), 2,
             f"{doubled}:1:1: error: expected a finite number for t, got '\\ufeff0'")
    header = tmp_path / "h.csv"
    header.write_text("time,vx,vy,vz\n0,5,0,0\n10,5,0,0\n")
    plain = tmp_path / "p.csv"
    plain.write_text("0,5,0,0\n10,5,0,0\n")
    runs = [run_cli("simulate", str(STALK), "--dt", "0.01", "--steps", "30", "--wind-file",
                    str(path)).stdout for path in (header, plain)]
    assert runs[0] == runs[1]


def test_a_file_name_with_a_line_break_is_shown_quoted(tmp_path):
    """'c\\nd.lsys' was shown as "c d.lsys", the name of another file."""
    bad = tmp_path / "c\nd.lsys"
    bad.write_text("axiom: Q(\n")
    result = run_cli("derive", str(bad), "-o", str(tmp_path / "x.jsonl"), exit_code=None)
    one_line(result, 2, f"{str(bad)!r}:1:10: error:")


def test_a_scene_on_standard_input_is_named_stdin():
    result = run_cli("scene", "-", input="dt = 0.01\nduration = 1\n\n[camera]\n"
                                         "position = [0, -20, 1.7]\n", exit_code=None)
    one_line(result, 2, "<stdin>:4:1: error: missing 'target'")


def test_outputs_where_the_user_cannot_write_are_refused_before_the_work(tmp_path):
    """A folder the user cannot enter was refused before the work (exit 2) and a read-only one
    after it (exit 1, "cannot write ro/x.jsonl"); folder outputs (--levels, --obj, a scene's
    --angles) failed after the work too. Now all before it, exit 2, naming the output."""
    (tmp_path / "s.lsys").write_bytes(STALK.read_bytes())
    (tmp_path / "sc.toml").write_text(SCENE)
    for folder, mode in (("ro", 0o555), ("nx", 0o000)):
        (tmp_path / folder).mkdir(mode=mode)
    cases = [(("derive", "s.lsys", "-o", "ro/x.jsonl"), "ro/x.jsonl: error: cannot write in "
                                                         "its folder: permission denied"),
             (("derive", "s.lsys", "-o", "nx/x.jsonl"), "nx/x.jsonl: error: cannot write in "
                                                         "its folder: permission denied"),
             (("simplify", "s.lsys", "--levels", "ro"), "ro: error: cannot write in it: "
                                                         "permission denied"),
             (("simplify", "s.lsys", "--levels", "ro/a/b"), f"ro/a/b: error: cannot write in "
                                                             f"{tmp_path / 'ro'}: permission"),
             (("scene", "sc.toml", "--angles", "ro/s.zarr"), "ro/s.zarr: error: cannot write in "
                                                             "its folder: permission denied")]
    try:
        for args, message in cases:
            done = run(without_root(*args), tmp_path)
            assert done.returncode == 2 and done.stderr.startswith(message), (args, done.stderr)
            assert done.stderr.count("\n") == 1
        done = run(without_root("derive", "s.lsys", "-o", "/dev/null"), tmp_path)
        assert done.returncode == 0, done.stderr          # (a device is written in place)
    finally:
        for folder in ("ro", "nx"):
            (tmp_path / folder).chmod(0o755)
    assert sorted(os.listdir(tmp_path / "ro")) == [] and os.listdir(tmp_path / "nx") == []


def test_a_scene_names_its_tree_file_that_cannot_be_read(tmp_path):
    """It said "/abs/path/s.lsys: error: permission denied", naming neither the scene nor the
    line that names the file, where a missing one is named at that line."""
    tree = tmp_path / "s.lsys"
    tree.write_bytes(STALK.read_bytes())
    (tmp_path / "sc.toml").write_text(SCENE)
    tree.chmod(0o000)
    try:
        done = run(without_root("scene", "sc.toml"), tmp_path)
    finally:
        tree.chmod(0o644)
    assert done.returncode == 2
    assert done.stderr == ("sc.toml:12:1: error: tree file 's.lsys' cannot be read: "
                           "permission denied\n")


def test_one_named_pipe_given_twice_is_refused(tmp_path):
    """`compare p.fifo p.fifo` (or `export p.fifo p.fifo`) waited for ever at the second open,
    where `- -` is refused: a pipe can be read once. Refused before either is opened."""
    fifo = tmp_path / "p.fifo"
    os.mkfifo(fifo)
    for args, names in ((("compare", "p.fifo", "p.fifo", "--dt", "0.01", "--steps", "3",
                          "--wind-speed", "1"), "ORIGINAL and SIMPLIFIED 1"),
                        (("export", "p.fifo", "p.fifo", "-o", "x.glb"), "TREE and ANGLES")):
        done = run([PLANTLOD, *args], tmp_path)
        assert done.returncode == 2, done.stderr
        assert done.stderr.startswith(f"plantlod {args[0]}: error: {names} both read the pipe "
                                      "p.fifo, which can be read once")
    assert sorted(os.listdir(tmp_path)) == ["p.fifo"]


def test_standard_input_from_the_named_pipe_given_too_is_refused(tmp_path):
    """`compare - p.fifo < p.fifo` waited for ever (a review): stdin is that pipe."""
    fifo = tmp_path / "p.fifo"
    os.mkfifo(fifo)
    writer = subprocess.Popen(["bash", "-c", f"cat {STALK} > p.fifo"], cwd=tmp_path)
    try:
        with open(fifo, "rb") as stdin:
            done = subprocess.run([PLANTLOD, "compare", "-", "p.fifo", "--dt", "0.01", "--steps",
                                   "3", "--wind-speed", "1"], cwd=tmp_path, stdin=stdin,
                                  capture_output=True, text=True, timeout=300)
    finally:
        writer.wait(timeout=60)
    assert done.returncode == 2 and "both read the pipe p.fifo" in done.stderr


def test_a_read_only_file_system_is_a_failure_before_the_work(tmp_path):
    """os.access says no on a read-only file system too: it was refused as "permission
    denied", exit 2 (a review); it is a failure to write (exit 1, docs/errors.md), said as
    what it is, and still before the work. Mounts a read-only tmpfs (root only)."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a read-only tmpfs needs root")
    ro = tmp_path / "ro"
    ro.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(ro)]).returncode:
        pytest.skip("this machine does not let a tmpfs be mounted here")
    try:
        for args, said in ((("derive", str(STALK), "-o", "ro/x.jsonl"),
                            "plantlod derive: error: cannot write ro/x.jsonl: its folder is on "
                            "a read-only file system"),
                           (("simplify", str(STALK), "--levels", "ro/lv"),
                            f"plantlod simplify: error: cannot write ro/lv: {ro} is on a "
                            "read-only file system")):
            done = run([PLANTLOD, *args], tmp_path)
            assert (done.returncode, done.stderr) == (1, said + "\n")
    finally:
        subprocess.run(["umount", str(ro)], check=True)
