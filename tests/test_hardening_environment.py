"""The environment a command runs in (a helper's fuzzing, session 35): the engine's and
numba's variables, a removed working directory, COLUMNS, matplotlib's settings, and outputs
that cannot be written to standard output while side outputs wait to land.

The real executable runs in a subprocess, each with its own environment."""

from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest

from golden_util import ROOT

PLANTLOD = str(ROOT / ".venv" / "bin" / "plantlod")
STALK8 = str(ROOT / "examples" / "stalk8.lsys")
SIM = ("--dt", "0.01", "--steps", "3", "--wind-speed", "2")


def run(args, env=None, cwd=None, stdout=subprocess.PIPE, drop=()):
    """``plantlod ARGS`` with ``env`` added to this environment (``drop``: names removed)."""
    full = {k: v for k, v in os.environ.items() if k not in drop}
    full.update(env or {})
    return subprocess.run([PLANTLOD, *args], env=full, cwd=cwd, stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=300)


def one_line(done, code: int, *fragments: str) -> str:
    assert done.returncode == code, (done.returncode, done.stderr)
    lines = done.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("name, value, says", [
    ("NUMBA_NUM_THREADS", "0", "expected a whole number >= 1"),     # numba: ValueError
    ("NUMBA_NUM_THREADS", "abc", "is not a whole number"),           # numba: a traceback
    ("NUMBA_NUM_THREADS", "99999", "expected a whole number <= 1,024"),  # a segmentation fault
    ("NUMBA_DISABLE_JIT", "x", "is not a whole number"),
    ("PLANTLOD_THREADS", "-1", "expected a whole number >= 1"),      # simulate took it
    ("PLANTLOD_KERNEL", "fast", "expected compiled or interpreted"),
])
def test_a_bad_engine_variable_is_refused_by_every_command_alike(name, value, says):
    for args in (("simulate", STALK8, *SIM), ("derive", STALK8)):
        one_line(run(args, {name: value}), 2, f"plantlod {args[0]}: error: {name}={value!r}", says)
    assert run(("simulate", "--help"), {name: value}).returncode == 0     # help still answers


def test_numba_without_its_compiler_is_refused_where_the_lanes_engine_runs(tmp_path):
    """NUMBA_DISABLE_JIT=1 ended simplify in an internal error (the vector type has no
    pure-Python form); simulate's single-run kernel runs without numba as before."""
    one_line(run(("simplify", STALK8, "--level", "1", "--duration", "3", "-o",
                  str(tmp_path / "l.lsys")), {"NUMBA_DISABLE_JIT": "1"}), 2,
             "NUMBA_DISABLE_JIT='1': the lanes engine", "unset it")
    assert not (tmp_path / "l.lsys").exists()
    plain = run(("simulate", STALK8, *SIM), {"NUMBA_DISABLE_JIT": "1"})
    assert plain.returncode == 0 and plain.stdout.startswith("t,"), plain.stderr


def test_a_removed_working_directory_is_one_line(tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()
    done = subprocess.run(["sh", "-c", f'cd "{gone}" && rmdir "{gone}" && exec "{PLANTLOD}" '
                           f'derive "{STALK8}" -o out.jsonl'], capture_output=True, text=True,
                          timeout=120)
    one_line(done, 1, "plantlod derive: error: the working directory no longer exists")
    # a command that needs no relative path still runs there
    done = subprocess.run(["sh", "-c", f'mkdir "{gone}" && cd "{gone}" && rmdir "{gone}" && '
                           f'exec "{PLANTLOD}" derive "{STALK8}"'], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0 and done.stdout.startswith('{"format"'), done.stderr


def test_columns_0_keeps_every_line():
    """rich took COLUMNS=0 for a width of 0 and drew nothing: no summary, no warning (on a
    terminal, or with --progress, whose bar is drawn through the same console)."""
    done = run(("simulate", STALK8, *SIM, "--progress"), {"COLUMNS": "0"})
    assert done.returncode == 0
    assert "simulate: " in done.stderr and "3 steps of 0.01 s" in done.stderr, done.stderr


def test_matplotlib_settings_do_not_reach_the_plot(tmp_path):
    """MPLBACKEND=bogus ended compare --plot in an internal error after the whole run; a home
    folder matplotlib cannot write printed two lines of its own."""
    png = tmp_path / "p.png"
    done = run(("compare", STALK8, STALK8, *SIM, "--plot", str(png), "-o", str(tmp_path / "c.txt")),
               {"MPLBACKEND": "bogus", "HOME": "/proc/no-home"}, drop=("MPLCONFIGDIR",))
    assert done.returncode == 0, done.stderr
    assert png.read_bytes().startswith(b"\x89PNG")
    assert all(line.startswith(("compare:", "warning:")) for line in done.stderr.splitlines()), \
        done.stderr


def test_standard_output_that_cannot_be_written_leaves_no_side_outputs(tmp_path):
    """compare --obj --plot and scene --plot wrote the table or report to standard output
    after the frames and the picture had landed, so a full disk or a reader gone there left
    them behind."""
    with open("/dev/full", "w") as full:
        done = run(("compare", STALK8, STALK8, "--dt", "0.01", "--steps", "50",
                    "--wind-speed", "2", "--obj", "O", "--every", "25", "--plot", "P.png"),
                   cwd=tmp_path, stdout=full)
        one_line(done, 1, "cannot write standard output")
        scene = tmp_path / "s.toml"
        scene.write_text(f'duration = 0.5\n[wind]\nspeed = 5\n[camera]\nposition = [0, -50, 2]\n'
                         f'target = [0, 0, 2]\n[[tree]]\nfile = "{STALK8}"\nposition = [0, 0, 0]\n')
        done = run(("scene", "s.toml", "--no-cache", "--plot", "Q.png", "--angles", "A.zarr"),
                   cwd=tmp_path, stdout=full)
        one_line(done, 1, "cannot write standard output")
    assert sorted(os.listdir(tmp_path)) == ["s.toml"]
    # a reader gone (`| head`) cut only the table: the side outputs land whole, exit 141 quietly
    for args in (("compare", STALK8, STALK8, "--dt", "0.01", "--steps", "50", "--wind-speed", "2",
                  "--obj", "O", "--every", "25", "--plot", "P.png"),
                 ("scene", "s.toml", "--no-cache", "--plot", "Q.png", "--angles", "A.zarr")):
        reader, writer = os.pipe()
        os.close(reader)
        with os.fdopen(writer, "w") as closed:
            done = run(args, cwd=tmp_path, stdout=closed)
        assert done.returncode == 141 and done.stderr == "", (done.returncode, done.stderr)
    assert sorted(os.listdir(tmp_path)) == ["A.zarr", "O", "P.png", "Q.png", "s.toml"]
    assert len(os.listdir(tmp_path / "O")) == 3 and not [
        p for p in os.listdir(tmp_path) if p.startswith(".plantlod-")]


def test_an_angle_store_whose_folder_is_removed_is_a_run_failure(tmp_path):
    """Removing the --angles store's folder while a scene ran gave "internal error: KeyError:
    'file_0/level_9'"."""
    from plantlod.lsys.build import build
    from plantlod.lsys.errors import RunFailure
    from plantlod.lsys.parse import parse_lsys
    from plantlod.scene.store import open_store, write_block

    tree = build(parse_lsys(open(STALK8).read())).tree
    path = tmp_path / "a.zarr"
    group = open_store(str(path), np.zeros((2, 3), dtype=np.int16),
                       [("s.lsys", [0, 1], [tree], None)], 3, 0.01)
    block = np.zeros((2, 3, tree.n_branches))
    write_block(group, 0, 0, 0, 0, block, block)
    shutil.rmtree(path)
    with pytest.raises(RunFailure, match="cannot write the --angles store: its arrays are gone"):
        write_block(group, 0, 0, 0, 0, block, block)


def test_an_output_folder_removed_while_the_command_ran_is_a_run_failure(tmp_path):
    """Every command checks its outputs' folders before its work (exit 2 where one is
    missing); a folder gone when the output is written was removed meanwhile: exit 1,
    naming the output (it was exit 2, and simplify --levels named its temporary folder)."""
    from plantlod.cli.io import check_output_path, forget_checked_outputs, open_output
    from plantlod.lsys.errors import InputError, RunFailure

    gone = tmp_path / "gone" / "x.csv"
    forget_checked_outputs()
    with pytest.raises(InputError, match="output directory does not exist"):
        with open_output(str(gone)):         # never checked (view, compare --angles): exit 2
            pass
    gone.parent.mkdir()
    check_output_path(str(gone))             # checked before the work, then removed
    gone.parent.rmdir()
    with pytest.raises(RunFailure, match="cannot write .*x.csv: its folder no longer exists"):
        with open_output(str(gone)):
            pass
    assert not gone.parent.exists()
    # export's temporary file beside the output met the same as ENOENT: exit 2 before
    import errno

    from plantlod.cli.io import write_errors

    with pytest.raises(RunFailure, match="its folder no longer exists"):
        with write_errors(str(gone)):
            raise FileNotFoundError(errno.ENOENT, "No such file or directory", str(gone))
    with pytest.raises(InputError):          # a folder that is there: the name is at fault
        with write_errors(str(tmp_path / "x.csv")):
            raise FileNotFoundError(errno.ENOENT, "No such file or directory")
