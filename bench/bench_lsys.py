"""L-system benchmarks: derivation and turtle throughput, `plantlod derive` end to end,
and the start-up time of `plantlod --help`.

``run(report)`` is called by bench/run.py; ``python bench/bench_lsys.py`` runs it
alone. Every figure is the best of ``REPEATS`` runs (wall clock, so the least
disturbed one). The inputs are the bundled examples with ``-n``:

- ABOP 1.24a (F -> F[+FL]F[-FL]F, not parametric: the table-lookup fast path)
  at n = 8: 2 + 12 (5^8 - 1) / 4 = 1,171,874 modules, 390,625 branches;
- ABOP 2.6a (parametric: the general engine) at n = 17: 917,498 modules, the
  derivation length nearest one million (n = 18 doubles it).
"""

from __future__ import annotations

import os
import pathlib
import stat
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
COMMAND = ".venv/bin/python bench/run.py lsys"
REPEATS = 3
ABOP_124A, N_124A = ROOT / "examples" / "abop_1_24a.lsys", 8
ABOP_26, N_26 = ROOT / "examples" / "abop_2_6.lsys", 17
PLANTLOD = ROOT / ".venv" / "bin" / "plantlod"

# Run in a fresh interpreter: which heavy modules does `plantlod --help` import?
_HELP_IMPORTS = """
import sys
from plantlod.cli.main import cli
try:
    cli(["--help"], prog_name="plantlod")
except SystemExit:
    pass
print(",".join(m for m in ("numba", "numpy", "scipy", "trimesh", "rich") if m in sys.modules),
      file=sys.stderr)
"""


def _best(func, repeats: int = REPEATS) -> tuple[float, object]:
    """(least seconds, last result) of ``func()`` over ``repeats`` calls."""
    best, result = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - t0)
    return best, result


def _system(path: pathlib.Path):
    from plantlod.lsys.parse import parse_lsys

    return parse_lsys(path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)))


def derive_rate(path: pathlib.Path, n: int) -> tuple[int, float]:
    """(modules, modules per second) of `derive` for ``n`` steps, best of REPEATS."""
    from plantlod.lsys.derive import derive

    system = _system(path)
    derive(system, 2)                                   # warm caches and imports
    seconds, derived = _best(lambda: derive(system, n))
    return len(derived), len(derived) / seconds


def turtle_rate(path: pathlib.Path, n: int) -> tuple[int, int, float]:
    """(modules read, branches, modules per second) of the turtle (`build_tree`)."""
    from plantlod.lsys.derive import derive, interpret
    from plantlod.lsys.turtle import build_tree

    system = _system(path)
    interpreted = interpret(system, derive(system, n))
    build_tree(system, interpret(system, derive(system, 2)))      # warm
    seconds, tree = _best(lambda: build_tree(system, interpreted))
    return len(interpreted), tree.n_branches, len(interpreted) / seconds


def _devnull_is_a_device() -> bool:
    return stat.S_ISCHR(os.stat(os.devnull).st_mode)


def derive_wall_time(path: pathlib.Path, n: int) -> float:
    """Seconds of ``plantlod derive FILE -n N -o /dev/null`` in a subprocess (start-up included)."""
    args = [str(PLANTLOD), "derive", str(path.relative_to(ROOT)), "-n", str(n), "-o", os.devnull]

    def once():
        subprocess.run(args, cwd=ROOT, check=True, capture_output=True)
        if not _devnull_is_a_device():       # open_output must write devices in place
            raise RuntimeError(f"{os.devnull} is no longer a character device")

    seconds, _ = _best(once)
    return seconds


def help_time() -> tuple[float, str]:
    """(seconds of ``plantlod --help`` in a subprocess, heavy modules it imported)."""
    seconds, _ = _best(lambda: subprocess.run([str(PLANTLOD), "--help"], cwd=ROOT, check=True,
                                              capture_output=True))
    done = subprocess.run([sys.executable, "-c", _HELP_IMPORTS], cwd=ROOT, check=True,
                          capture_output=True, text=True)
    return seconds, done.stderr.strip()


# Deep chains (session 21, found by fuzzing): addresses of thousands of parts, where
# building them prefix by prefix cost the cube of the depth (a 3,000-deep chain 4.2 s,
# 8,900 deep 481 s), and a stochastic chain read its history once a step (1,500 steps 26 s).
DEEP_CHAIN = """derivation_length: {n}
branching_angle: 30
force_absorbed: 0.005
force_propagated: 0.7
branch F: length=1 radius=0.02 bend_strength=20 rotation_strength=20
leaf L: area=0.01
axiom: A L
productions:
{rules}
"""
DEEP_STEPS, STOCHASTIC_STEPS = 3000, 1500


def deep_chain_time(stochastic: bool) -> tuple[int, float]:
    """(branches, seconds) of deriving and building the chain A -> F A (stochastic: A ->
    (0.5) F A, A -> (0.5) A) to its addressed tree, best of REPEATS."""
    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys

    rules = ("  A -> (0.5) F A\n  A -> (0.5) A" if stochastic else "  A -> F A")
    n = STOCHASTIC_STEPS if stochastic else DEEP_STEPS
    system = parse_lsys(DEEP_CHAIN.format(n=n, rules=rules), "chain.lsys")
    seconds, built = _best(lambda: build(system))
    return built.tree.n_branches, seconds


def run(report) -> None:
    modules, rate = derive_rate(ABOP_124A, N_124A)
    report(f"derive ABOP 1.24a n={N_124A} ({modules:,} modules, fast path)", rate, "modules/s",
           ">= 5e6", COMMAND)
    modules, rate = derive_rate(ABOP_26, N_26)
    report(f"derive ABOP 2.6 n={N_26} ({modules:,} modules, parametric)", rate, "modules/s",
           ">= 5e5", COMMAND)
    modules, branches, rate = turtle_rate(ABOP_124A, N_124A)
    report(f"turtle ABOP 1.24a n={N_124A} ({modules:,} modules, {branches:,} branches)", rate,
           "modules/s", ">= 1e6", COMMAND)
    seconds = derive_wall_time(ABOP_124A, N_124A)
    report(f"plantlod derive abop_1_24a.lsys -n {N_124A} -o /dev/null (subprocess)", seconds, "s",
           "", COMMAND)
    for stochastic in (False, True):
        branches, seconds = deep_chain_time(stochastic)
        kind = f"stochastic chain n={STOCHASTIC_STEPS}" if stochastic else f"chain n={DEEP_STEPS}"
        report(f"derive and build a {kind} ({branches:,} branches deep)", seconds, "s", "", COMMAND)
    seconds, heavy = help_time()
    report(f"plantlod --help start-up (heavy modules imported: {heavy or 'none'})", seconds, "s",
           "no numba", COMMAND)


if __name__ == "__main__":
    def _print(name, value, unit, target="", command=""):
        print(f"{name}: {value:.4g} {unit}" + (f" (target {target})" if target else ""))

    run(_print)
