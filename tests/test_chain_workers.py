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
        workers = [pid for pid in _children(proc.pid) if "plantlod.sim.workers" in _command_line(pid)]
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signal.SIGTERM, stderr
    assert stderr.splitlines() == ["plantlod simplify: ended by SIGTERM"], stderr
    assert os.listdir(tmp_path) == []
    # the handler kills and reaps its workers before it exits (session 26: they lived on
    # for 1-2 s, killed by PR_SET_PDEATHSIG only once the parent had gone); one still
    # starting (a signal during its Popen) asks for that kill before any import
    deadline = time.monotonic() + 0.5
    while any(_alive(pid) for pid in workers):
        assert time.monotonic() < deadline, "a worker outlived its parent"
        time.sleep(0.01)


def test_a_workers_error_is_raised_where_it_would_have_been():
    """A worker's error crosses to the parent as it is: plantlod's errors with their file,
    line and column; anything that does not pickle as a RuntimeError naming it."""
    from plantlod.lsys.errors import InputError
    from plantlod.sim.workers import portable

    back = pickle.loads(pickle.dumps(portable(InputError("level 3 diverges", "t.lsys", 4, 7))))
    assert isinstance(back, InputError) and str(back) == "t.lsys:4:7: level 3 diverges"

    class Odd(Exception):
        def __reduce__(self):
            raise TypeError("no")

    back = portable(Odd("x"))
    assert type(back) is RuntimeError and str(back) == "Odd: x"


def test_jobs_are_shared_from_both_ends_and_lost_ones_come_back():
    from plantlod.sim.workers import Jobs

    jobs = Jobs(1, 5)
    taken = [jobs.take(False), jobs.take(True), jobs.take(True), jobs.take(False),
             jobs.take(True), jobs.take(False)]
    assert taken == [1, 5, 4, 2, 3, None]
    jobs.put(5, "five")
    jobs.worker_ended({4, 5})                # the worker that took 4 and 5 ended after 5
    assert jobs.wait_for(5) and not jobs.wait_for(4)


def test_jobs_in_workers_come_back_in_order_with_their_warnings_and_errors():
    """`run_jobs` with real spawned workers: results in job order whichever process ran
    them, a worker's warning warned here, a job's error raised in its turn (after the jobs
    before it), whether it ran here or in a worker."""
    import warnings

    import pytest

    from plantlod.sim.workers import run_jobs

    import time

    def slowly(k):                  # a job here takes 1 s, a worker's none: once up, the
        time.sleep(1.0)             # worker takes what is left from the back
        return ("here", k * k)

    got, seen = [], []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for k, value in run_jobs(1, 12, slowly, 1, _squares, 10):
            got.append((k, value[1]))
            seen.append(value[0])
    assert got == [(k, k * k) for k in range(1, 13)]
    assert seen[0] == "here" and seen[-1] == "worker"
    worker_jobs = [k for k, where in zip(range(1, 13), seen) if where == "worker"]
    assert sorted(str(w.message) for w in caught) == sorted(f"job {k}" for k in worker_jobs)

    def failing_here(k):
        if k == 2:
            raise ValueError("two")
        return ("here", k)

    out = []
    with pytest.raises(ValueError, match="two"):
        for k, value in run_jobs(1, 4, failing_here, 1, _squares, 10):
            out.append(k)
    assert out == [1]


def _squares(payload, ask):
    """A worker's job function for the test above: (where, k²), warning once per job."""
    import warnings

    def job(k):
        warnings.warn(f"job {k}", UserWarning)
        return ("worker", k * k)

    return job


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


def test_a_scenes_chains_in_two_processes_are_those_of_one(tmp_path):
    """`scene.levels.level_chains`: the tree files' chains not cached are fitted in two
    processes; texts and tip errors equal those fitted in one, all stored in the cache, and
    read back from it the second time."""
    import pathlib

    import numpy as np

    from plantlod.scene.levels import level_chains

    # (the last grown from another seed than its file's: a worker grows it from that seed)
    paths = [(ROOT / "examples" / "stalk8.lsys", None),
             (ROOT / "examples" / "eval" / "stalk_unequal.lsys", None),
             (ROOT / "examples" / "eval" / "twin_draw.lsys", None),
             (ROOT / "examples" / "eval" / "stochastic.lsys", 3)]
    got = {}
    for jobs in (1, 2):
        cache = tmp_path / f"cache{jobs}"
        got[jobs] = list(level_chains(paths, 5.0, 0.01, 2.0, cache, jobs=jobs))
        assert [p for p, _c, hit in got[jobs]] == paths and not any(h for _p, _c, h in got[jobs])
        assert len(list(cache.glob("*.json"))) == 4
    for (_p, one, _h), (_q, two, _g) in zip(got[1], got[2]):
        assert one.texts == two.texts and np.array_equal(one.tip_error_m, two.tip_error_m)
    again = list(level_chains(paths, 5.0, 0.01, 2.0, tmp_path / "cache2", jobs=2))
    assert all(hit for _p, _c, hit in again)
    assert [c.texts for _p, c, _h in again] == [c.texts for _p, c, _h in got[1]]
    assert isinstance(again[0][0][0], pathlib.Path)
