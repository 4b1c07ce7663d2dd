"""What the explicit form costs (issue 21 item 5): one level, and a whole chain.

- `plantlod simplify abop_1_24a.lsys (derivation length 5, 3,125 branches) --level 1
  --form explicit`: target 10 s.
- `plantlod simplify abop_1_24c.lsys (4,096 branches) --levels DIR`: every explicit level,
  target 30 s and 2 GB, in the default two processes (`simplify.chain_workers`), and the
  same with `--jobs 1` for the ratio (measured in the same run).

Each is the command as a user runs it, wall clock, peak memory from /proc: the largest sum
of the resident sets of the command and its workers (or the command's own VmHWM where
larger; bench/peak_memory.py).

    .venv/bin/python bench/bench_explicit_cost.py
"""

from __future__ import annotations

import pathlib
import re
import tempfile

from peak_memory import run_with_peak

ROOT = pathlib.Path(__file__).resolve().parents[1]
PLANTLOD = ROOT / ".venv" / "bin" / "plantlod"
LEVEL_COMMAND = "plantlod simplify abop_1_24a.lsys (derivation_length 5) --level 1 --form explicit"
CHAIN_COMMAND = "plantlod simplify examples/abop_1_24c.lsys --levels DIR"
MEMORY = "VmRSS of the command and its workers, summed, polled (/proc)"


def run(report) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        work = pathlib.Path(tmp)
        source = (ROOT / "examples" / "abop_1_24a.lsys").read_text()
        path = work / "a5.lsys"
        path.write_text(re.sub(r"(?m)^derivation_length: .*$", "derivation_length: 5", source))
        _out, _err, seconds, mb = run_with_peak(
            [str(PLANTLOD), "simplify", str(path), "--level", "1", "--form", "explicit",
             "-o", str(work / "a5_l1.lsys")])
        report("explicit form, abop_1_24a n=5 (3,125 branches), level 1: wall", seconds, "s",
               "<= 10", LEVEL_COMMAND)
        report("explicit form, abop_1_24a n=5, level 1: peak memory", mb, "MB", "", MEMORY)
        for jobs in ("2", "1"):
            folder = work / f"levels{jobs}"
            _out, err, seconds, mb = run_with_peak(
                [str(PLANTLOD), "simplify", str(ROOT / "examples" / "abop_1_24c.lsys"),
                 "--levels", str(folder), "--jobs", jobs])
            count = len(list(folder.glob("level*.lsys")))
            name = f"explicit chain, abop_1_24c (4,096 branches, {count} levels), --jobs {jobs}"
            report(f"{name}: wall", seconds, "s", "<= 30" if jobs == "2" else "",
                   CHAIN_COMMAND + f" --jobs {jobs}")
            report(f"{name}: peak memory", mb, "MB", "<= 2048" if jobs == "2" else "", MEMORY)


if __name__ == "__main__":
    def _print(name, value, unit, target="", command=""):
        print(f"{name}: {value:.3g} {unit}" + (f"  (target {target})" if target else ""))

    run(_print)
