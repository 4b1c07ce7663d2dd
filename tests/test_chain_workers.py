"""A chain's levels fitted in several processes (simplify/chain_workers.py, `--levels --jobs`)."""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import time

from golden_util import ROOT, run_cli

PLANTLOD = str(ROOT / ".venv" / "bin" / "plantlod")


def _files(folder) -> dict[str, str]:
    """Each level file's text, its first line (the command's path to the input) left out."""
    return {p.name: p.read_text().split("\n", 1)[1] for p in sorted(folder.iterdir())}


def test_levels_in_several_processes_are_the_files_of_one(tmp_path):
    """Each level is an independent fit once level 1's groups are settled (bush3d: 159
    branches, regrouped first), so one, two and three processes write the same bytes,
    in whichever process each level was fitted; the lines printed come in level order."""
    outputs = {}
    for jobs in (1, 2, 3):
        result = run_cli("simplify", "examples/eval/bush3d.lsys", "--levels",
                         str(tmp_path / f"j{jobs}"), "--duration", "5", "--jobs", str(jobs))
        lines = [line for line in result.stderr.splitlines() if " level " in line]
        assert [line.split(" level ")[1].split(":")[0] for line in lines] == \
            [f"{k}/9" for k in range(1, 10)]
        outputs[jobs] = _files(tmp_path / f"j{jobs}")
    assert len(outputs[1]) == 9
    assert outputs[2] == outputs[1] and outputs[3] == outputs[1]


def test_jobs_is_for_levels_only():
    result = run_cli("simplify", "examples/stalk8.lsys", "--level", "1", "--jobs", "2", exit_code=2)
    assert "--jobs applies to --levels" in result.stderr


def test_a_signal_ends_the_workers_and_leaves_nothing(tmp_path):
    """SIGTERM while a worker fits levels (abop_1_24c: 4,096 branches, not regrouped, so the
    worker starts at once): exit 143 and one line, no folder left, and the worker ends with
    its parent (it ignores the signal itself; PR_SET_PDEATHSIG)."""
    proc = subprocess.Popen([PLANTLOD, "simplify", str(ROOT / "examples" / "abop_1_24c.lsys"),
                             "--levels", str(tmp_path / "lv"), "--jobs", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    workers = []
    while not workers:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.1)
        workers = [pid for pid in _children(proc.pid) if "spawn_main" in _command_line(pid)]
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signal.SIGTERM, stderr
    assert stderr.splitlines() == ["plantlod simplify: ended by SIGTERM"], stderr
    assert os.listdir(tmp_path) == []
    deadline = time.monotonic() + 30
    while any(_alive(pid) for pid in workers):
        assert time.monotonic() < deadline, "a worker outlived its parent"
        time.sleep(0.1)


def test_a_workers_error_is_raised_where_it_would_have_been():
    """A worker's error crosses to the parent as it is: plantlod's errors with their file,
    line and column; anything that does not pickle as a RuntimeError naming it."""
    from plantlod.lsys.errors import InputError
    from plantlod.simplify.chain_workers import _portable

    back = pickle.loads(pickle.dumps(_portable(InputError("level 3 diverges", "t.lsys", 4, 7))))
    assert isinstance(back, InputError) and str(back) == "t.lsys:4:7: level 3 diverges"

    class Odd(Exception):
        def __reduce__(self):
            raise TypeError("no")

    back = _portable(Odd("x"))
    assert type(back) is RuntimeError and str(back) == "Odd: x"


def test_levels_are_shared_from_both_ends_and_lost_ones_come_back():
    from plantlod.simplify.chain_workers import _Levels

    levels = _Levels(1, 5)
    taken = [levels.take(False), levels.take(True), levels.take(True), levels.take(False),
             levels.take(True), levels.take(False)]
    assert taken == [1, 5, 4, 2, 3, None]
    levels.put(5, "five")
    levels.worker_ended({4, 5})              # the worker that took 4 and 5 ended after 5
    assert levels.wait_for(5) and not levels.wait_for(4)


def _children(pid: int) -> list[int]:
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stat:
                    if int(stat.read().rsplit(")", 1)[1].split()[1]) == pid:
                        found.append(int(entry))
            except (OSError, IndexError, ValueError):
                continue
    return found


def _command_line(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False
