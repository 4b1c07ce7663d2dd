#!/usr/bin/env python3
"""Turn `plantlod compare --json` files into one Markdown table of errors.

Usage:
    python3 results_table.py [--command TEXT ...] [--title TEXT] FILE.json ... > results.md

Each FILE is named TREE-lLEVEL-METHOD-wWIND.json (the names examples/Makefile
gives them; TREE holds no '-'), for example stalk8-l1-derived-w0.5.json: the
level-LEVEL simplification of TREE made with METHOD, compared with TREE in a
steady wind of WIND m/s. The name is where the row's labels come from; the
figures come from the file (its first comparison): the worst-group amplitude,
period and tip errors of docs/errors.md, as percentages with two decimals,
and the largest original combined-angle amplitude in radians.

Two tables: one row per (tree, level, method) with each figure's worst value
over the winds and the wind where it occurs, then one row per file.

Rows are sorted by tree, level, method and wind (numerically), so the bytes of
the table depend only on the set of files, not their order. Each --command is
printed below the table as it is given (the commands that made the files).

Only the Python standard library is used, so the script can be copied anywhere.
Exit status 2 with one line on stderr for a file that cannot be read or named.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import re
import sys

NAME = re.compile(r"^(?P<tree>[^-]+)-l(?P<level>\d+)-(?P<method>[^-]+)-w(?P<wind>[0-9.]+)\.json$")
UNDEFINED = "-"
TITLE = "Simplified trees against their originals"


class TableError(Exception):
    """A file that cannot be turned into a row (bad name, unreadable, not compare JSON)."""


def percent(fraction: float | None) -> str:
    """A fraction as a percentage with two decimals, e.g. 0.01234 -> '1.23 %'; None -> '-'."""
    if fraction is None or not math.isfinite(fraction):
        return UNDEFINED
    return f"{100.0 * fraction:.2f} %"


def radians(value: float | None) -> str:
    """An angle in radians with four decimals; None -> '-'."""
    if value is None or not math.isfinite(value):
        return UNDEFINED
    return f"{value:.4f}"


def read_row(path: pathlib.Path) -> dict:
    """The labels (from the file name) and figures (from the JSON) of one compare file."""
    match = NAME.match(path.name)
    if match is None:
        raise TableError(f"{path}: expected a name TREE-lLEVEL-METHOD-wWIND.json, "
                         f"e.g. stalk8-l1-derived-w0.5.json")
    try:
        wind = float(match["wind"])
    except ValueError:
        raise TableError(f"{path}: expected a wind speed in m/s after '-w', got {match['wind']!r}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise TableError(f"{path}: cannot read: {exc.strerror}") from None
    except ValueError as exc:
        raise TableError(f"{path}: expected JSON from `plantlod compare --json`: {exc}") from None
    try:
        original = data["original"]
        comparison = data["comparisons"][0]
        row = {
            "tree": match["tree"], "level": int(match["level"]), "method": match["method"],
            "wind": wind, "wind_text": match["wind"],
            "branches": f"{original['branches']} → {comparison['simplified']['branches']}",
            "amplitude": comparison["amplitude_error"],
            "period": comparison["period_error"],
            "tip": comparison["tip_error"],
            "undefined_periods": len(comparison["undefined_periods"]),
            "largest": comparison["largest_amplitude"],
            "time": tuple(data["time"]), "samples": data["samples"],
        }
    except (KeyError, IndexError, TypeError) as exc:
        raise TableError(f"{path}: expected JSON from `plantlod compare --json` "
                         f"(missing {exc})") from None
    return row


def sort_key(row: dict) -> tuple:
    return (row["tree"], row["level"], row["method"], row["wind"])


def _worst(rows: list[dict], key: str) -> str:
    """The largest defined figure over ``rows`` as a percentage, with its wind: '1.26 % (20)'."""
    defined = [r for r in rows if r[key] is not None and math.isfinite(r[key])]
    if not defined:
        return UNDEFINED
    worst = max(defined, key=lambda r: (r[key], -r["wind"]))   # ties: the lowest wind
    return f"{percent(worst[key])} ({worst['wind_text']})"


def summary_lines(rows: list[dict]) -> list[str]:
    """One row per (tree, level, method): the worst of each figure over the winds."""
    groups: dict[tuple, list[dict]] = {}
    for r in sorted(rows, key=sort_key):
        groups.setdefault((r["tree"], r["level"], r["method"]), []).append(r)
    lines = [
        "| tree | level | branches | method | winds (m/s) | amplitude error | period error "
        "| tip error |",
        "|---|--:|--:|---|---|--:|--:|--:|",
    ]
    for (tree, level, method), members in groups.items():
        winds = ", ".join(r["wind_text"] for r in members)
        lines.append(f"| {tree} | {level} | {members[0]['branches']} | {method} | {winds} "
                     f"| {_worst(members, 'amplitude')} | {_worst(members, 'period')} "
                     f"| {_worst(members, 'tip')} |")
    return lines


def run_lines(rows: list[dict]) -> tuple[list[str], bool]:
    """One row per file, and whether some row's period leaves out undefined periods."""
    lines = [
        "| tree | level | branches | method | wind (m/s) | amplitude error | period error "
        "| tip error | largest A (rad) |",
        "|---|--:|--:|---|--:|--:|--:|--:|--:|",
    ]
    any_undefined = False
    for r in sorted(rows, key=sort_key):
        period = percent(r["period"])
        if r["undefined_periods"]:
            period += " *"
            any_undefined = True
        lines.append(
            f"| {r['tree']} | {r['level']} | {r['branches']} | {r['method']} | {r['wind_text']} "
            f"| {percent(r['amplitude'])} | {period} | {percent(r['tip'])} "
            f"| {radians(r['largest'])} |")
    return lines, any_undefined


def markdown(rows: list[dict], commands: list[str], title: str) -> str:
    """The whole document as Markdown text (ends with a newline)."""
    lines = [f"# {title}", ""]
    lines += [
        "Worst-group errors of each simplified tree against its original in a steady "
        "wind from rest (docs/errors.md): amplitude and period error over the counted "
        "combined angles, tip error as a fraction of the original's rest height.",
        "",
        "## Worst over the winds",
        "",
        "Each figure's largest value over the winds, with that wind (m/s) in brackets.",
        "",
    ]
    lines += summary_lines(rows)
    lines += ["", "## Every run", "",
              "\"largest A\" is the original's largest combined-angle amplitude (rad).", ""]
    table, any_undefined = run_lines(rows)
    lines += table + [""]
    if any_undefined:
        lines += ["\\* some counted components had no defined period (fewer than two "
                  "upward crossings) and are left out of the period error.", ""]
    for (t0, t1), samples in sorted({(r["time"], r["samples"]) for r in rows}):
        lines.append(f"Runs from t = {t0:g} to {t1:g} s, {samples} samples.")
    if commands:
        lines += ["", "Made by:", "", "```sh"] + commands + ["```"]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Markdown table of `plantlod compare --json` files named "
                    "TREE-lLEVEL-METHOD-wWIND.json.")
    parser.add_argument("files", nargs="+", metavar="FILE.json", type=pathlib.Path)
    parser.add_argument("--command", action="append", default=[], metavar="TEXT",
                        help="a command that made the files, printed below the table")
    parser.add_argument("--title", default=TITLE, help="the table's heading")
    args = parser.parse_args(argv)
    try:
        rows = [read_row(path) for path in args.files]
        seen = {}
        for path, row in zip(args.files, rows):
            key = sort_key(row)
            if key in seen:
                raise TableError(f"{path}: same tree, level, method and wind as {seen[key]}")
            seen[key] = path
    except TableError as exc:
        print(f"results_table.py: error: {exc}", file=sys.stderr)
        return 2
    sys.stdout.write(markdown(rows, [" ".join(c.split()) for c in args.command], args.title))
    return 0


if __name__ == "__main__":
    sys.exit(main())
