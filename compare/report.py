"""Tables and JSON for `plantlod compare` (docs/compare.md).

The table is for people: angles in degrees, periods in seconds, relative
errors as fractions, every number with `TABLE_FLOAT_FORMAT`, undefined values
as ``-``. It comes as plain aligned text (`plain_table`, deterministic bytes,
for pipes and files) or as a rich table for a terminal (`rich_tables`); both
show the same cells.

The JSON is for programs: SI units (radians, seconds, metres), relative errors
as fractions, floats rounded to `JSON_SIGNIFICANT_DIGITS` significant digits,
undefined values as ``null``, keys in a fixed order.
"""

from __future__ import annotations

import json
import math

import numpy as np

from .runs import AngleDifference, Comparison, Violation
from .measures import COMPONENTS, json_float

from plantlod.formats.constants import JSON_SIGNIFICANT_DIGITS, TABLE_FLOAT_FORMAT
from plantlod.lsys.words import counted

UNDEFINED = "-"

GROUP_HEADERS = ["group", "members", "path", "component", "A orig (deg)", "A simp (deg)",
                 "A error", "P orig (s)", "P simp (s)", "P error", "counted", "tip error"]
LEFT_ALIGNED = ("group", "root", "component", "counted", "branch")
DIFF_HEADERS = ["branch", "max |Δbend| (deg)", "at t (s)", "max |Δrot| (deg)", "at t (s)"]


# --- numbers -------------------------------------------------------------------------

def fmt(value: float | None, scale: float = 1.0) -> str:
    """A table cell: TABLE_FLOAT_FORMAT of value * scale, ``-`` for None or NaN, never ``-0``."""
    if value is None or not math.isfinite(value):
        return UNDEFINED
    return TABLE_FLOAT_FORMAT % (value * scale + 0.0)


def round_floats(value):
    """A copy of a JSON-ready value with every float rounded to JSON_SIGNIFICANT_DIGITS.

    NaN and infinities become None; -0.0 becomes 0.0. Dicts keep their key order.
    """
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            return None
        return float(f"{value:.{JSON_SIGNIFICANT_DIGITS}g}") + 0.0
    if isinstance(value, dict):
        return {k: round_floats(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [round_floats(v) for v in value]
    if isinstance(value, np.generic):
        return round_floats(value.item())
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def dumps(document: dict) -> str:
    """The JSON text of a document (rounded floats, two-space indent, final newline)."""
    return json.dumps(round_floats(document), indent=2, ensure_ascii=False, allow_nan=False) + "\n"


# --- the comparison report --------------------------------------------------------------

def group_headers(comparison: Comparison) -> list[str]:
    """GROUP_HEADERS, with a column ``root`` after ``group`` for an explicit level: the
    original branch rooting each group (its ``groups:`` section), where ``group`` is the
    level's own address of its branch."""
    if comparison.simplified.tree.group_root:
        return GROUP_HEADERS[:1] + ["root"] + GROUP_HEADERS[1:]
    return GROUP_HEADERS


def group_rows(comparison: Comparison) -> list[list[str]]:
    """Two table rows per group (bend, rotation), in simplified-branch order (the columns of
    `group_headers`)."""
    roots = comparison.simplified.tree.group_root
    members = np.bincount(comparison.groups[comparison.groups >= 0],
                          minlength=len(comparison.paths))
    deg = 180.0 / math.pi
    rows = []
    for j, g in enumerate(comparison.report.groups):
        for c, name in enumerate(COMPONENTS):
            f = g.component(name)
            first = c == 0
            rows.append([
                g.address if first else ""] + ([roots[j] if first else ""] if roots else []) + [
                str(int(members[j])) if first else "",
                str(len(comparison.paths[j])) if first else "", name,
                fmt(f.amplitude_original, deg), fmt(f.amplitude_simplified, deg),
                fmt(f.amplitude_error), fmt(f.period_original), fmt(f.period_simplified),
                fmt(f.period_error), "yes" if f.counted else "no",
                fmt(g.tip_error) if first else "",
            ])
    return rows


def _where(worst) -> str:
    if worst is None:
        return ""
    return f" at group {worst.address}" + (f" {worst.component}" if worst.component else "")


def headline_lines(comparison: Comparison) -> list[str]:
    """The worst-group figures and where they are, one line each."""
    r = comparison.report
    undefined = ", ".join(f"{w.address} {w.component}" for w in r.undefined_periods) or "none"
    return [
        f"worst amplitude error: {fmt(r.amplitude_error)}{_where(r.amplitude_error_at)}",
        f"worst period error:    {fmt(r.period_error)}{_where(r.period_error_at)}",
        f"worst tip error:       {fmt(r.tip_error)}{_where(r.tip_error_at)}",
        f"motion error:          {fmt(r.motion_error)}{_where(r.motion_error_at)}",
        f"period error (major):  {fmt(r.period_error_major)}{_where(r.period_error_major_at)}",
        f"tip error (max), m:    {fmt(r.tip_error_max_m)}{_where(r.tip_error_max_m_at)}",
        f"undefined periods:     {undefined}",
    ]


def context_lines(comparison: Comparison) -> list[str]:
    """What was compared: the two trees and the window."""
    o, s, r = comparison.original, comparison.simplified, comparison.report
    k = comparison.window.stop - comparison.window.start
    return [
        f"original:   {o.name} ({counted(o.tree.n_branches, 'branch', False)}, "
        f"{counted(o.tree.n_leaves, 'leaf', False)}, rest height {fmt(r.rest_height)} m)",
        f"simplified: {s.name} ({counted(s.tree.n_branches, 'branch', False)} = groups, "
        f"{counted(s.tree.n_leaves, 'leaf', False)}; "
        f"{counted(comparison.unassigned, 'original branch', False)} in no group)",
        f"window:     {fmt(r.t0)} to {fmt(r.t1)} s ({k} samples)",
    ]


def plain_table(headers: list[str], rows: list[list[str]], left: tuple[str, ...] = LEFT_ALIGNED
                ) -> str:
    """Aligned plain text, columns two spaces apart: those named in ``left`` left-aligned,
    the others (numbers) right-aligned; no trailing spaces."""
    widths = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(headers)]
    flush_left = [h in left for h in headers]

    def line(cells: list[str]) -> str:
        parts = [c.ljust(w) if lft else c.rjust(w) for c, w, lft in zip(cells, widths, flush_left)]
        return "  ".join(parts).rstrip() + "\n"

    return line(headers) + line(["-" * w for w in widths]) + "".join(line(r) for r in rows)


def comparison_text(comparisons: list[Comparison]) -> str:
    """The whole plain-text report: per simplified tree, context, group table and headline."""
    blocks = []
    for comp in comparisons:
        blocks.append("".join(line + "\n" for line in context_lines(comp)) + "\n"
                      + plain_table(group_headers(comp), group_rows(comp)) + "\n"
                      + "".join(line + "\n" for line in headline_lines(comp)))
    return "\n".join(blocks)


def print_rich(comparisons: list[Comparison], console) -> None:
    """The same report as `comparison_text`, as rich tables on ``console`` (a terminal)."""
    from rich.table import Table

    for i, comp in enumerate(comparisons):
        if i:
            console.print()
        for line in context_lines(comp):
            console.print(line, markup=False, highlight=False)
        table = Table(show_edge=False, header_style="bold")
        for h in group_headers(comp):
            table.add_column(h, justify="left" if h in LEFT_ALIGNED else "right", no_wrap=True)
        for row in group_rows(comp):
            table.add_row(*row)
        console.print(table)
        for line in headline_lines(comp):
            console.print(line, markup=False, highlight=False)


def comparison_document(comparisons: list[Comparison], bounds: dict[str, float | None],
                        violations: list[list[Violation]]) -> dict:
    """The JSON object of docs/compare.md ("JSON output"), before rounding.

    violations : one list per comparison (`plantlod.compare.runs.check_bounds`).
    """
    first = comparisons[0]
    o = first.original
    out = {
        "original": {"file": o.name, "branches": o.tree.n_branches, "leaves": o.tree.n_leaves,
                     "rest_height": first.report.rest_height},
        "samples": int(len(o.times)),
        "time": [float(o.times[0]), float(o.times[-1])],
        "bounds": {f"max_{k}": (None if v is None else float(v)) for k, v in bounds.items()},
        "passed": not any(violations),
        "comparisons": [],
    }
    for comp, broken in zip(comparisons, violations):
        report = comp.report.to_dict()
        groups = report.pop("groups")
        addr = comp.original.tree.address
        members = np.bincount(comp.groups[comp.groups >= 0], minlength=len(comp.paths))
        for j, g in enumerate(groups):
            g_address = g.pop("address")
            groups[j] = {"address": g_address, "members": int(members[j]),
                         "main_path": [addr[i] for i in comp.paths[j].tolist()], **g}
        s = comp.simplified
        out["comparisons"].append({
            "simplified": {"file": s.name, "branches": s.tree.n_branches, "leaves": s.tree.n_leaves},
            "unassigned_branches": comp.unassigned,
            **report,
            # (an undefined figure breaks its bound as None, as the figures above say it)
            "exceeded": [{"bound": v.option, "figure": v.figure, "value": json_float(v.value),
                          "limit": json_float(v.limit), "at": None if v.at is None else v.at.to_dict()}
                         for v in broken],
            "groups": groups,
        })
    return out


# --- two angle CSVs of one tree -------------------------------------------------------

def difference_rows(diff: AngleDifference) -> list[list[str]]:
    """One row per branch: largest |Δbend| and |Δrot| in degrees and when they occur."""
    deg = 180.0 / math.pi
    return [[a, fmt(b, deg), fmt(bt), fmt(r, deg), fmt(rt)]
            for a, b, bt, r, rt in zip(diff.addresses, diff.bend.tolist(), diff.bend_at.tolist(),
                                       diff.rot.tolist(), diff.rot_at.tolist())]


def difference_document(diff: AngleDifference, name_a: str, name_b: str, samples: int,
                        atol: float | None) -> dict:
    """The JSON object of the CSV-against-CSV mode (docs/compare.md), before rounding."""
    j, component = diff.worst()
    largest = float(diff.largest[j])
    return {
        "a": name_a, "b": name_b, "samples": samples, "atol": atol,
        "largest": largest,
        "at": {"address": diff.addresses[j], "component": component,
               "t": float(diff.bend_at[j] if component == "bend" else diff.rot_at[j])},
        "passed": atol is None or largest <= atol,
        "branches": [{"address": a, "bend": b, "bend_t": bt, "rotation": r, "rotation_t": rt}
                     for a, b, bt, r, rt in zip(diff.addresses, diff.bend.tolist(),
                                                diff.bend_at.tolist(), diff.rot.tolist(),
                                                diff.rot_at.tolist())],
    }
