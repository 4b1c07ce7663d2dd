"""What every command shares: help texts, input errors, atomic output, determinism,
start-up cost, and the golden-file utility itself."""

from __future__ import annotations

import ast
import os
import re
import stat
import subprocess
import threading

import pytest

import golden_util
from golden_util import ROOT, assert_golden, run_cli

PYTHON = str(ROOT / ".venv" / "bin" / "python")
PLANTLOD = str(ROOT / ".venv" / "bin" / "plantlod")
STALK8 = "examples/stalk8.lsys"

# For each command that reads one input file: the rest of a valid command line.
READERS = {
    "derive": (),
    "simulate": ("--dt", "0.01", "--steps", "3", "--wind-speed", "2"),
}


def _registered_commands() -> list[str]:
    from plantlod.cli.main import cli

    return sorted(cli.commands)


# --- help -----------------------------------------------------------------------------

def test_root_help_has_an_example_block():
    out = run_cli("--help").stdout
    assert "Example" in out, "`plantlod --help` should show an Example block"


def test_root_help_lists_every_command():
    out = run_cli("--help").stdout
    commands = out.split("Commands:", 1)[1]
    for name in _registered_commands():
        assert f"\n  {name} " in commands, f"{name} is missing from `plantlod --help`"


def test_plantlod_alone_prints_its_help_as_help_does():
    """`plantlod` with no command: the help, laid out as `--help` lays it out, on stderr,
    exit 2 (click's own choice); it was squashed into one `error: Usage: …` line (a new
    user's report, session 33)."""
    done = subprocess.run([PLANTLOD], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.splitlines()
    assert lines[0] == "Usage: plantlod [OPTIONS] COMMAND [ARGS]..." and "error" not in lines[0]
    # (the same text as --help's up to the width the commands' summaries are cut at)
    assert lines[:10] == run_cli("--help").stdout.splitlines()[:10]
    for name in _registered_commands():
        assert any(line.startswith(f"  {name} ") for line in lines), name


def test_derive_and_simulate_are_registered():
    assert {"derive", "simulate"} <= set(_registered_commands())


@pytest.mark.parametrize("name", _registered_commands())
def test_every_command_help_has_an_example(name):
    out = run_cli(name, "--help").stdout
    assert out.startswith(f"Usage: plantlod {name} ")
    assert "Example" in out
    example = out.split("Example", 1)[1]
    # the example block shows at least one full command line of this command
    assert f"plantlod {name} " in example
    assert run_cli(name, "-h").stdout == out


def test_version():
    assert run_cli("--version").stdout.startswith("plantlod, version ")


# --- input errors shared by the commands that read a file -----------------------------------

def _input_error(result, name: str, message: str) -> None:
    assert result.stdout == ""
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    assert re.match(rf"{re.escape(name)}(:\d+:\d+)?: error: ", result.stderr), result.stderr
    assert message in result.stderr


@pytest.mark.parametrize("command", sorted(READERS))
def test_missing_file(command, tmp_path):
    result = run_cli(command, "nothing.lsys", *READERS[command], exit_code=2, cwd=tmp_path)
    _input_error(result, "nothing.lsys", "no such file")


@pytest.mark.parametrize("command", sorted(READERS))
def test_directory_instead_of_file(command, tmp_path):
    (tmp_path / "adir").mkdir()
    result = run_cli(command, "adir", *READERS[command], exit_code=2, cwd=tmp_path)
    _input_error(result, "adir", "directory")


@pytest.mark.parametrize("command", sorted(READERS))
def test_non_utf8_file(command, tmp_path):
    text = (ROOT / STALK8).read_bytes().replace(b"name: stalk8", b"name: st\xe4lk8")
    (tmp_path / "latin1.lsys").write_bytes(text)
    result = run_cli(command, "latin1.lsys", *READERS[command], exit_code=2, cwd=tmp_path)
    offset = text.index(b"\xe4")
    _input_error(result, "latin1.lsys", f"not UTF-8 text (byte {offset})")


@pytest.mark.parametrize("command", sorted(READERS))
def test_non_utf8_stdin(command):
    result = run_cli(command, "-", *READERS[command], input=b"\xff\xfe\x00", exit_code=2)
    _input_error(result, "<stdin>", "not UTF-8")


@pytest.mark.parametrize("command", sorted(READERS))
def test_empty_stdin(command):
    result = run_cli(command, "-", *READERS[command], input="", exit_code=2)
    assert result.stderr.startswith("<stdin>:1:1: error: ")
    assert result.stderr.count("\n") == 1


def test_bad_tree_file_is_located(tmp_path):
    """A tree file with a bad parent: file:line:col of the offending key (docs/tree-format.md)."""
    lines = run_cli("derive", STALK8).stdout.splitlines(keepends=True)
    lines[3] = lines[3].replace('"parent": 1', '"parent": 5')
    (tmp_path / "t.jsonl").write_text("".join(lines), encoding="utf-8")
    result = run_cli("simulate", "t.jsonl", *READERS["simulate"], exit_code=2, cwd=tmp_path)
    col = lines[3].index('"parent"') + 1
    assert result.stderr.startswith(f"t.jsonl:4:{col}: error: ")
    assert result.stderr.count("\n") == 1


# --- the io helpers -----------------------------------------------------------------------

def test_open_output_is_atomic(tmp_path):
    from plantlod.cli.io import open_output

    target = tmp_path / "out.txt"
    target.write_text("old\n")
    with pytest.raises(RuntimeError):
        with open_output(str(target)) as out:
            out.write("partial")
            raise RuntimeError("boom")
    assert target.read_text() == "old\n"                  # untouched
    assert os.listdir(tmp_path) == ["out.txt"]            # temporary file removed
    with open_output(str(target)) as out:
        out.write("a\nb\n")
    assert target.read_bytes() == b"a\nb\n"
    assert os.listdir(tmp_path) == ["out.txt"]


def test_open_output_sets_the_usual_mode(tmp_path):
    from plantlod.cli.io import open_output

    umask = os.umask(0o022)
    try:
        with open_output(str(tmp_path / "m.txt")) as out:
            out.write("x\n")
    finally:
        os.umask(umask)
    assert stat.S_IMODE(os.stat(tmp_path / "m.txt").st_mode) == 0o644


def test_open_output_writes_a_pipe_in_place(tmp_path):
    """A named pipe (like /dev/null, not a regular file) must stay what it is."""
    from plantlod.cli.io import open_output

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(fifo.read_bytes()))
    reader.start()
    with open_output(str(fifo)) as out:
        out.write("a\nb\n")
    reader.join(timeout=10)
    assert received == [b"a\nb\n"]
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert sorted(os.listdir(tmp_path)) == ["pipe"]


def test_open_output_binary(tmp_path):
    from plantlod.cli.io import open_output

    with open_output(str(tmp_path / "b.bin"), binary=True) as out:
        out.write(b"\x00\xff")
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\xff"


def test_output_to_a_directory_is_refused(tmp_path):
    result = run_cli("derive", STALK8, "-o", str(tmp_path), exit_code=2)
    assert "is a directory" in result.stderr and result.stderr.count("\n") == 1
    assert os.listdir(tmp_path) == []


def test_count_words():
    from plantlod.cli.io import count

    assert [count(1, "leaf"), count(2, "leaf"), count(1, "branch"), count(1234, "branch"),
            count(0, "module")] == ["1 leaf", "2 leaves", "1 branch", "1,234 branches",
                                    "0 modules"]


def test_tree_files_are_told_by_content():
    from plantlod.formats.kinds import looks_like_tree_file

    assert looks_like_tree_file('\n  {"format": "plantlod-tree"}\n')
    assert not looks_like_tree_file("# {not a tree}\nname: x\n")
    assert not looks_like_tree_file("")


# --- determinism across processes ------------------------------------------------------------

@pytest.mark.parametrize("args", [
    ("derive", "examples/abop_1_25.lsys"),
    ("derive", "examples/abop_2_6.lsys", "--format", "string", "-n", "5"),
    ("simulate", "examples/abop_1_24a.lsys", "-n", "2", "--dt", "0.01", "--steps", "30",
     "--wind", "3,1,0", "--gust-strength", "0.4", "--gust-seed", "7"),
])
def test_output_independent_of_hash_seed(args):
    outputs = []
    for seed in ("0", "12345"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        done = subprocess.run([PLANTLOD, *args], cwd=ROOT, env=env, capture_output=True,
                              timeout=120)
        assert done.returncode == 0, done.stderr
        outputs.append(done.stdout)
    assert outputs[0] == outputs[1]
    assert len(outputs[0]) > 1000


def test_subprocess_output_equals_in_process_output():
    done = subprocess.run([PLANTLOD, "derive", STALK8], cwd=ROOT, capture_output=True, timeout=60)
    assert done.stdout.decode("utf-8") == run_cli("derive", STALK8).stdout


# --- start-up cost ---------------------------------------------------------------------------

HEAVY_MODULES = ("numba", "numpy", "scipy", "trimesh", "rich")


def modules_imported_by(args: list[str]) -> list[str]:
    """Which of HEAVY_MODULES a fresh interpreter has imported after `plantlod ARGS`."""
    code = ("import sys; from plantlod.cli.main import cli\n"
            f"try:\n    cli({args!r}, prog_name='plantlod')\n"
            "except SystemExit as e:\n    assert not e.code, e.code\n"
            f"print('LOADED', sorted(m for m in {HEAVY_MODULES!r} if m in sys.modules), "
            "file=sys.stderr)")
    done = subprocess.run([PYTHON, "-c", code], cwd=ROOT, capture_output=True, text=True,
                          timeout=60)
    lines = [line for line in done.stderr.splitlines() if line.startswith("LOADED ")]
    assert len(lines) == 1, done.stderr
    return ast.literal_eval(lines[0][len("LOADED "):])


def test_help_does_not_import_heavy_modules():
    """`plantlod --help` must not pay for numba, numpy, scipy, trimesh or rich."""
    assert modules_imported_by(["--help"]) == []


def test_derive_does_not_import_numba():
    assert "numba" not in modules_imported_by(["derive", "examples/stalk8.lsys", "-o", "/dev/null"])


def test_a_short_simulate_imports_only_numpy():
    """A short run is interpreted (sim/kernel.py): no numba, scipy or rich on its path."""
    assert modules_imported_by(["simulate", "examples/stalk8.lsys", "--dt", "0.01", "--steps",
                                "10", "--wind-speed", "5", "-o", "/dev/null"]) == ["numpy"]


# --- the golden-file utility -----------------------------------------------------------------

@pytest.fixture
def scratch_golden(tmp_path, monkeypatch):
    """golden_util pointed at an empty folder, with regeneration off."""
    monkeypatch.setattr(golden_util, "GOLDEN_DIR", tmp_path)
    monkeypatch.delenv(golden_util.REGEN_VARIABLE, raising=False)
    return tmp_path


def test_golden_util_missing_file_says_make_golden(scratch_golden):
    with pytest.raises(pytest.fail.Exception, match="make golden"):
        assert_golden("x.txt", "a\n")
    assert os.listdir(scratch_golden) == []


def test_golden_util_regenerates_then_compares(scratch_golden, monkeypatch):
    monkeypatch.setenv(golden_util.REGEN_VARIABLE, "1")
    assert_golden("sub/x.txt", "a\nb\n")
    assert (scratch_golden / "sub" / "x.txt").read_bytes() == b"a\nb\n"
    monkeypatch.delenv(golden_util.REGEN_VARIABLE)
    assert_golden("sub/x.txt", "a\nb\n")
    with pytest.raises(pytest.fail.Exception) as failure:
        assert_golden("sub/x.txt", "a\nc\n")
    message = str(failure.value)
    assert "-b" in message and "+c" in message and "make golden" in message
    assert (scratch_golden / "sub" / "x.txt.obtained").read_bytes() == b"a\nc\n"
    assert (scratch_golden / "sub" / "x.txt").read_bytes() == b"a\nb\n"     # not overwritten
    assert_golden("sub/x.txt", "a\nb\n")                                      # stale .obtained
    assert not (scratch_golden / "sub" / "x.txt.obtained").exists()


def test_golden_util_is_byte_exact(scratch_golden):
    (scratch_golden / "x.txt").write_bytes(b"a\r\nb\n")
    with pytest.raises(pytest.fail.Exception, match="differs"):
        assert_golden("x.txt", "a\nb\n")
    assert (scratch_golden / "x.txt.obtained").read_bytes() == b"a\nb\n"
    (scratch_golden / "y.txt").write_bytes(b"a\n")
    with pytest.raises(pytest.fail.Exception):
        assert_golden("y.txt", "a")


def test_golden_util_rejects_names_outside_the_folder(scratch_golden):
    for name in ("../x.txt", "/tmp/x.txt", ""):
        with pytest.raises(ValueError):
            assert_golden(name, "a\n")


def test_golden_util_only_regenerates_on_1(scratch_golden, monkeypatch):
    monkeypatch.setenv(golden_util.REGEN_VARIABLE, "0")
    with pytest.raises(pytest.fail.Exception, match="make golden"):
        assert_golden("x.txt", "a\n")


def test_run_cli_reports_unexpected_exit_codes():
    with pytest.raises(pytest.fail.Exception, match="exited 2, expected 0"):
        run_cli("derive", "no-such-file.lsys")
    assert run_cli("derive", "no-such-file.lsys", exit_code=None).exit_code == 2

