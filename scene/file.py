"""The scene file (TOML, docs/scene.md): trees, wind, camera, pixel budget, time.

    dt = 0.01
    duration = 10
    budget_px = 1
    [wind]    speed = 5, direction = 0, gust_strength = 0, gust_seed = 0, front_speed = 0
    [camera]  position = [0, -50, 2], target = [0, 0, 2], fov_deg = 60, height_px = 1080
              (or, moving: [[camera.key]] t = 0, position = [...], target = [...], one per key)
    [[tree]]  file = "stalk8.lsys", position = [0, 0, 0], heading = 0, scale = 1, seed = 3
    [scatter] files = ["a.lsys", "b.lsys"], count = 100, seed = 1,
              area = [x0, y0, x1, y1], min_spacing = 5, tree_seeds = [1, 2, 3]

A tree's ``seed`` (model.md 7: a file, a seed, a position, a heading and a scale each) grows
its file's stochastic productions from that seed in place of the file's own ``seed:``; a
scatter's trees each draw one of ``tree_seeds``. Every distinct (file, seed) is a tree of its
own, with its own level chain (`Source`).

Every error is an `InputError` naming the file and the line of the offending key
(tomllib reports syntax errors with line and column; values are located by a scan of
the text for their key, within the section of the table being read: the second [[tree]]'s
seed at that tree's line, a table's missing key at its header).
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import pathlib
import re
import tomllib
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from plantlod.lsys.checks import did_you_mean, finite  # (finite: an integer of 400 digits is not)
from plantlod.lsys.errors import InputError, shown
from plantlod.sim.constants import MAX_DAMPING_RATIO, MAX_WIND_SPEED
from plantlod.sim.wind import gust_peak_factor
from plantlod.simplify.constants import SIMPLIFY_EVERY

from .constants import (MAX_SCATTER_CELLS, MAX_SCATTER_TRIES, MAX_SCENE_CHAINS,
                        MAX_SCENE_COORDINATE_M, MAX_SCENE_NESTING, MAX_SCENE_STEPS, MAX_TREE_SCALE,
                        MAX_TREES)

TOP_KEYS = {"dt", "duration", "budget_px", "damping_ratio", "wind", "camera", "tree", "scatter"}
WIND_KEYS = {"speed", "direction", "gust_strength", "gust_seed", "front_speed"}
CAMERA_KEYS = {"position", "target", "fov_deg", "height_px", "key"}
CAMERA_KEY_KEYS = {"t", "position", "target"}
TREE_KEYS = {"file", "position", "heading", "scale", "seed"}
SCATTER_KEYS = {"files", "count", "seed", "area", "min_spacing", "scale", "tree_seeds"}

# A tree file and the seed its stochastic productions grow from (None: the file's own
# ``seed:``): what one level chain stands for.
Source = tuple[pathlib.Path, int | None]


@dataclass(frozen=True)
class Placed:
    """One tree of the scene: its L-system file, base position (m), heading (deg), scale, and
    the seed it is grown from (None: the file's own; `read_scene` keeps a seed only where it
    grows another tree, `shared_seeds`)."""

    file: pathlib.Path
    position: tuple[float, float, float]
    heading: float
    scale: float
    seed: int | None = None

    @property
    def source(self) -> Source:
        return (self.file, self.seed)


def sources(trees: list[Placed]) -> list[Source]:
    """The distinct (file, seed) of ``trees`` in a fixed order: by file, then seed (the
    file's own first)."""
    return sorted({t.source for t in trees}, key=lambda s: (str(s[0]), -1 if s[1] is None else s[1]))


def members_by_source(trees: list[Placed]) -> dict[Source, list[int]]:
    """Each (file, seed) of ``trees`` -> the indices of its trees, in scene order (one pass:
    a scan per source, trees x sources, was 62 s at 2,000)."""
    members: dict[Source, list[int]] = {}
    for k, t in enumerate(trees):
        members.setdefault(t.source, []).append(k)
    return members


def source_name(source: Source, full: bool = False) -> str:
    """A source for messages and reports: the file's name (``full``: its path), and its seed
    where one is given."""
    path, seed = source
    name = str(path) if full else path.name
    return name if seed is None else f"{name} (seed {seed})"


@contextlib.contextmanager
def seed_named(source: Source):
    """Bad input found in a seeded tree (a time step too large for it, more branches than the
    limit) says which seed grew it: the file alone may not show it."""
    try:
        yield
    except InputError as exc:
        if source[1] is None:
            raise
        raise InputError(f"{exc.message} (the tree grown from seed {source[1]}, given in the "
                         "scene)", exc.file, exc.line, exc.col) from None


def shared_seeds(trees: list[Placed]) -> list[Placed]:
    """``trees`` with their seeds made canonical, so that trees of one tree share one chain:
    None (the file's own chain) for every seed that grows what the file grows anyway (a seed
    on a file without stochastic productions, the file's own ``seed:``, and any seed whose
    tree is the file's own: a production of probability 1, a derivation length of 0), and
    among seeds that grow one same other tree, the smallest of them. "The same tree" is the
    same `simplify.evaluate.tree_digest`, of everything a level's fit and runs read. Reads
    (and checks) each file that has a seed, and builds its trees of the seeds given."""
    from dataclasses import replace

    from plantlod.formats.lsys_file import read_lsys
    from plantlod.lsys.build import build
    from plantlod.simplify.evaluate import tree_digest

    systems, canonical = {}, {}
    first: dict[tuple, int | None] = {}          # (file, digest) -> the seed that grew it first
    for path, seed in sorted({(t.file, t.seed) for t in trees if t.seed is not None},
                             key=lambda s: (str(s[0]), s[1])):
        if path not in systems:
            systems[path] = read_lsys(str(path))
            if systems[path].stochastic:
                first[(path, tree_digest(build(systems[path]).tree))] = None
        system = systems[path]
        if not system.stochastic or seed == system.seed:
            canonical[(path, seed)] = None
            continue
        with seed_named((path, seed)):
            digest = tree_digest(build(system.grown_from(seed)).tree)
        canonical[(path, seed)] = first.setdefault((path, digest), seed)   # (seeds ascend)
    return [t if t.seed is None or canonical[(t.file, t.seed)] == t.seed
            else replace(t, seed=canonical[(t.file, t.seed)]) for t in trees]


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: vertical field of view (deg), image height (px), and its position
    and target (m), fixed or keyed in time.

    position, target : (3,) the first key's (what a fixed camera has)
    key_t            : (K,) s, increasing; key_position, key_target (K, 3); K = 1 when fixed.
    Between keys both are interpolated linearly, before the first and after the last held.
    """

    position: np.ndarray
    target: np.ndarray
    fov_deg: float
    height_px: int
    key_t: np.ndarray | None = None
    key_position: np.ndarray | None = None
    key_target: np.ndarray | None = None

    @property
    def moving(self) -> bool:
        return self.key_t is not None and len(self.key_t) > 1

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position and target (T, 3) m at times ``t`` (T,) s."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        if not self.moving:
            return (np.broadcast_to(self.position, (len(t), 3)),
                    np.broadcast_to(self.target, (len(t), 3)))
        pos = np.stack([np.interp(t, self.key_t, self.key_position[:, i]) for i in range(3)], 1)
        tgt = np.stack([np.interp(t, self.key_t, self.key_target[:, i]) for i in range(3)], 1)
        return pos, tgt

    def pixels_per_metre(self, distance: np.ndarray) -> np.ndarray:
        """model.md 7: p = e H / (2 d tan(fov / 2)), per metre of e, at distance d (m)."""
        d = np.asarray(distance, dtype=np.float64)
        with np.errstate(divide="ignore"):
            return self.height_px / (2.0 * d * math.tan(math.radians(self.fov_deg) / 2.0))


@dataclass(frozen=True)
class Wind:
    speed: float
    direction: float
    gust_strength: float
    gust_seed: int
    front_speed: float


@dataclass(frozen=True)
class Scene:
    source: str
    trees: list[Placed]
    wind: Wind
    camera: Camera
    budget_px: float
    dt: float
    duration: float
    damping_ratio: float = 0.0      # ζ of every tree (model.md 4); levels fitted under it

    @property
    def steps(self) -> int:
        return int(round(self.duration / self.dt))


_ANY = object()
SHOWN_CHARS = 80      # a value quoted in a message is cut to this many characters


def _shown(value) -> str:
    """``repr(value)`` for a message, cut to SHOWN_CHARS (a seed of 4,000 digits)."""
    return shown(repr(value), SHOWN_CHARS)



# a table header on a line of its own: [wind], [[tree]], [[camera.key]], [ "scatter" ] (an
# element of an array over several lines, [1, 2], has a comma or a digit-only name)
_HEADER = re.compile(r"""(?m)^[ \t]*\[\[?[ \t]*([A-Za-z0-9_\-"'. \t]*[A-Za-z_\-"'][A-Za-z0-9_\-"'. \t]*?)[ \t]*\]\]?[ \t]*(?:#.*)?\r?$""")


def _table_spans(text: str) -> list[tuple[str, int, int]]:
    """(name, start, end) of every table header's section in ``text``, in order: from the
    header to the next header (or the end); names with spaces and quotes dropped
    ("camera.key")."""
    heads = [(re.sub(r"""[\s"']""", "", m.group(1)), m.start()) for m in _HEADER.finditer(text)]
    ends = [start for _, start in heads[1:]] + [len(text)]
    return [(name, start, end) for (name, start), end in zip(heads, ends)]


def _line_of(text: str, key: str, value=_ANY, span: tuple[int, int] | None = None) -> int | None:
    """The line of ``key = …`` in ``text``: of the first one whose value reads as ``value``
    where given (a key that several tables set: `[[tree]]`'s scale, a camera key's position),
    else of the first one; within ``span`` (start, end), the section of the table being read,
    only (None where it does not hold the key)."""
    found = _key_match(text, key, value, span)
    if found is None and span is None:           # a table of that name: [wind.extra]
        table = re.search(rf"(?m)^[ \t]*\[\[?[^\]\n]*\b{re.escape(key)}[ \t]*\]", text)
        return text.count("\n", 0, table.start()) + 1 if table else None
    return None if found is None else text.count("\n", 0, found.start()) + 1


def _loose_line(text: str, key: str, span: tuple[int, int] | None, value=_ANY) -> int | None:
    """The line of a ``key =`` anywhere on a line (an inline table's, a dotted key's last
    part, a quoted key), not in a comment, within ``span`` where given: the first whose value
    reads as ``value`` where one does, else the first; None where there is none."""
    pattern = re.compile(rf"""(?<![\w-])["']?{re.escape(key)}["']?[ \t]*=[ \t]*([^,}}\]\n#]*)""")
    found = [m for m in (pattern.finditer(text, *span) if span is not None
                         else pattern.finditer(text))
             if "#" not in text[text.rfind("\n", 0, m.start()) + 1:m.start()]]
    if not found:
        return _quoted_line(text, key, span)
    chosen = found[0]
    if value is not _ANY:
        for m in found:
            try:
                if tomllib.loads(f"v = {m.group(1).strip()}")["v"] == value:
                    chosen = m
                    break
            except (tomllib.TOMLDecodeError, RecursionError, ValueError):
                continue
    return text.count("\n", 0, chosen.start()) + 1


_QUOTED_KEY = re.compile(r"""(?m)^[ \t]*("(?:[^"\\\n]|\\.)*"|'[^'\n]*')[ \t]*=""")


def _quoted_line(text: str, key: str, span: tuple[int, int] | None) -> int | None:
    """The line of a quoted key that reads as ``key`` only once its escapes are read
    (``"x\\u0001y" = 3``: the key holds a control character), within ``span`` where given;
    None where there is none."""
    for m in (_QUOTED_KEY.finditer(text, *span) if span is not None
              else _QUOTED_KEY.finditer(text)):
        try:
            if key in tomllib.loads(f"{m.group(1)} = 0"):
                return text.count("\n", 0, m.start()) + 1
        except (tomllib.TOMLDecodeError, RecursionError, ValueError):
            continue
    return None


def _key_match(text: str, key: str, value=_ANY, span: tuple[int, int] | None = None):
    """The match of ``key = …`` that `_line_of` names (group 1: the text after ``=`` on its
    line), None where there is none."""
    # ([ \t]*, not \s*: a blank line before the key is not its line; `key.sub = …` is a
    # dotted key's line)
    pattern = re.compile(rf"(?m)^[ \t]*{re.escape(key)}[ \t]*(?:=|\.[^=\n]*=)(.*)$")
    found = list(pattern.finditer(text, *span) if span is not None else pattern.finditer(text))
    if not found:
        return None
    chosen = found[0]
    if value is not _ANY:
        unread = False
        for m in found:
            try:
                if tomllib.loads(f"v ={m.group(1)}")["v"] == value:
                    return m
            except (tomllib.TOMLDecodeError, RecursionError, ValueError):  # (an array over
                unread = True             # several lines; an integer past Python's digit limit)
        if not unread:                    # every one read, none holds it: an inline table's
            return None                   # (`tree = [{seed = -1}]`), found by `_loose_line`
    return chosen


def _element_offset(text: str, start: int, index: int) -> int | None:
    """The offset in ``text`` of element ``index`` of the TOML array whose value begins at
    ``start`` (after its key's ``=``), found by a scan that skips strings and comments and
    counts commas at the array's own depth; None where the value is no array or has fewer
    elements."""
    k = start
    while k < len(text) and text[k] in " \t":
        k += 1
    if k >= len(text) or text[k] != "[":
        return None
    depth, element, expect = 1, 0, True
    for k, c in _significant(text, k + 1):
        if c in " \t\r\n":
            continue
        if depth == 1 and expect and c not in ",]":
            if element == index:
                return k
            expect = False
        if c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
            if depth == 0:
                return None
        elif c == "," and depth == 1:
            element, expect = element + 1, True
    return None


def _line_col(text: str, offset: int) -> tuple[int, int]:
    """The line and column (both from 1) of ``offset`` in ``text``."""
    return text.count("\n", 0, offset) + 1, offset - text.rfind("\n", 0, offset)


def _significant(text: str, k: int = 0) -> Iterator[tuple[int, str]]:
    """(offset, character) of ``text`` from ``k`` on, comments left out (their line end is
    kept) and each string given by its opening quote alone."""
    while k < len(text):
        c = text[k]
        if c == "#":                                   # a comment runs to the line's end
            k = text.find("\n", k)
            if k < 0:
                return
            continue
        yield k, c
        k = _past_string(text, k) if c in "\"'" else k + 1


def _past_string(text: str, k: int) -> int:
    """The offset just past the TOML string that opens at ``text[k]`` (a quote: basic or
    literal, single-line or triple)."""
    quote = text[k:k + 3] if text[k:k + 3] in ('"""', "'''") else text[k]
    k += len(quote)
    while k < len(text) and not text.startswith(quote, k):
        k += 2 if quote[0] == '"' and text[k] == "\\" else 1
    return k + len(quote)


def _too_deep(text: str, limit: int = MAX_SCENE_NESTING) -> int | None:
    """The offset of the first ``[`` or ``{`` of a value that opens more than ``limit`` arrays
    and inline tables at once (strings, comments and table headers skipped), None where
    none does: where tomllib ran out of stack, the place to name."""
    depth, line_start, header = 0, True, False
    for k, c in _significant(text):
        if c == "\n":
            line_start, header = True, False
            continue
        if header or c in " \t\r":
            continue
        if c == "[" and depth == 0 and line_start:         # a [table] or [[array]] header
            header = True
            continue
        line_start = False
        if c in "[{":
            depth += 1
            if depth > limit:
                return k
        elif c in "]}":
            depth = max(depth - 1, 0)
    return None


class _Reader:
    def __init__(self, text: str, source: str):
        self.text, self.source = text, source
        self.tables = _table_spans(text)
        # each name's sections in file order, found once: `table` looked them up by a scan of
        # every section per call, quadratic in [[tree]] entries (12 s at 10,000; a fuzzing round)
        self.sections: dict[str, list[tuple[int, int]]] = {}
        for n, start, end in self.tables:
            self.sections.setdefault(n, []).append((start, end))
        # the keys before the first header (`tree = [...]`, `camera.key = [...]`)
        self.top = (0, self.tables[0][1] if self.tables else len(text))
        # the section being read: the top, until `table` says
        self.span: tuple[int, int] | None = self.top
        self.name = ""
        self.index = 0

    @contextlib.contextmanager
    def table(self, name: str, index: int = 0):
        """Errors inside name the lines of the ``index``-th ``[name]`` / ``[[name]]`` section
        (a key several tables set, each its own; a missing key at the header's line); where
        the file has no such header (an inline table), the first line that sets the key."""
        sections = self.sections.get(name, [])
        outer = self.span, self.name, self.index
        self.span, self.name = sections[index] if index < len(sections) else None, name
        self.index = index
        try:
            yield
        finally:
            self.span, self.name, self.index = outer

    def _inline_place(self) -> tuple[int, int] | None:
        """(line, column) of the table being read where the file writes it inline, as
        element ``index`` of an array (`tree = [{…}, {}]`) or as a key's value
        (`scatter = {…}`): the table ``a.b`` is the key ``b`` in ``[a]``, or ``a.b`` at the top."""
        if self.span is not None or not self.name:
            return None
        *outer, key = self.name.split(".")
        places = [(key, (start, end)) for n, start, end in self.tables
                  if outer and n == ".".join(outer)] + [(self.name, self.top)]
        found = next((m for k, span in places
                      if (m := _key_match(self.text, k, _ANY, span)) is not None), None)
        if found is None:
            return None
        offset = _element_offset(self.text, found.start(1), self.index)
        return _line_col(self.text, found.start() if offset is None else offset)

    def error(self, message: str, key: str | None = None, value=_ANY) -> InputError:
        """InputError at the line of ``key`` (the one holding ``value`` where given) in the
        section being read; where that section has no such key (a missing key, or a message
        without one), at its header; before any header, or in a table written inline, at the
        key's first line anywhere."""
        line = _line_of(self.text, key, value, self.span) if key and self.span else None
        header = self.span is not None and self.name != ""   # (a table's, even at offset 0)
        if line is None and header:              # a sub-table of that name: [wind.extra]
            line = next((self.text.count("\n", 0, start) + 1 for n, start, _ in self.tables
                         if n == f"{self.name}.{key}"), None)
        if line is None and key and not header:
            line = _line_of(self.text, key, value)
        if line is None and key:                 # inline, dotted or quoted: `wind = {speed = -5}`,
            line = _loose_line(self.text, key, self.span if header else None, value)  # `"scale"`
        if line is None and header:
            line = self.text.count("\n", 0, self.span[0]) + 1
        if line is None:                         # a missing key of a table written inline
            place = self._inline_place()
            if place is not None:
                return InputError(message, self.source, *place)
        return InputError(message, self.source, line, 1 if line else None)

    def element_error(self, message: str, key: str, index: int) -> InputError:
        """InputError at the line and column of element ``index`` of the array ``key`` in the
        section being read (an array over several lines: the element's own line); where it
        cannot be found, as `error` names the key."""
        found = _key_match(self.text, key, _ANY, self.span)
        offset = _element_offset(self.text, found.start(1), index) if found is not None else None
        if offset is None:
            return self.error(message, key)
        return InputError(message, self.source, *_line_col(self.text, offset))

    def keys(self, table: dict, allowed: set[str], where: str) -> None:
        for key in table:
            if key not in allowed:
                raise self.error(f"unknown key '{key}' in {where}"
                                 f"{did_you_mean(str(key), allowed)}; expected one of "
                                 f"{', '.join(sorted(allowed))}", key)

    def number(self, table: dict, key: str, default=None, *, low=None, low_open=False,
               integer=False, high=None) -> float:
        if key not in table:
            if default is None:
                raise self.error(f"missing '{key}'", None)
            return default
        value = table[key]
        ok = isinstance(value, int) if integer else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok or not finite(value):
            kind = "a whole number" if integer else "a finite number"
            raise self.error(f"'{key}' must be {kind}, got {_shown(value)}", key, value)
        if low is not None and (value <= low if low_open else value < low):
            raise self.error(f"'{key}' must be {'>' if low_open else '>='} {low:g}, got {_shown(value)}",
                             key, value)
        if high is not None and value > high:
            raise self.error(f"'{key}' must be <= {high:g}, got {_shown(value)}", key, value)
        # a float where one is asked for: a whole number past 2^64 would reach numpy as an
        # object (a camera key's t of 1e23 written as digits, a fuzzer's find, session 42)
        return value if integer else float(value)

    def vector(self, table: dict, key: str, size: int, default=None) -> tuple[float, ...]:
        if key not in table:
            if default is None:
                raise self.error(f"missing '{key}' ({size} numbers)", None)
            return default
        value = table[key]
        if (not isinstance(value, list) or len(value) != size
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                           and finite(v) for v in value)):
            raise self.error(f"'{key}' must be a list of {size} finite numbers, got {_shown(value)}",
                             key, value)
        if any(abs(v) > MAX_SCENE_COORDINATE_M for v in value):     # (every vector is metres)
            raise self.error(f"'{key}' must lie within {MAX_SCENE_COORDINATE_M:.0e} m of the "
                             f"origin in each coordinate, got {_shown(value)}", key, value)
        return tuple(float(v) for v in value)

    def seed(self, table: dict, key: str, element: int | None = None) -> int:
        """A seed: a whole number >= 0, of any size TOML reads (an .lsys file's ``seed:`` takes
        any; no float range applies, as the seed is only ever hashed); ``element``: the index
        of ``table[key]`` in the array ``key`` of the file, where errors are placed."""
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            message = f"'{key}' must be a whole number >= 0, got {_shown(value)}"
            raise (self.error(message, key, value) if element is None
                   else self.element_error(message, key, element))
        return value

    def file(self, name, key: str, folder: pathlib.Path, element: int | None = None) -> pathlib.Path:
        """The .lsys file ``name`` (the value of ``key``, or its element ``element``) found
        relative to ``folder``."""
        def error(message: str) -> InputError:
            return (self.error(message, key, name) if element is None
                    else self.element_error(message, key, element))

        if name is None:
            raise self.error(f"missing '{key}' (the tree's .lsys file)", None)
        if not isinstance(name, str) or not name or "\0" in name:
            raise error(f"'{key}' must name an .lsys file, got {_shown(name)}")
        try:
            path = (folder / name).resolve()
            found = path.is_file()
        except (OSError, RuntimeError) as exc:   # a name too long, a loop of links (RuntimeError
                                                 # from Path.resolve on Python 3.11)
            raise error(f"tree file {name[:80]!r}{'…' if len(name) > 80 else ''}: "
                        f"{getattr(exc, 'strerror', None) or exc}") from None
        if not found:
            if path.is_dir():
                raise error(f"tree file {name!r} is a folder (in {folder}); expected an .lsys "
                            "file")
            if path.exists():                    # /dev/null, a FIFO, a socket
                raise error(f"tree file {name!r} is not a regular file; expected an .lsys file")
            raise error(f"tree file {name!r} not found"
                        + ("" if pathlib.Path(name).is_absolute() else f" (looked in {folder})"))
        if not os.access(path, os.R_OK):          # (at the scene's line: its reader named it
                                                 # alone, by its absolute path)
            raise error(f"tree file {name!r} cannot be read: permission denied")
        other = _other_kind_of(path)
        if other is not None:
            raise error(f"tree file {name!r} is {other}; expected an .lsys file")
        return path


def _other_kind_of(path: pathlib.Path) -> str | None:
    """What the file at ``path`` is, by its start (`formats.kinds`), where that is another
    kind than an L-system (an angle CSV, a tree file, a glTF, a scene, ...); None where it
    looks like one, shows no kind, or cannot be read (its reader says why, later). So a
    scene's `file = "run.csv"` is named at the scene's line, not in the CSV. Looked at once
    per file and version (a scatter's files are named by every tree they grow)."""
    try:
        stat = path.stat()
    except OSError:
        return None
    return _sniffed_kind(path, stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=64)
def _sniffed_kind(path: pathlib.Path, _mtime_ns: int, _size: int) -> str | None:
    from plantlod.formats.kinds import SNIFF_CHARS, other_kind_of_text
    from plantlod.formats.text_input import binary_kind

    try:
        with open(path, "rb") as f:
            start = f.read(SNIFF_CHARS)
    except OSError:
        return None
    binary = binary_kind(start)
    if binary is not None:
        return binary[0]
    other = other_kind_of_text(start.decode("utf-8", errors="replace"), "lsys")
    return None if other is None else f"{other[0]} ({other[1]})"


# the scene's lists of tables, each entry a [[name]] header (docs/scene.md)
LISTED_TABLES = ("tree", "camera.key")


# what tomllib's commonest complaints mean in a scene, said as what was expected
TOML_HINTS = {
    "Unclosed array": "an array opened with [ earlier is not closed; expected its ]",
    "Unclosed inline table": "an inline table opened with { is not closed on its line; "
                             "expected its }",
    "Illegal character '\\n'": "a string runs to the end of its line; expected its closing "
                                "quote on the same line",
    "Expected '=' after a key in a key/value pair": "expected key = value; a key without quotes "
                                                    "holds only A-Z a-z 0-9 _ -",
    "Invalid value": "expected a value after = (a number, \"text\", true, [..] or {..})",
    "Expected newline or end of document after a statement": "expected one key = value per "
                                                             "line",
}


def _toml_hint(complaint: str, text: str, line: int, col: int, message: str
               ) -> tuple[str, int]:
    """(message, column) for tomllib's ``complaint`` at ``line``:``col`` of ``text``: a key
    given twice is named with the line it was first given on (tomllib said "Cannot overwrite a
    value" at the end of the second); the commonest other complaints get what was expected
    (`TOML_HINTS`). Anything else keeps ``message``."""
    lines = text.splitlines()
    key = lines[line - 1].split("=", 1)[0].strip() if line <= len(lines) else ""
    if complaint == "Cannot overwrite a value" and key and not key.startswith("["):
        first = None
        for k in range(line - 2, -1, -1):      # back to the table's header
            if lines[k].lstrip().startswith("["):
                break
            if "=" in lines[k] and lines[k].split("=", 1)[0].strip() == key:
                first = k + 1
                break
        before = "" if first is None else f" (first on line {first})"
        return (f"the key '{key}' is given twice in its table{before}; expected it once",
                lines[line - 1].find(key) + 1)
    hint = TOML_HINTS.get(complaint)
    return (message if hint is None else f"{message}: {hint}"), col


def read_scene(path: str) -> Scene:
    """Read and check a scene file (see the module doc); trees resolved relative to it."""
    from plantlod.formats.kinds import other_kind
    from plantlod.formats.text_input import read_text, refuse_empty, source_name

    file = pathlib.Path(path)
    text = read_text(path, expected="a scene file, TOML")   # missing, unreadable, not UTF-8,
    # a line too long: exit 2
    shown_as = source_name(path)      # (stdin was named "-" where other readers say <stdin>)
    refuse_empty(text, shown_as, "a scene (docs/scene.md)")   # ("missing [camera]" before)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        other = other_kind(text, shown_as, "scene")    # an L-system or angle CSV given for a scene
        if other is not None:
            raise other from None
        m = re.search(r"line (\d+), column (\d+)", str(exc))
        line, col = (int(m.group(1)), int(m.group(2))) if m else (None, None)
        if m is None and "(at end of document)" in str(exc):
            # an unclosed string, array or table runs to the end: say where the text ends
            line, col = _line_col(text, len(text.rstrip("\r\n")) if text.strip() else 0)
        message = f"not valid TOML: {str(exc).split(' (at')[0]}"
        twice = re.match(r"Cannot declare \(([^)]*)\) twice", str(exc))
        if twice and line is not None:
            # `[tree]` where `[[tree]]` was meant: each entry of a list is a [[..]] header
            name = ".".join(re.findall(r"'([^']*)'", twice.group(1)))
            lines = text.splitlines()
            header = lines[line - 1] if line <= len(lines) else ""
            col = header.find("[") + 1 if "[" in header else col
            message = (f"the table [{name}] is declared twice; "
                       + (f"several of them are written [[{name}]] each (double brackets)"
                          if name in LISTED_TABLES else "expected it once"))
        if twice is None and line is not None:
            message, col = _toml_hint(str(exc).split(" (at")[0], text, line, col, message)
        raise InputError(message, shown_as, line, col) from None
    except RecursionError:              # arrays or tables nested thousands deep
        at = _too_deep(text)
        raise InputError(f"not valid here: TOML nested too deeply for a scene (more than "
                         f"{MAX_SCENE_NESTING} arrays or inline tables inside each other)",
                         shown_as, *((None, None) if at is None else _line_col(text, at))) from None
    except ValueError:                  # an integer past Python's digit limit (tomllib's int())
        raise _long_integer(text, shown_as) from None
    r = _Reader(text, shown_as)
    r.keys(data, TOP_KEYS, "the scene")
    folder = file.resolve().parent
    dt = r.number(data, "dt", 0.01, low=0, low_open=True)
    duration = r.number(data, "duration", 10.0, low=0, low_open=True)
    steps = duration / dt
    if not steps <= MAX_SCENE_STEPS:                 # NaN and infinity included
        count = f"{steps:,.3g}" if math.isfinite(steps) else "more than 1e308"
        raise r.error(f"duration {duration:g} s at dt = {dt:g} s is {count} steps, more than "
                      f"the limit of {MAX_SCENE_STEPS:,}; expected a shorter scene or a larger dt",
                      "duration" if "duration" in data else "dt")
    if steps < 2 * SIMPLIFY_EVERY:                   # (the levels' motion fit reads periods)
        raise r.error(f"duration {duration:g} s at dt = {dt:g} s is fewer than "
                      f"{2 * SIMPLIFY_EVERY} steps, too short to fit levels in; expected a "
                      "longer scene or a smaller dt", "duration" if "duration" in data else "dt")
    damping_ratio = r.number(data, "damping_ratio", 0.0, low=0, high=MAX_DAMPING_RATIO)
    if data.get("budget_px") == 0 and not isinstance(data.get("budget_px"), bool):
        raise r.error("'budget_px' is 0: no level but the full tree shows no error; expected a "
                      "positive pixel budget", "budget_px")
    budget = r.number(data, "budget_px", 1.0, low=0, low_open=True)   # (-1: "must be > 0")

    wind_t = data.get("wind", {})
    if not isinstance(wind_t, dict):
        raise r.error("[wind] must be a table", "wind")
    with r.table("wind"):
        r.keys(wind_t, WIND_KEYS, "[wind]")
        wind = Wind(r.number(wind_t, "speed", 0.0, low=0, high=MAX_WIND_SPEED),
                    r.number(wind_t, "direction", 0.0),
                    r.number(wind_t, "gust_strength", 0.0, low=0),
                    int(r.number(wind_t, "gust_seed", 0, low=0, integer=True)),
                    r.number(wind_t, "front_speed", 0.0, low=0))
        if "gust_seed" in wind_t and wind.gust_strength == 0:     # (as simulate refuses it)
            raise r.error("'gust_seed' applies to gusts; give gust_strength > 0 too (or drop "
                          "gust_seed)", "gust_seed")
        peak = wind.speed * gust_peak_factor(wind.gust_strength)
        if peak > MAX_WIND_SPEED:      # the levels are fitted at the strongest gust (scene.run)
            raise r.error(f"'gust_strength' {wind.gust_strength:g} lets a {wind.speed:g} m/s wind "
                          f"gust to {peak:.4g} m/s, over the largest wind speed "
                          f"{MAX_WIND_SPEED:g} m/s; expected a weaker gust_strength or speed",
                          "gust_strength")

    cam_t = data.get("camera")
    if not isinstance(cam_t, dict):
        said = ("missing [camera]" if cam_t is None else
                "[camera] must be a table")   # (camera = "front" said "missing")
        raise r.error(f"{said}: expected position and target (or [[camera.key]] "
                      "entries), and optionally fov_deg (default 60) and height_px (default "
                      "1080)", "camera")
    with r.table("camera"):
        r.keys(cam_t, CAMERA_KEYS, "[camera]")
        camera = _camera(r, cam_t)

    trees: list[Placed] = []
    entries = data.get("tree", [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise r.error("trees are [[tree]] entries", "tree")
    if len(entries) > MAX_TREES:
        raise r.error(f"{len(entries):,} trees is more than the limit of {MAX_TREES:,}", "tree")
    for index, entry in enumerate(entries):
        with r.table("tree", index):
            r.keys(entry, TREE_KEYS, "[[tree]]")
            trees.append(Placed(r.file(entry.get("file"), "file", folder),
                                r.vector(entry, "position", 3, (0.0, 0.0, 0.0)),
                                r.number(entry, "heading", 0.0),
                                r.number(entry, "scale", 1.0, low=0, low_open=True,
                                         high=MAX_TREE_SCALE),
                                r.seed(entry, "seed") if "seed" in entry else None))
    if "scatter" in data:
        with r.table("scatter"):
            trees += _scatter(r, data["scatter"], folder, MAX_TREES - len(trees))
    if not trees:
        raise r.error("the scene has no trees; expected [[tree]] entries or a [scatter] block", None)
    if len(trees) > MAX_TREES:
        raise r.error(f"{len(trees):,} trees is more than the limit of {MAX_TREES:,}", None)
    asked = len({t.source for t in trees})
    if asked > MAX_SCENE_CHAINS:          # (each is a chain to fit, about 10-20 s a tree file)
        raise r.error(f"the scene's trees come from {asked:,} distinct (file, seed) pairs, more "
                      f"than the limit of {MAX_SCENE_CHAINS:,} level chains; expected fewer "
                      "seeds", "tree_seeds" if "tree_seeds" in text else "seed")
    return Scene(shown_as, shared_seeds(trees), wind, camera, budget, dt, duration, damping_ratio)


def _long_integer(text: str, path: str) -> InputError:
    """The error for an integer of more digits than Python converts
    (`sys.get_int_max_str_digits`), at its line and column, worded as the .lsys reader's."""
    import sys

    limit = sys.get_int_max_str_digits()
    for m in re.finditer(r"[0-9][0-9_]*", text):
        digits = m.group(0).replace("_", "").lstrip("0")
        before = text[text.rfind("\n", 0, m.start()) + 1:m.start()]
        if "#" in before or before.count('"') % 2 or before.count("'") % 2:
            continue                      # (in a comment or a string: not a number)
        if limit and len(digits) > limit:
            return InputError(f"a whole number of {len(digits)} digits; expected at most {limit}",
                              path, *_line_col(text, m.start()))
    return InputError("not valid TOML: a number Python cannot read", path)


def _camera(r: _Reader, cam_t: dict) -> Camera:
    """[camera]: a fixed position and target, or [[camera.key]] entries (t, position, target)."""
    fov = r.number(cam_t, "fov_deg", 60.0, low=0, low_open=True)
    if fov >= 180:
        raise r.error(f"'fov_deg' must be below 180, got {fov:g}", "fov_deg")
    height = int(r.number(cam_t, "height_px", 1080, low=1, integer=True))
    keys = cam_t.get("key")
    if keys is None:
        pos, tgt = np.array(r.vector(cam_t, "position", 3)), np.array(r.vector(cam_t, "target", 3))
        if np.array_equal(pos, tgt):      # (allclose refused a target 30 m off at 4.6e6 m)
            raise r.error("the camera's target is its position; expected a direction to look in",
                          "target")
        return Camera(pos, tgt, fov, height)
    if not isinstance(keys, list) or not keys or not all(isinstance(k, dict) for k in keys):
        raise r.error("camera keys are [[camera.key]] tables (t, position, target)", "key")
    if "position" in cam_t or "target" in cam_t:
        raise r.error("[camera] has both position/target and [[camera.key]] entries; expected "
                      "one or the other", "position" if "position" in cam_t else "target")
    times, positions, targets = [], [], []
    for index, key in enumerate(keys):
        with r.table("camera.key", index):
            r.keys(key, CAMERA_KEY_KEYS, "[[camera.key]]")
            times.append(r.number(key, "t", low=0))
            positions.append(r.vector(key, "position", 3))
            targets.append(r.vector(key, "target", 3))
            if positions[-1] == targets[-1]:
                raise r.error(f"the camera key at t = {times[-1]:g} s looks at its own position",
                              "target")
    for index, (a, b) in enumerate(zip(times, times[1:])):
        if b <= a:
            with r.table("camera.key", index + 1):
                raise r.error("camera keys must have increasing times 't'", "t")
    kt, kp, ktg = np.array(times), np.array(positions), np.array(targets)
    # (between two keys position and target move linearly, and may pass through each other,
    # as a camera flipping round does: at that instant it looks nowhere and no tree is ahead)
    return Camera(kp[0], ktg[0], fov, height, kt, kp, ktg)


def _scatter(r: _Reader, table, folder: pathlib.Path, room: int) -> list[Placed]:
    """N trees drawn from ``files`` over a rectangle, at least ``min_spacing`` apart, from ``seed``;
    N beyond ``room`` (what MAX_TREES leaves after the [[tree]] entries) is refused before drawing."""
    if not isinstance(table, dict):
        raise r.error("[scatter] must be a table", "scatter")
    r.keys(table, SCATTER_KEYS, "[scatter]")
    names = table.get("files")
    if not isinstance(names, list) or not names:
        raise r.error("'files' must be a non-empty list of .lsys files", "files")
    files = [r.file(n, "files", folder, element=k) for k, n in enumerate(names)]
    count = int(r.number(table, "count", None, low=1, integer=True))
    if count > room:
        # (the total: 1 [[tree]] and count 100,000 read "100,000 makes more than 100,000")
        raise r.error(f"[scatter] count {count:,} and the {MAX_TREES - room:,} [[tree]] "
                      f"entries make {count + MAX_TREES - room:,} trees, more than the limit of "
                      f"{MAX_TREES:,}; expected a count of at most {room:,}", "count")
    seed = int(r.number(table, "seed", 0, low=0, integer=True))
    tree_seeds = _tree_seeds(r, table)
    x0, y0, x1, y1 = r.vector(table, "area", 4)
    if not (x1 > x0 and y1 > y0 and math.isfinite(x1 - x0) and math.isfinite(y1 - y0)):
        raise r.error("'area' is [x0, y0, x1, y1] with x1 > x0 and y1 > y0 (and sides that are "
                      "finite numbers)", "area")
    spacing = r.number(table, "min_spacing", 0.0, low=0)
    scale = r.number(table, "scale", 1.0, low=0, low_open=True, high=MAX_TREE_SCALE)
    if spacing > 0:
        # points at least s apart in a w x h rectangle: disks of radius s/2 in the rectangle
        # grown by s/2 a side, packed at most hexagonally (density pi / (2 sqrt 3))
        most = ((x1 - x0) / spacing + 1) * ((y1 - y0) / spacing + 1) / (math.sqrt(3) / 2)
        if count > most:
            raise r.error(f"cannot place {count:,} trees {spacing:g} m apart in the area: at most "
                          f"{int(most):,} fit; expected a larger area or a smaller spacing",
                          "min_spacing")
    rng = np.random.default_rng(seed)
    points: list[tuple[float, float]] = []
    # the spacing grid: cells at least the spacing (neighbours are then in the 3 x 3 cells
    # around), and at most MAX_SCATTER_CELLS a side, so cell numbers stay integers however
    # small the spacing against the area (1e-300 m across 1e300 m overflowed int())
    cell = max(spacing, max(x1 - x0, y1 - y0) / MAX_SCATTER_CELLS)
    grid: dict[tuple[int, int], list[int]] = {}
    tries = 0
    while len(points) < count:
        tries += 1
        if tries > MAX_SCATTER_TRIES * count:
            raise r.error(f"cannot place {count:,} trees {spacing:g} m apart in the area "
                          f"(placed {len(points):,}); expected a larger area or a smaller spacing",
                          "min_spacing")
        x, y = float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1))
        if spacing == 0:                             # nothing to keep apart
            points.append((x, y))
            continue
        gx, gy = int((x - x0) // cell), int((y - y0) // cell)
        near = [j for dx in (-1, 0, 1) for dy in (-1, 0, 1) for j in grid.get((gx + dx, gy + dy), [])]
        if any(math.hypot(points[j][0] - x, points[j][1] - y) < spacing
                               for j in near):
            continue
        grid.setdefault((gx, gy), []).append(len(points))
        points.append((x, y))
    picks = rng.integers(0, len(files), size=count)
    headings = rng.uniform(0.0, 360.0, size=count)
    # drawn last, so that giving tree_seeds moves no tree and changes no file or heading
    grown = ([tree_seeds[int(k)] for k in rng.integers(0, len(tree_seeds), size=count)]
             if tree_seeds else [None] * count)
    return [Placed(files[int(k)], (x, y, 0.0), float(h), scale, g)
            for (x, y), k, h, g in zip(points, picks, headings, grown)]


def _tree_seeds(r: _Reader, table: dict) -> list[int] | None:
    """[scatter] tree_seeds: a non-empty list of seeds (whole numbers >= 0), each scattered
    tree grown from one of them drawn uniformly; None where not given (the files' own)."""
    if "tree_seeds" not in table:
        return None
    given = table["tree_seeds"]
    if not isinstance(given, list) or not given:
        raise r.error(f"'tree_seeds' must be a non-empty list of whole numbers >= 0, got "
                      f"{_shown(given)}", "tree_seeds", given)
    return [r.seed({"tree_seeds": v}, "tree_seeds", element=k) for k, v in enumerate(given)]
