"""Run every benchmark (bench/bench_*.py) and print one table of figures.

Each benchmark module defines ``run(report)`` and calls
``report(name, value, unit, target, command)`` once per figure. Figures are
wall-clock measurements on a shared machine: compare ratios taken in one run,
not absolute numbers across runs.

Usage: make bench   (or: .venv/bin/python bench/run.py [NAME ...])
"""

from __future__ import annotations

import importlib.util
import pathlib
import platform
import sys

HERE = pathlib.Path(__file__).resolve().parent


def _load(path: pathlib.Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(HERE))
    spec.loader.exec_module(mod)
    return mod


def main(argv: list[str]) -> int:
    wanted = set(argv)
    known = {path.stem.removeprefix("bench_") for path in HERE.glob("bench_*.py")}
    if wanted - known:                  # (a typo ran nothing and exited 0)
        print(f"bench/run.py: error: no benchmark {', '.join(sorted(wanted - known))}; "
              f"expected some of {', '.join(sorted(known))}", file=sys.stderr)
        return 2
    rows: list[tuple[str, str, str, str, str]] = []

    def report(name, value, unit, target="", command=""):
        text = f"{value:,.3g}" if isinstance(value, float) else f"{value:,}"
        rows.append((name, text, unit, target, command))
        print(f"  {name}: {text} {unit}" + (f"   (target {target})" if target else ""),
              flush=True)

    print(f"# plantlod benchmarks on {platform.machine()}, Python {platform.python_version()}")
    for path in sorted(HERE.glob("bench_*.py")):
        if wanted and path.stem.removeprefix("bench_") not in wanted:
            continue
        print(f"## {path.stem}", flush=True)
        _load(path).run(report)
    print()
    print("| figure | value | unit | target | command |")
    print("|---|---:|---|---|---|")
    for name, text, unit, target, command in rows:
        print(f"| {name} | {text} | {unit} | {target} | `{command}` |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
