"""What a level's header comment says it was fitted under: the time step and damping.

`plantlod simplify` writes its header (`simplify.pipeline.header_comment`) first in the level
file, as comment lines:

    # plantlod simplify: level 1 of stalk8.lsys (derivation length 3 -> 2)
    ...
    # damping ratio: 0.05 (fitted and measured under it; simulate it with --damping-ratio)
    # errors of this file against the original (model.md section 6), steady winds from rest,
    # dt 0.01 s, 20 s, every 4 steps sampled:

A level holds under the time step and damping it was fitted at (a branch's period depends
on Δt, model.md 4; the swing's decay on ζ), which the file's parameters cannot say: only the
header does. `fitted_conditions` reads them back, so that a run under other conditions can say
so (the commands `simulate` and `compare`, and the API's). A file without that header (hand-written, or edited so that the
first lines are no longer simplify's) gives None: nothing is assumed.
"""

from __future__ import annotations

import io
import os
import re
from dataclasses import dataclass

HEADER_START = "plantlod simplify: "           # the first header line's start
DAMPING_RATIO_LINE = "damping ratio: "          # present only where ζ > 0
RUNS_LINE = "dt "                               # "dt 0.01 s, 20 s, every 4 steps sampled:"

_NUMBER = r"([0-9.eE+-]+)"
_DAMPING = re.compile(re.escape(DAMPING_RATIO_LINE) + _NUMBER + r"\b")
_RUNS = re.compile(re.escape(RUNS_LINE) + _NUMBER + r" s, ")


@dataclass(frozen=True)
class FittedConditions:
    """dt (s) and damping ratio ζ (0: undamped) a level was fitted and measured under."""

    dt: float
    damping_ratio: float

    def said(self, name: str, dt: float, damping_c: float, damping_ratio: float,
             spelling: dict[str, str]) -> str | None:
        """The warning where a run at ``dt`` with damping c ``damping_c`` or ratio
        ``damping_ratio`` differs from these conditions, None where it runs as fitted;
        ``spelling`` names the options as the caller gives them (`CLI_SPELLING`,
        `API_SPELLING`)."""
        differ = []
        if not _same(dt, self.dt):
            differ.append(spelling["dt"].format(f"{self.dt:g}"))
        if damping_c:                          # a coefficient c: neither undamped nor a ratio
            differ.append(spelling["ratio_for_c"].format(f"{self.damping_ratio:g}")
                          if self.damping_ratio else spelling["no_c"])
        elif not _same(damping_ratio, self.damping_ratio):
            differ.append(spelling["ratio"].format(f"{self.damping_ratio:g}"))
        if not differ:
            return None
        fitted = f"damping ratio {self.damping_ratio:g}" if self.damping_ratio else "undamped"
        return (f"{name}: simplify fitted and measured this level at dt {self.dt:g} s, "
                f"{fitted} (its header); this run differs, and the level's figures hold only "
                f"under those: give {', '.join(differ)}")


CLI_SPELLING = {"dt": "--dt {}", "ratio": "--damping-ratio {}",
                "ratio_for_c": "--damping-ratio {} in place of --damping", "no_c": "no --damping"}
API_SPELLING = {"dt": "dt={}", "ratio": "damping_ratio={}",
                "ratio_for_c": "damping_ratio={} in place of damping", "no_c": "no damping"}


def _same(a: float, b: float) -> bool:
    """Equal to the 6 significant digits a header writes (``:g``)."""
    return f"{a:g}" == f"{b:g}"


def fitted_conditions(text: str) -> FittedConditions | None:
    """The conditions in ``text``'s leading comment lines where they are simplify's header
    (its first line starts with HEADER_START and it has the runs' line), else None."""
    return comment_conditions(leading_comment(text))


def leading_comment(text: str) -> str:
    """The comment lines a file's ``text`` starts with, without their ``#`` (blank lines
    skipped): where simplify writes its header. The leading lines only, not a whole level."""
    lines = []
    for line in io.StringIO(text):
        stripped = line.strip()
        if not stripped:
            continue
        if not stripped.startswith("#"):
            break
        lines.append(stripped.lstrip("#"))
    return "\n".join(lines)


def comment_conditions(comment: str) -> FittedConditions | None:
    """`fitted_conditions` of a header comment's text without its ``#`` (an `LSystem`'s
    ``comment``, as `plantlod.simplify` returns it)."""
    lines = [line.strip() for line in comment.splitlines() if line.strip()]
    if not lines or not lines[0].startswith(HEADER_START):
        return None
    dt = ratio = None
    for line in lines[1:]:
        if ratio is None and (m := _DAMPING.match(line)):
            ratio = _float(m.group(1))
        elif dt is None and (m := _RUNS.match(line)):
            dt = _float(m.group(1))
    if dt is None or not dt > 0:
        return None
    return FittedConditions(dt, ratio if ratio is not None and ratio >= 0 else 0.0)


_LEVEL_OF = re.compile(re.escape(HEADER_START) + r"level (\d+) of (.+) \((?:derivation length|"
                       r"explicit form)[^()]*\)$")


def comment_source(comment: str) -> str | None:
    """The file a level says it was simplified from, as simplify was given it (the header's
    first line: ``plantlod simplify: level 1 of stalk8.lsys (…)``), from a header comment's
    text without its ``#`` (an `LSystem`'s ``comment``); None where there is no such line or
    it came from standard input."""
    first = next((line.strip() for line in comment.splitlines() if line.strip()), "")
    m = _LEVEL_OF.match(first)
    return m.group(2) if m and m.group(2) != "<input>" else None


def made_from_another(source: str | None, level: str, original: str) -> str | None:
    """The warning where a level (named ``level``) whose header names ``source`` as the file
    it was made from is compared with ``original``, another file by name; None where they
    agree, or either is unknown (no header, stdin, the text itself). A level compared with a
    tree it was not made from gave 100 % figures, or an error about addresses alone (a
    newcomer's first hour); the CLI and the API say the same."""
    if source is None or original in ("", "-", "<stdin>", "<text>"):
        return None
    if os.path.basename(source) == os.path.basename(original):
        return None
    return f"{level}: its header says it is a level of {source}, and it is compared here " \
           f"with {original}"


def _float(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if value == value and abs(value) != float("inf") else None
