"""The CLI's error discipline (issue 16), for every command: exit 2 and one line for bad
input and usage, exit 1 and one line for run-time failures (output that cannot be
written included), 128 + n for signals, and nothing partial left behind.

Signal tests run the real executable (subprocess); everything else runs in-process.
"""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from golden_util import ROOT, run_cli

PLANTLOD = str(ROOT / ".venv" / "bin" / "plantlod")
STALK8 = "examples/stalk8.lsys"
SIM = ("--dt", "0.01", "--steps", "3", "--wind-speed", "2")


def commands() -> list[str]:
    from plantlod.cli.main import cli

    return sorted(cli.commands)


def one_line(result, code: int, *fragments: str) -> str:
    """The result ended with ``code`` and exactly one stderr line holding ``fragments``."""
    assert result.exit_code == code, (result.exit_code, result.stderr, result.exception)
    assert "Traceback" not in result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def no_temporary_files(directory) -> None:
    assert not [p for p in os.listdir(directory) if p.startswith(".plantlod-")]


# --- usage errors: one line, exit 2, for every command ----------------------------------

@pytest.mark.parametrize("name", commands())
def test_unknown_option_is_one_line(name):
    line = one_line(run_cli(name, "--no-such-option", exit_code=None), 2, f"plantlod {name}: error:")
    assert "--no-such-option" in line and f"'plantlod {name} --help'" in line


@pytest.mark.parametrize("name", commands())
def test_missing_argument_is_one_line(name):
    result = run_cli(name, exit_code=None)
    one_line(result, 2, f"plantlod {name}: error:")


def test_unknown_command_is_one_line():
    one_line(run_cli("nosuch", exit_code=None), 2, "plantlod: error: No such command")


@pytest.mark.parametrize("args, fragment", [
    (("simulate", STALK8, "--dt", "nan", "--steps", "3"), "'--dt': 'nan' is not a finite"),
    (("simulate", STALK8, "--dt", "inf", "--steps", "3"), "not a finite"),
    (("simulate", STALK8, "--dt", "1e-320", "--duration", "10"), "smallest time step"),
    (("simulate", STALK8, "--dt", "1e-9", "--duration", "1e308"), "the limit of one run"),
    (("simulate", STALK8, "--dt", "0.01", "--steps", "1" + "0" * 30), "too large"),
    (("simulate", STALK8, "--dt", "0.01", "--steps", "3", "--wind-direction", "45"),
     "--wind-direction applies to --wind-speed"),
    (("simulate", STALK8, "--dt", "0.01", "--steps", "3", "--gust-seed", "4"),
     "--gust-seed applies to gusts"),
    (("compare", STALK8, STALK8, *SIM, "--max-amplitude-error", "nan"), "not a finite"),
    (("compare", STALK8, STALK8, *SIM, "--max-tip-error", "inf"), "not a finite"),
    (("derive", STALK8, "-n", "99999999999999999999999"), "too large"),
    (("derive", STALK8, "-n", "10001"), "more than the limit of 10,000 steps"),
])
def test_bad_option_values(args, fragment):
    one_line(run_cli(*args, exit_code=None), 2, fragment)


def test_zero_wind_warns_but_runs():
    result = run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "3")
    assert "warning: the wind is zero" in result.stderr
    assert run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "3", "--wind-speed", "0"
                   ).stderr.count("warning: the wind is zero") == 1
    assert "wind is zero" not in run_cli("simulate", STALK8, *SIM).stderr


def test_refused_run_prints_no_pending_warning():
    # zero wind (a warning) and an unstable dt (the error): one line, the error
    one_line(run_cli("simulate", STALK8, "--dt", "250", "--steps", "3", exit_code=None), 2,
             "time step too large")


# --- output that cannot be written: exit 1, one line, nothing left ----------------------

def test_dev_full_as_output(tmp_path):
    one_line(run_cli("derive", STALK8, "-o", "/dev/full", exit_code=None), 1,
             "cannot write /dev/full: No space left on device")
    # export's glTF through a link to /dev/full named no file (session 23, found by fuzzing)
    angles = tmp_path / "a.csv"
    run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "20", "--wind-speed", "5",
            "-o", str(angles))
    (tmp_path / "full.glb").symlink_to("/dev/full")
    one_line(run_cli("export", STALK8, str(angles), "-o", str(tmp_path / "full.glb"),
                     exit_code=None), 1, "full.glb: No space left on device")


@pytest.mark.parametrize("code, reason", [(errno.EROFS, "Read-only file system"),
                                          (errno.EACCES, "Permission denied")])
def test_unwritable_directory(tmp_path, monkeypatch, code, reason):
    from plantlod.formats import atomic

    def refuse(*args, **kwargs):
        raise OSError(code, os.strerror(code))
    monkeypatch.setattr(atomic, "new_temporary", refuse)
    one_line(run_cli("derive", STALK8, "-o", str(tmp_path / "t.jsonl"), exit_code=None), 1,
             f"t.jsonl: {reason}")
    assert os.listdir(tmp_path) == []


def test_disk_full_while_writing_leaves_nothing(tmp_path, monkeypatch):
    import plantlod.cli.io as cli_io

    real = cli_io._open_stream

    class Full:
        def __init__(self, stream):
            self.stream = stream

        def write(self, text):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.stream.close()

    monkeypatch.setattr(cli_io, "_open_stream",
                        lambda target, binary, name=None: Full(real(target, binary, name)))
    for args in (("derive", STALK8), ("simulate", STALK8, *SIM)):
        one_line(run_cli(*args, "-o", str(tmp_path / "out"), exit_code=None), 1,
                 "No space left on device")
    assert os.listdir(tmp_path) == []


def test_internal_error_is_one_line(monkeypatch):
    import plantlod.lsys.build as build

    def broken(*args, **kwargs):
        raise ValueError("boom\nsecond line")
    monkeypatch.setattr(build, "build", broken)
    line = one_line(run_cli("derive", STALK8, exit_code=None), 1, "internal error: ValueError")
    assert "boom second line" in line and "PLANTLOD_DEBUG" in line
    monkeypatch.setenv("PLANTLOD_DEBUG", "1")
    assert "Traceback" in run_cli("derive", STALK8, exit_code=None).stderr


def test_closed_stdin_is_bad_input():
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} derive - <&-"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.splitlines() == [
        "<stdin>: error: standard input is closed; expected a file name or data on stdin"]


@pytest.mark.parametrize("progress", ["--no-progress", "--progress"])
def test_a_reader_of_stderr_that_goes_away_changes_nothing(tmp_path, progress):
    """docs/errors.md: a stderr that is closed loses the messages, never the exit code. With
    SIGPIPE's default action the first message after the reader left killed the command:
    141 in place of 0, and with --progress no output and its temporary file left."""
    out = tmp_path / "a.csv"
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} simulate {STALK8} --dt 0.01 --steps 20000 "
                           f"--wind-speed 5 -o {out} {progress} 2>&1 | (exec true); "
                           "exit ${PIPESTATUS[0]}"], cwd=ROOT, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0
    assert sorted(os.listdir(tmp_path)) == ["a.csv"]
    assert len(out.read_text().splitlines()) == 20002             # header, t = 0, 20,000 steps


def _stderr_to_a_file(tmp_path, args: str):
    """(the finished process, its stderr) of ``plantlod ARGS`` run with stderr on a file."""
    err = tmp_path / "err.txt"
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} {args} 2> {err}"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    return done, err.read_text()


def test_progress_forced_on_a_file_draws_the_bar(tmp_path):
    """README: `--progress` forces the progress bar, which by default shows only on a
    terminal. On a file rich drew nothing (a new user saw one blank line, session 33): the
    bar is drawn as on a terminal; without the option a file gets the one summary line."""
    for flag, bar in (("--progress", True), ("", False)):
        done, text = _stderr_to_a_file(tmp_path, f"simulate {STALK8} --dt 0.01 --steps 200000 "
                                       f"--wind-speed 5 -o {tmp_path / 'a.csv'} {flag}")
        last = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", text.splitlines()[-1])  # (the bar erased)
        assert done.returncode == 0 and last.startswith("simulate: ")
        assert ("simulating" in text and "\x1b[" in text) == bar, text[:200]
        assert bar or len(text.splitlines()) == 1


def test_a_reader_of_stdout_that_goes_away_ends_the_command_quietly():
    """`| head`: 141 (128 + SIGPIPE) and nothing on stderr; click's own handling of a broken
    pipe would make it exit 1."""
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} simulate {STALK8} --dt 0.01 --steps 200000 "
                           "--wind-speed 5 | head -1; exit ${PIPESTATUS[0]}"], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 141 and done.stderr == ""
    assert done.stdout.startswith("t,b:")


def test_closed_and_full_stdout_exit_1():
    for redirect, reason in ((">&-", "standard output is closed"),
                             ("> /dev/full", "cannot write standard output: No space left")):
        done = subprocess.run(["bash", "-c", f"{PLANTLOD} derive {STALK8} {redirect}"], cwd=ROOT,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 1, done.stderr
        assert done.stderr.splitlines() == [f"plantlod derive: error: {reason}"
                                            + ("; give -o FILE or redirect it" if "closed" in reason
                                               else " on device")]


def test_a_closed_stdout_table_and_a_closed_stderr(tmp_path):
    """compare's table asked a closed stdout whether it was a terminal (an internal error),
    and with stderr closed (2>&-) every command that reads whether stderr is a terminal, or
    says a line, ended with exit 1: their data is still written, exit 0 (session 23, fuzzing)."""
    level = tmp_path / "l1.lsys"
    run_cli("simplify", STALK8, "--level", "1", "-o", str(level))
    run = "--dt 0.01 --duration 2 --wind-speed 5"
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} compare {STALK8} {level} {run} >&-"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and done.stderr.splitlines() == [
        "plantlod compare: error: standard output is closed; give -o FILE or redirect it"]
    for command in (f"simulate {STALK8} {run} -o {tmp_path}/a.csv",
                    f"simulate {STALK8} --dt 0.01 --steps 5 -o {tmp_path}/b.csv",   # a warning
                    f"simplify {STALK8} --level 1 -o {tmp_path}/c.lsys",
                    f"compare {STALK8} {level} {run} -o {tmp_path}/d.txt"):
        done = subprocess.run(["bash", "-c", f"{PLANTLOD} {command} 2>&-"], cwd=ROOT,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, command
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv", "b.csv", "c.lsys", "d.txt",
                                                          "l1.lsys"]


def test_a_signal_handler_imports_nothing():
    """A signal that landed while cli.io was still loading met a circular import in the
    handler's own import: a traceback, exit 1, or the signal swallowed and the run finished
    (session 23, found by fuzzing). The handler needs no import now, and the console script
    installs a first handler before anything else loads (`cli.entry`, `cli.early_signals`),
    which ends a command still starting with one line; importing cli.main (tests, benchmarks)
    installs none."""
    import ast
    import inspect

    from plantlod.cli import discipline, early_signals

    for handler in (discipline._end_on_signal, early_signals._end_early):
        body = ast.parse(inspect.getsource(handler))
        assert not [n for n in ast.walk(body) if isinstance(n, (ast.Import, ast.ImportFrom))]
    assert 'plantlod = "plantlod.cli.entry:main"' in (ROOT / "pyproject.toml").read_text()
    code = ("import os, signal\n"
            "import plantlod.cli.main\n"
            "assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL\n"
            "from plantlod.cli import early_signals\n"
            "early_signals.install()\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 128 + signal.SIGTERM, done.stderr
    assert done.stderr == "plantlod: ended by SIGTERM\n"


def test_an_output_that_is_a_link_to_the_input_replaces_the_link(tmp_path):
    """A link at the output path is replaced (os.replace), never followed, so the input it
    points at is not written over: refusing it was a false positive (found in review)."""
    s = tmp_path / "s.lsys"
    s.write_text((ROOT / STALK8).read_text())
    (tmp_path / "link.jsonl").symlink_to(s)
    run_cli("derive", str(s), "-o", str(tmp_path / "link.jsonl"))
    assert not (tmp_path / "link.jsonl").is_symlink()
    assert s.read_text() == (ROOT / STALK8).read_text()


@pytest.mark.parametrize("make, args, message", [
    (None, ["derive", "{s}", "-o", "{s}"], "-o would write over the input"),
    (None, ["simulate", "{s}", "--dt", "0.01", "--steps", "5", "--wind-speed", "5", "-o", "{s}"],
     "-o would write over the input"),
    (None, ["simplify", "{s}", "--level", "1", "-o", "{s}"], "-o would write over the input"),
    ("level", ["simplify", "{d}/level1.lsys", "--levels", "{d}"], "--levels (level1.lsys) would write over"),
    ("level", ["compare", "{s}", "{d}/level1.lsys", "--dt", "0.01", "--steps", "50", "--wind-speed",
               "5", "-o", "{d}/level1.lsys"], "-o would write over the input"),
    ("level", ["compare", "{s}", "{d}/level1.lsys", "--dt", "0.01", "--steps", "50", "--wind-speed",
               "5", "-o", "{d}/x.png", "--plot", "{d}/x.png"], "-o and --plot name the same file"),
    ("level", ["compare", "{s}", "{d}/level1.lsys", "--dt", "0.01", "--steps", "50", "--wind-speed",
               "5", "-o", "{d}/xd", "--obj", "{d}/xd", "--at", "0.1"], "-o and --obj name the same file"),
    # an input named as an OBJ frame in --obj DIR: the frames landed over it (session 30)
    ("frame", ["compare", "{d}/frame_t0.1.obj", "{d}/level1.lsys", "--dt", "0.01", "--steps",
               "50", "--wind-speed", "5", "--obj", "{d}", "--at", "0.1"],
     "is one of its names; expected another folder"),
])
def test_an_output_over_an_input_or_another_output_is_refused_before_any_work(tmp_path, make, args,
                                                                              message):
    """Every one of these exited 0 having replaced its input (derive x.lsys -o x.lsys), or
    left one output's file where the other wanted a folder (session 23, found by fuzzing)."""
    s = tmp_path / "s.lsys"
    s.write_text((ROOT / STALK8).read_text())
    if make:
        (tmp_path / "lv").mkdir()
        run_cli("simplify", str(s), "--level", "1", "-o", str(tmp_path / "lv" / "level1.lsys"))
    if make == "frame":
        (tmp_path / "lv" / "frame_t0.1.obj").write_text(s.read_text())
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    line = one_line(run_cli(*[a.format(s=s, d=tmp_path / "lv") for a in args], exit_code=None), 2,
                    message)
    assert "expected" in line
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert sorted(tmp_path.rglob("*")) == sorted([*before, *([tmp_path / "lv"] if make else [])])


@pytest.mark.parametrize("args, message", [
    # - is stdout elsewhere; export's format is its name's extension ('no extension' before;
    # compare's --plot - beside the table: tests/test_wrong_kind_of_file.py)
    (["export", "{s}", "{csv}", "-o", "-"], "-o -: export takes the format from the file name"),
])
def test_standard_output_where_it_cannot_serve_says_why(tmp_path, args, message):
    s = tmp_path / "s.lsys"
    s.write_text((ROOT / STALK8).read_text())
    csv = tmp_path / "a.csv"
    run_cli("simulate", str(s), "--dt", "0.01", "--steps", "5", "--wind-speed", "5", "-o", str(csv))
    result = run_cli(*[a.format(s=s, csv=csv) for a in args], exit_code=None)
    one_line(result, 2, message)
    assert result.stdout == ""


# --- signals: 128 + n, and the temporary file removed -------------------------------------

@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT,
                                    # (their default action left the temporary file: session 29)
                                    signal.SIGQUIT, signal.SIGUSR1, signal.SIGXCPU])
def test_signal_mid_run_removes_the_temporary_file(tmp_path, signum):
    out = tmp_path / "big.csv"
    proc = subprocess.Popen([PLANTLOD, "simulate", str(ROOT / STALK8), "--dt", "0.01",
                             "--steps", "100000000", "--wind-speed", "5", "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while not any(p.startswith(".plantlod-") for p in os.listdir(tmp_path)):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    proc.send_signal(signum)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, stderr
    assert "Traceback" not in stderr and len(stderr.splitlines()) == 1
    assert os.listdir(tmp_path) == []


# --- random argument lists ---------------------------------------------------------------

TOKENS = st.sampled_from([
    "derive", "simulate", "simplify", "compare", STALK8, "examples", "no-such.lsys", "-",
    "--dt", "0.01", "-1", "nan", "1e-320", "1e400", "--steps", "2", "0", "--duration", "0.02",
    "--wind", "1,0,0", "1,nan,0", "--wind-speed", "3", "--wind-direction", "90", "--every",
    "--gust-strength", "0.3", "--gust-seed", "-o", "/dev/null", "--format", "string", "-n",
    "--max-modules", "1", "--level", "1", "--json", "--window", "0,", "--at", "--obj",
    "--plot-at", "--angles", "--atol", "--damping", "1.5", "--degrees", "x", "",
])


@settings(max_examples=120, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.lists(TOKENS, min_size=1, max_size=9))
def test_random_arguments_follow_the_discipline(args):
    if "simplify" in args and "--dt" not in args:
        args = args + ["--dt", "0.05"]          # keep simplify's own runs short
    args += ["--duration", "0.02"] if "simplify" in args else []
    result = run_cli(*args, exit_code=None)
    assert result.exit_code in (0, 1, 2), (args, result.exit_code, result.stderr)
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, args
    if result.exit_code:
        assert "error:" in result.stderr.strip().splitlines()[-1], (args, result.stderr)


OPTION_VALUES = st.sampled_from([
    ("--dt", "0.01"), ("--dt", "1e-320"), ("--dt", "nan"), ("--steps", "2"), ("--steps", "-1"),
    ("--duration", "0.02"), ("--duration", "inf"), ("--wind", "1,0,0"), ("--wind", "1,2"),
    ("--wind-speed", "3"), ("--wind-speed", "0"), ("--wind-direction", "90"), ("--every", "2"),
    ("--gust-strength", "0.3"), ("--gust-seed", "7"), ("--damping", "1.5"), ("--damping", "2"),
    ("-o", "/dev/full"), ("-o", "/dev/null"), ("-o", "no/such/dir/x"), ("--format", "string"),
    ("-n", "2"), ("-n", "20000"), ("--max-modules", "3"), ("--level", "1"), ("--level", "9"),
    ("--json",), ("--window", "0,"), ("--window", "nan,1"), ("--at", "0.01"), ("--at", "99"),
    ("--obj", "/dev/null"), ("--plot-at", "0"), ("--atol", "1e-9"), ("--degrees",),
    ("--max-amplitude-error", "0"), ("--wind-file", "no-such.csv"), ("--wind-file", STALK8),
])


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.sampled_from(["derive", "simulate", "compare"]), st.lists(OPTION_VALUES, max_size=5))
def test_random_options_of_a_real_command_follow_the_discipline(command, options):
    args = [command, STALK8] + ([STALK8] if command == "compare" else [])
    args += [token for option in options for token in option]
    result = run_cli(*args, exit_code=None)
    assert result.exit_code in (0, 1, 2), (args, result.exit_code, result.stderr)
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, args
    if result.exit_code:
        assert "error:" in result.stderr.strip().splitlines()[-1], (args, result.stderr)


@pytest.mark.parametrize("extra, fragment", [
    (("--obj", "{tmp}/frames", "--at", "99"), "--at 99 s is outside the run"),
    (("--plot", "{tmp}/p.png", "--plot-at", "99"), "--plot-at 99 s is outside the run"),
    (("--plot", "{tmp}/no/such/p.png"), "output directory does not exist"),
    (("--obj", "{tmp}/frames", "--at", "0.01,99"), "--at 99 s is outside the run"),
    # (session 34: frame 0 alone was written, exit 0)
    (("--obj", "{tmp}/frames", "--every", "4"), "--every 4 is more than the run's 3 samples "
                                                "after t = 0; expected at most 3"),
])
def test_compare_validates_everything_before_writing(tmp_path, extra, fragment):
    pytest.importorskip("matplotlib")
    out = tmp_path / "report.txt"
    args = ["compare", STALK8, STALK8, *SIM, "-o", str(out)]
    args += [a.format(tmp=tmp_path) for a in extra]
    one_line(run_cli(*args, exit_code=None), 2, fragment)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("plot", ["{tmp}/p/", "/dev/full"])
def test_compare_outputs_land_together_or_not_at_all(tmp_path, plot):
    """A picture that cannot be written once the report was: the report file was replaced
    and the OBJ frames left, with two lines on stderr (a helper's fuzzing, session 29). Now
    the report, the frames and the picture land together, when every one is written."""
    pytest.importorskip("matplotlib")
    out = tmp_path / "report.txt"
    out.write_text("OLD\n")
    args = ["compare", STALK8, STALK8, *SIM, "-o", str(out), "--obj", str(tmp_path / "frames"),
            "--at", "0.01", "--plot", plot.format(tmp=tmp_path)]
    result = run_cli(*args, exit_code=None)
    assert result.exit_code in (1, 2) and len(result.stderr.strip().splitlines()) == 1
    assert out.read_text() == "OLD\n" and sorted(os.listdir(tmp_path)) == ["report.txt"]


@pytest.mark.parametrize("args", [
    ["derive", STALK8, "-o", "{tmp}/x/"],
    ["simulate", STALK8, *SIM, "-o", "{tmp}/x/"],
    ["simplify", STALK8, "--level", "1", "-o", "{tmp}/x/"],
    ["compare", STALK8, STALK8, *SIM, "--plot", "{tmp}/x/"],
])
def test_an_output_file_named_as_a_folder_is_refused_before_any_work(tmp_path, args):
    """abspath drops a trailing /, so 'x/' passed the early check and failed only when the
    work was done ('cannot write: Not a directory'; compare had printed its table)."""
    result = run_cli(*[a.format(tmp=tmp_path) for a in args], exit_code=None)
    one_line(result, 2, "names a folder (it ends in /); expected a file name")
    assert result.stdout == "" and os.listdir(tmp_path) == []


@pytest.mark.parametrize("name, said", [("", "an empty name"), ("-", "standard output")])
@pytest.mark.parametrize("args", [
    ["simplify", STALK8, "--levels", "{name}"],
    ["compare", STALK8, STALK8, *SIM, "--obj", "{name}", "--at", "0.01", "-o", "r.txt"],
])
def test_a_folder_output_needs_a_folder_name(tmp_path, args, name, said):
    """`--levels ""` was told of an empty *file* name, and `--levels -` made a folder named
    "-" (a helper's review, session 34); both name no folder, as for scene --angles."""
    args = [str(ROOT / a) if a == STALK8 else a.format(name=name) for a in args]
    result = run_cli(*args, exit_code=None, cwd=tmp_path)
    one_line(result, 2, f"a folder: {said} cannot hold one; expected the name of a folder")
    assert result.stdout == "" and os.listdir(tmp_path) == []


@pytest.mark.parametrize("args, fragment", [
    (["compare", STALK8, STALK8, "--dt", "0.01", "--steps", "0", "--wind-speed", "5"],
     "compare needs a run of at least one step (two samples); --steps 0 gives none"),
    (["compare", STALK8, STALK8, "--dt", "0.01", "--duration", "0.001", "--wind-speed", "5"],
     "--duration 0.001 s at --dt 0.01 s gives no time step (duration / dt rounds to 0)"),
    (["simulate", STALK8, "--dt", "0.01", "--duration", "0.001", "--wind-speed", "5"],
     "--duration 0.001 s at --dt 0.01 s gives no time step (duration / dt rounds to 0)"),
    (["simulate", STALK8, "--dt", "0.01", "--steps", "5", "--wind-speed", "5",
      "--damping-ratio", "100.0001"], "must be a number in [0, 100], got 100.0001"),
    (["simulate", STALK8, "--dt", "0.01", "--steps", "5", "--wind", "1000,1,0"],
     "a wind of 1000.0005 m/s; expected at most 1000 m/s"),
    (["simulate", STALK8, "--dt", "300", "--steps", "5", "--wind", "1,0,0"],
     ">= 4, the limit without damping (dt = 300 s)"),
])
def test_messages_say_what_was_given(args, fragment):
    """Session 34's fuzzing: compare --steps 0 spoke of a window nobody gave; a value just
    past a limit was rounded onto it ("in [0, 100], got 100"); "the limit at undamped".
    Session 42: a duration shorter than half a step ran 0 steps without a word (a new user's
    first hour); --duration 0 still asks for the rest pose alone."""
    one_line(run_cli(*args, exit_code=None), 2, fragment)


def test_many_warnings_are_capped(tmp_path):
    head = open(ROOT / STALK8, encoding="utf-8").read()
    lines = "\n".join(f"  {i}.0.0.0: length=2" for i in range(1, 200))   # 1.0.0.0 is the leaf
    long_address = ".".join(["0"] * 50_000)
    path = tmp_path / "ov.lsys"
    path.write_text(f"{head}overrides:\n{lines}\n  {long_address}: length=3\n", encoding="utf-8")
    result = run_cli("derive", str(path), "-o", os.devnull)
    warnings = [line for line in result.stderr.splitlines() if line.startswith("warning:")]
    # (the leaf's length applies to nothing: its own warning, since session 36)
    assert len(warnings) == 7 and "194 more overrides match no" in warnings[-1]
    assert sum("length for address 1.0.0.0 applies to nothing" in w for w in warnings) == 1
    assert max(map(len, result.stderr.splitlines())) < 500


def test_output_name_too_long_is_bad_input(tmp_path):
    one_line(run_cli("derive", STALK8, "-o", str(tmp_path / ("x" * 300)), exit_code=None), 2,
             "cannot write: File name too long")
    no_temporary_files(tmp_path)


@pytest.mark.parametrize("suffix", [".glb", ".usda"])
def test_export_to_a_name_the_system_refuses_is_bad_input_as_every_command(tmp_path, suffix):
    """export's -o in a folder that takes no new file (/proc) was exit 1, "plantlod export:
    error: /proc/x.glb: No such file or directory", where derive, simulate and the others
    say "cannot write" with exit 2 (session 28's fuzzing)."""
    angles = tmp_path / "a.csv"
    run_cli("simulate", STALK8, "--dt", "0.01", "--steps", "5", "--wind-speed", "1",
            "-o", str(angles))
    target = f"/proc/plantlod-test{suffix}"
    one_line(run_cli("export", STALK8, str(angles), "-o", target, exit_code=None), 2,
             f"{target}: error: cannot write: No such file or directory")
    one_line(run_cli("derive", STALK8, "-o", "/proc/plantlod-test.jsonl", exit_code=None), 2,
             "/proc/plantlod-test.jsonl: error: cannot write: No such file or directory")


def test_compare_refuses_a_run_too_big_for_memory():
    one_line(run_cli("compare", STALK8, STALK8, "--dt", "1e-6", "--steps", "9999999999",
                     "--wind-speed", "1", exit_code=None), 2, "GB of angles in memory")


def test_full_stderr_does_not_fail_the_command(tmp_path):
    out = tmp_path / "t.jsonl"
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} derive {STALK8} -o {out} 2>/dev/full"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and out.exists()


@pytest.mark.parametrize("args, fragment", [
    (("compare", STALK8, STALK8, *SIM, "--degrees"),
     "--degrees has no effect without --original-angles or --simplified-angles or --angles"),
    (("simplify", STALK8, "--level", "1", "--evaluations", "5"),
     "--evaluations has no effect without --calibrate"),
])
def test_options_without_effect_are_usage_errors(args, fragment):
    one_line(run_cli(*args, exit_code=None), 2, fragment)


# --- a disk that fills up mid-write (a short write, then an error) ----------------------

@pytest.mark.parametrize("command", [
    f"simulate {STALK8} --dt 0.01 --steps 3000 --wind-speed 5",
    f"simulate {STALK8} --dt 0.01 --steps 3000 --wind-speed 5 -o {{tmp}}/a.csv",
    f"simulate {STALK8} --dt 0.01 --steps 3000 --wind-speed 5 -o {{tmp}}/a.npz",
    "derive examples/abop_1_24c.lsys",
    "derive examples/abop_1_24c.lsys --format string -n 6",
])
def test_a_disk_filling_up_is_exit_1(tmp_path, command):
    # RLIMIT_FSIZE behaves as a full disk: the write that crosses it is short, the next fails
    # (SIGXFSZ ignored, as a shell's `trap '' XFSZ` does)
    target = tmp_path / "out"
    done = subprocess.run(["bash", "-c", f"trap '' XFSZ; ulimit -f 100; {PLANTLOD} "
                           f"{command.format(tmp=tmp_path)} > {target}"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1, (done.returncode, done.stderr)
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and "File too large" in lines[0], done.stderr
    assert sorted(os.listdir(tmp_path)) == ["out"]


def test_whole_writes_refuse_a_short_write():
    import io as _io

    from plantlod.cli.io import WholeWrites

    class Short(_io.RawIOBase):
        def __init__(self):
            self.data, self.room = b"", 10

        def writable(self):
            return True

        def write(self, b):
            if not self.room:
                raise OSError(errno.ENOSPC, "No space left on device")
            n = min(len(b), self.room)
            self.data += bytes(b[:n])
            self.room -= n
            return n

    stream = Short()
    with pytest.raises(OSError, match="No space"):
        WholeWrites(stream, text=True).write("x" * 20)
    assert stream.data == b"x" * 10


def test_a_file_name_that_is_not_utf8_is_no_internal_error(tmp_path):
    name = os.fsdecode(b"\xff.lsys")                  # '\udcff.lsys': a surrogate escape
    path = tmp_path / name
    path.write_bytes((ROOT / STALK8).read_bytes())
    tree = tmp_path / "t.jsonl"
    run_cli("derive", str(path), "-o", str(tree))
    assert '"source": "' in tree.read_text(encoding="utf-8")
    run_cli("simulate", str(tree), *SIM, "-o", os.devnull)
    result = run_cli("compare", str(path), str(path), *SIM, "--json")
    assert "\\udcff.lsys" in result.stdout
    run_cli("simplify", str(path), "--level", "1", "--duration", "1", "-o", os.devnull)


def test_numpy_floating_point_warnings_never_reach_stderr_raw(tmp_path):
    """A drag coefficient of 1e308 overflows numpy's multiply before the run is found to
    diverge: the command still says one line (numpy's RuntimeWarning, two lines with a
    source path, is one of the run's warnings, dropped with it on failure; session 21)."""
    tree = tmp_path / "t.jsonl"
    run_cli("derive", str(ROOT / "examples" / "stalk8.lsys"), "-o", str(tree))
    text = tree.read_text().replace('"drag_coefficient": 0.0015', '"drag_coefficient": 1e308')
    assert "1e308" in text
    tree.write_text(text)
    done = subprocess.run([str(PLANTLOD), "simulate", str(tree), "--dt", "0.01", "--steps", "50",
                           "--wind-speed", "5"], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 1
    assert done.stderr.count("\n") == 1 and "simulation diverged" in done.stderr, done.stderr


def test_a_failed_atomic_write_names_the_target_not_its_temporary(tmp_path, monkeypatch):
    """export into a folder that cannot take a file said '…/.plantlod-o7jsvca7.glb: Operation
    not permitted', the temporary's name (session 23, found by fuzzing): a failure to make or
    write the temporary is reported against the file asked for."""
    from plantlod.formats import atomic
    from plantlod.formats.atomic import atomic_path, write_whole

    target = str(tmp_path / "x.glb")

    def refused(*args, **kwargs):
        raise PermissionError(errno.EPERM, "Operation not permitted",
                              str(tmp_path / ".plantlod-abc.glb"))

    with monkeypatch.context() as m:
        m.setattr(atomic, "new_temporary", refused)
        with pytest.raises(OSError) as info:
            with atomic_path(target, ".glb"):
                pass
    assert info.value.filename == target and info.value.errno == errno.EPERM
    with pytest.raises(OSError) as info:
        with atomic_path(target, ".glb") as tmp:
            write_whole(tmp, b"x")
            raise OSError(errno.ENOSPC, "No space left on device", tmp)
    assert info.value.filename == target and os.listdir(tmp_path) == []


@pytest.mark.parametrize("is_folder", [False, True])
def test_a_temporary_is_registered_before_it_exists(tmp_path, monkeypatch, is_folder):
    """A signal between making a temporary and registering it left it behind (3 of 100
    interrupted `simulate -o` runs on a loaded machine, session 38): the name is now held
    for `remove_pending` before the file or folder is made, and released where the name was
    taken (a second try) or the making failed."""
    from plantlod.formats import atomic

    made, real = {}, {"open": os.open, "mkdir": os.mkdir}
    taken = []

    def spy(kind):
        def call(path, *args, **kwargs):
            made[path] = path in atomic._pending           # registered at the moment it is made
            if not taken:                                  # the first name: taken already
                taken.append(path)
                raise FileExistsError(errno.EEXIST, "File exists", path)
            return real[kind](path, *args, **kwargs)
        return call

    monkeypatch.setattr(atomic.os, "mkdir" if is_folder else "open",
                        spy("mkdir" if is_folder else "open"))
    path = atomic.new_temporary(str(tmp_path), ".x", is_folder=is_folder)
    monkeypatch.undo()
    assert list(made.values()) == [True, True] and taken[0] not in atomic._pending
    assert path in atomic._pending and os.path.basename(path).startswith(".plantlod-")
    assert os.path.isdir(path) if is_folder else os.path.isfile(path)
    atomic.remove_pending()
    assert os.listdir(tmp_path) == []
    atomic.release(path)


def test_a_levels_folder_name_too_long_is_refused_before_the_fit(tmp_path):
    """It was refused only after every level was fitted (session 23, found by fuzzing)."""
    folder = str(tmp_path / ("a" * 300))
    one_line(run_cli("simplify", STALK8, "--levels", folder, exit_code=None), 2,
             "cannot write: File name too long")
    assert list(tmp_path.iterdir()) == []


def test_a_summary_naming_a_file_with_a_line_break_stays_one_line(tmp_path):
    """view's summary printed the raw line break of its output's name (found by fuzzing)."""
    import plantlod

    glb = tmp_path / "s.glb"
    tree = plantlod.derive(str(ROOT / STALK8))
    plantlod.export_animation(tree, plantlod.simulate(tree, wind=(5.0, 0.0, 0.0), dt=0.01,
                                                      steps=20), glb)
    out = tmp_path / "x\ny.html"
    result = run_cli("view", str(glb), "-o", str(out))
    assert result.stderr.count("\n") == 1 and "x\\ny.html" in result.stderr
    assert out.exists()


def test_view_to_a_reader_of_stdout_that_goes_away_ends_quietly(tmp_path):
    """`plantlod view A.glb -o - | head` ended with exit 1 and "cannot write the stream: Broken
    pipe" where every other command ends quietly with 141 (a helper's fuzzing, session 32),
    and a full stdout did not say which output: now "standard output", as derive says it."""
    csv, glb = tmp_path / "a.csv", tmp_path / "a.glb"
    run_cli("simulate", STALK8, "--dt", "0.01", "--duration", "1", "--wind-speed", "5", "-o", str(csv))
    run_cli("export", STALK8, str(csv), "-o", str(glb))
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} view {glb} -o - | head -c 15; "
                           "exit ${PIPESTATUS[0]}"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert (done.returncode, done.stderr, done.stdout) == (141, "", "<!DOCTYPE html>")
    done = subprocess.run(["bash", "-c", f"{PLANTLOD} view {glb} -o - > /dev/full"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        "plantlod view: error: cannot write standard output: No space left on device"]


@pytest.mark.parametrize("args", [
    ("compare", "-", "-", "--dt", "0.01", "--duration", "1", "--wind-speed", "3"),
    ("compare", "--angles", "-", "-"),
    ("export", "-", "-", "-o", "OUT/e.glb"),
    ("simulate", "-", "--wind-file", "-", "--dt", "0.01", "--steps", "3"),
])
def test_standard_input_is_read_by_one_input_only(tmp_path, args):
    """`compare - -` read the tree from stdin and then called the second input "empty"
    (a helper's fuzzing, session 32): two inputs given as - are refused before any reading,
    naming both, and nothing is written."""
    args = [a.replace("OUT", str(tmp_path)) for a in args]
    done = subprocess.run([PLANTLOD, *args], input=(ROOT / STALK8).read_text(),
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    line, = done.stderr.splitlines()
    assert "both read standard input (-), which can be read once" in line
    assert os.listdir(tmp_path) == []


def test_out_of_memory_names_what_makes_each_commands_run_smaller():
    """A MemoryError's line names options of the command that failed: `export` of a 313 MB
    CSV said "lower --max-modules", an option of `derive` alone (a helper's fuzzing, session
    33). Every option named is one `CMD --help` lists."""
    from plantlod.cli.discipline import describe_failure
    from plantlod.cli.main import cli

    for name, command in cli.commands.items():
        exc = MemoryError()
        exc.plantlod_command = name
        code, line = describe_failure(exc)
        assert code == 1 and line.startswith(f"plantlod {name}: error: out of memory; "), line
        options = {opt for param in command.params for opt in param.opts}
        for named in re.findall(r"--[a-z-]+", line):
            assert named in options, (name, named)


def test_a_signal_after_the_work_is_done_is_too_late_to_stop_it(tmp_path):
    """After its summary line a command's output is in place, and the interpreter still takes
    0.1-0.8 s to end: a SIGINT there said "interrupted", exit 130, beside a whole output, or
    (once Python's finalisation had put the default action back) killed it with no word (a
    helper's fuzzing, session 33). It is ignored: exit 0, the output kept."""
    out = tmp_path / "a.npz"
    lsys = ROOT / "examples" / "abop_1_24a.lsys"
    for wait in (0.05, 0.12):
        done = subprocess.Popen([PLANTLOD, "simulate", str(lsys), "--dt", "0.01", "--steps",
                                 "300", "--wind-speed", "5", "-o", str(out)], cwd=ROOT,
                                stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        summary = done.stderr.readline()
        time.sleep(wait)
        done.send_signal(signal.SIGINT)
        rest = done.stderr.read()
        assert done.wait(timeout=60) == 0 and rest == "", (done.returncode, rest)
        assert summary.startswith("simulate: ") and out.stat().st_size > 0
        out.unlink()


def test_compare_with_one_file_says_what_its_form_needs():
    """`compare --angles golden.csv` said "Missing argument 'SIMPLIFIED...'", a name its
    --angles form does not use (a new user's first hour, session 38)."""
    line = one_line(run_cli("compare", "--angles", "golden.csv", exit_code=None), 2,
                    "--angles compares two angle CSVs of one tree: give both")
    assert "SIMPLIFIED" not in line
    one_line(run_cli("compare", STALK8, exit_code=None), 2, "Missing argument 'SIMPLIFIED...'.")


def test_simplify_level_and_n_say_what_n_is_here():
    """`simplify --level 1 -n 30` (-n the derivation length, as in simulate) said only "-n is
    its old spelling" (a new user's first hour, session 38)."""
    one_line(run_cli("simplify", STALK8, "--level", "1", "-n", "30", exit_code=None), 2,
             "simplify's -n is an old spelling of --level, not the derivation length")


def test_a_divergence_of_a_tree_of_absurd_size_is_bad_input(tmp_path):
    """A branch F(1e200) diverged at step 2 and was told to lower force_absorbed, the wind or
    dt (exit 1; session 37's fuzzing): where a run diverges, simulate now asks whether the tree
    reaches past what compare and export measure (exit 2, naming the file, no output left).
    A tree of ordinary size whose run diverges is still a runtime failure."""
    text = (ROOT / "examples" / "stalk8.lsys").read_text()
    huge = tmp_path / "huge.lsys"
    huge.write_text(text.replace("axiom: F L", "axiom: F(1e200) L").replace(
        "  F -> F F", "  F(x) -> F(x) F(x)"))
    out = tmp_path / "a.csv"
    line = one_line(run_cli("simulate", str(huge), "--dt", "0.01", "--steps", "50",
                            "--wind-speed", "5", "-o", str(out), exit_code=None), 2,
                    "the tree reaches 8e+200 m from the origin at rest")   # 2^3 branches of 1e200 m
    assert line.startswith(f"{huge}: error:") and os.listdir(tmp_path) == ["huge.lsys"]
    strong = tmp_path / "strong.lsys"
    strong.write_text(text.replace("force_absorbed: 0.005", "force_absorbed: 1e300"))
    one_line(run_cli("simulate", str(strong), "--dt", "0.01", "--steps", "50", "--wind-speed",
                     "5", "-o", str(out), exit_code=None), 1, "simulation diverged")
    assert not out.exists()


def test_a_force_passed_on_to_a_subnormal_share_raises_no_warning(tmp_path):
    """A 512-branch stalk with force_propagated 0.24 passes its top 0.24^511 ~ 1e-317 (a
    subnormal) of the force: the sequential fit's leaf area u / lam overflowed to inf, capped
    after, and numpy's 'overflow encountered in divide' reached stderr as a warning (a 2,048-
    branch stalk at 0.7 in a helper's runs, session 38). The levels are the same bytes."""
    text = (ROOT / "examples" / "stalk8.lsys").read_text()
    tree = tmp_path / "s.lsys"
    tree.write_text(text.replace("derivation_length: 3", "derivation_length: 9")
                    .replace("force_propagated: 0.7", "force_propagated: 0.24"))
    result = run_cli("simplify", str(tree), "--levels", str(tmp_path / "L"), exit_code=0)
    assert "overflow" not in result.stderr and "warning: floating point" not in result.stderr


# --- long messages keep what they say is wrong (session 40, a helper's novel trees) -----

def test_cut_middle_keeps_the_head_and_the_tail():
    from plantlod.lsys.errors import cut_middle

    assert cut_middle("short", 9) == "short"
    assert cut_middle("a" * 10 + "b" * 10, 9) == "aaaa…bbbb"
    assert cut_middle("a" * 10 + "b" * 10, 10) == "aaaa…bbbbb"
    assert all(len(cut_middle("x" * 50, n)) == n for n in range(1, 50))


DEEP_NEGATIVE = """name: deep_negative
derivation_length: 600
branching_angle: 30
force_absorbed: 0.002
force_propagated: 0.7
branch F: length=1 radius=0.01 bend_strength=30 rotation_strength=30
axiom: A(0)
productions:
  A(n) -> F(0.5-n*0.001) A(n+1)
"""


def test_an_error_at_a_deep_address_still_says_what_is_wrong(tmp_path):
    """Branch 501 of a 600-step chain is F(-0.001): its address has 500 parts, and the line,
    cut at its end to 1,000 characters, stopped inside the address, before 'has a negative
    length'."""
    (tmp_path / "deep.lsys").write_text(DEEP_NEGATIVE)
    line = one_line(run_cli("simplify", str(tmp_path / "deep.lsys"), "--level", "1",
                            exit_code=None), 2, "deep.lsys", "F(-0.00", "…",
                    "has a negative length; expected a number >= 0")
    assert len(line) <= 1000                # (the whole line: it was the message alone)


def test_an_error_line_is_cut_whole_with_its_place(tmp_path):
    """A number of 5,001 digits: the message was cut to 1,000 characters and its place put
    before it, a line of 1,064 (an L-system fuzzing round). errors.md: lines of at most 1,000."""
    path = tmp_path / ("d" * 200 + ".lsys")
    path.write_text("derivation_length: 1\nbranching_angle: 30\nforce_absorbed: 0.005\n"
                    "force_propagated: 0.7\nbranch F: length=" + "1" * 5001 +
                    " radius=0.02 bend_strength=20 rotation_strength=20\naxiom: F\n")
    line = one_line(run_cli("derive", str(path), exit_code=None), 2, ".lsys:5:18: error: number",
                    "…", "' is too large; expected a finite number")
    assert len(line) <= 1000 and line.startswith(str(tmp_path))


def test_a_warning_at_a_deep_address_still_says_what_to_do(tmp_path):
    """A soft chain of 300 branches (k_fp 1) tilts past 1 rad near its top: the warning,
    cut at its end to 400 characters, stopped inside the branch's 300-part address."""
    (tmp_path / "soft.lsys").write_text(
        "derivation_length: 300\nbranching_angle: 30\nforce_absorbed: 0.002\n"
        "force_propagated: 1\nbranch F: length=0.02 radius=0.005 bend_strength=2 "
        "rotation_strength=2\nleaf L: area=0.002\naxiom: A\nproductions:\n  A -> F L A\n")
    result = run_cli("simulate", str(tmp_path / "soft.lsys"), "--dt", "0.01", "--steps", "200",
                     "--wind-speed", "10", "-o", str(tmp_path / "a.csv"))
    warnings = [w for w in result.stderr.splitlines() if "tilts" in w]
    assert warnings and all(len(w) <= len("warning: ") + 400 for w in warnings)
    assert "branch 0.0.0" in warnings[0] and "…" in warnings[0]
    assert warnings[0].endswith("check the units (metres), the wind and the strengths")


def test_scene_takes_progress_as_simulate_and_simplify_do(tmp_path):
    """`scene` had no --progress/--no-progress (a new user's first hour, session 42): forced
    on a file it draws the bar (its batches), and --no-progress draws none."""
    scene = tmp_path / "s.toml"
    scene.write_text(f'dt = 0.01\nduration = 0.5\n[wind]\nspeed = 5\n[camera]\n'
                     f'position = [0, -40, 1.7]\ntarget = [0, 0, 1.7]\n'
                     f'[[tree]]\nfile = "{ROOT / STALK8}"\n')
    for flag, bar in (("--progress", True), ("--no-progress", False)):
        done, text = _stderr_to_a_file(tmp_path, f"scene {scene} --no-cache {flag} "
                                       f"--report {tmp_path / 'r.json'}")
        assert done.returncode == 0, text
        assert ("batches" in text and "\x1b[" in text) == bar, text[:200]


@pytest.mark.parametrize("late, code, said", [
    ("signal", 143, "plantlod derive: ended by SIGTERM"),
    ("memory", 1, "plantlod derive: error: InputError (and MemoryError while saying it)")])
def test_a_failure_interrupted_while_it_is_said_still_ends_in_one_line(tmp_path, monkeypatch,
                                                                      late, code, said):
    """A signal (or memory running out) while a failure's line was being made escaped the
    one place every failure ends, and Python printed its traceback of both (seen once in an
    L-system fuzzing round, under a parallel 5 GB run)."""
    import signal as signals

    import plantlod.cli.discipline as discipline

    describe = discipline.describe_failure
    calls = []

    def interrupted(exc, prog="plantlod"):
        calls.append(exc)
        if len(calls) == 1:
            raise (discipline.Terminated(signals.SIGTERM) if late == "signal" else MemoryError())
        return describe(exc, prog)

    monkeypatch.setattr(discipline, "describe_failure", interrupted)
    bad = tmp_path / "bad.lsys"
    bad.write_text("axiom: Q(\n")
    result = run_cli("derive", str(bad), exit_code=None)
    assert (result.exit_code, result.stderr) == (code, said + "\n")
