"""The angle CSV written by `plantlod simulate` (docs/angles-csv.md).

Header ``t,b:ADDR0,r:ADDR0,b:ADDR1,r:ADDR1,...``: the time in seconds, then for
every branch, in branch order, its bend angle and its rotation angle. One row
per sample; every number is formatted with `CSV_FLOAT_FORMAT` ("%.10g"), -0 is
written as 0, lines end with "\\n". Angles are radians, or degrees when the
writer was asked for them (the file does not record which; the caller knows).
"""

from __future__ import annotations

import math
from typing import TextIO

import numpy as np

from .constants import CSV_BLOCK_VALUES, CSV_FLOAT_FORMAT
from plantlod.lsys.errors import InputError

BEND_PREFIX = "b:"
ROT_PREFIX = "r:"


def header_fields(addresses: list[str]) -> list[str]:
    """``["t", "b:A0", "r:A0", "b:A1", ...]`` for branch addresses A0, A1, ..."""
    out = ["t"]
    for a in addresses:
        out += [BEND_PREFIX + a, ROT_PREFIX + a]
    return out


class AnglesCsvWriter:
    """Write the angle CSV to a text stream, one chunk of samples at a time.

    The header is written when the writer is made. ``degrees=True`` converts
    the angles (not the times) from radians to degrees.
    """

    def __init__(self, stream: TextIO, addresses: list[str], degrees: bool = False):
        self.stream = stream
        self.n_branches = len(addresses)
        self.degrees = degrees
        self._row = ",".join([CSV_FLOAT_FORMAT] * (2 * self.n_branches + 1)) + "\n"
        stream.write(",".join(header_fields(list(addresses))) + "\n")

    def write(self, times: np.ndarray, bend: np.ndarray, rot: np.ndarray) -> None:
        """Write rows: times (m,) s; bend and rot (m, B) radians."""
        times = np.asarray(times, dtype=np.float64).reshape(-1)
        m, b = len(times), self.n_branches
        bend = np.asarray(bend, dtype=np.float64).reshape(m, b)
        rot = np.asarray(rot, dtype=np.float64).reshape(m, b)
        table = np.empty((m, 2 * b + 1))
        table[:, 0] = times
        with np.errstate(over="ignore"):
            table[:, 1::2] = np.degrees(bend) if self.degrees else bend
            table[:, 2::2] = np.degrees(rot) if self.degrees else rot
        if not np.isfinite(table).all():  # (the reader takes finite numbers only)
            raise InputError("angles that are not finite numbers in degrees (above about "
                             "3e305 rad, or not finite at all) cannot be written to an angle "
                             "CSV; expected finite angles" + (", in radians" if self.degrees
                                                              else ""))
        table += 0.0                      # -0.0 + 0.0 is +0.0: no "-0" in the file
        row = self._row
        self.stream.write("".join([row % tuple(r) for r in table.tolist()]))


def read_angles_csv(stream: TextIO, source: str | None = None, degrees: bool = False
                    ) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """Read an angle CSV: (times (m,), addresses [B], bend (m, B), rot (m, B)).

    ``degrees=True`` says the file holds degrees; they are returned in radians.
    Checks, each an `InputError` at (source, line, column): the header is
    ``t`` followed by ``b:ADDR,r:ADDR`` pairs (distinct, non-empty ADDR); every
    row has as many fields as the header, each a finite number; times strictly
    increase; there is at least one row. Blank lines are skipped.
    """
    lines = iter(enumerate(stream, start=1))
    header_line, header = _first_nonblank(lines)
    if header is None:
        raise InputError("expected a header line t,b:ADDR,r:ADDR,...; the file is empty",
                         source, max(header_line, 1), 1)
    fields = header.split(",")
    cols = _field_starts(fields)
    if fields[0] != "t":
        raise InputError(f"expected the header to start with 't', got {fields[0]!r}",
                         source, header_line, 1)
    if len(fields) % 2 != 1:
        raise InputError("expected a b:ADDR and an r:ADDR column for every branch "
                         f"after 't', got {len(fields) - 1} angle column(s)", source, header_line, 1)
    addresses: list[str] = []
    seen: set[str] = set()
    for j in range(1, len(fields), 2):
        bend_f, rot_f = fields[j], fields[j + 1]
        if not bend_f.startswith(BEND_PREFIX) or len(bend_f) == len(BEND_PREFIX):
            raise InputError(f"expected a column b:ADDR, got {bend_f!r}", source, header_line, cols[j])
        address = bend_f[len(BEND_PREFIX):]
        if rot_f != ROT_PREFIX + address:
            raise InputError(f"expected the column r:{address} after b:{address}, got {rot_f!r}",
                             source, header_line, cols[j + 1])
        if address in seen:
            raise InputError(f"branch address {address} appears twice in the header",
                             source, header_line, cols[j])
        seen.add(address)
        addresses.append(address)

    width = len(fields)
    # rows are gathered in blocks of numpy arrays: a list of Python floats takes about four
    # times the bytes of the text (a 313 MB CSV peaked at 4.7 GB in export)
    blocks: list[np.ndarray] = []
    rows: list[list[float]] = []
    last_t = -math.inf
    for line_no, raw in lines:
        line = raw.rstrip("\r\n")
        if not line.strip():
            continue
        parts = line.split(",")
        if len(parts) != width:
            raise InputError(f"expected {width} fields like the header, got {len(parts)}",
                             source, line_no, 1)
        try:
            # float() also reads "1_0" as 10 and "\u0661" (Arabic-Indic one) or "１" as 1
            values = None if "_" in line or not line.isascii() else [float(p) for p in parts]
        except ValueError:
            values = None
        if values is None or not all(map(math.isfinite, values)):
            _raise_bad_field(parts, source, line_no)
        if values[0] <= last_t:
            raise InputError(f"expected times to increase, got t={parts[0].strip()} after {last_t:.10g}",
                             source, line_no, 1)
        last_t = values[0]
        rows.append(values)
        if len(rows) * width >= CSV_BLOCK_VALUES:
            blocks.append(np.array(rows, dtype=np.float64))
            rows = []
    if not blocks and not rows:
        raise InputError("expected at least one row of angles after the header",
                         source, header_line + 1, 1)
    if rows:
        blocks.append(np.array(rows, dtype=np.float64))
    table = blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
    del blocks, rows
    bend, rot = table[:, 1::2].copy(), table[:, 2::2].copy()
    if degrees:
        bend, rot = np.radians(bend), np.radians(rot)
    return table[:, 0].copy(), addresses, bend, rot


def _first_nonblank(lines) -> tuple[int, str | None]:
    line_no = 0
    for line_no, raw in lines:
        line = raw.rstrip("\r\n")
        if line.strip():
            return line_no, line
    return line_no, None


def _field_starts(fields: list[str]) -> list[int]:
    """1-based column where each comma-separated field starts."""
    cols, pos = [], 1
    for f in fields:
        cols.append(pos)
        pos += len(f) + 1
    return cols


def _raise_bad_field(parts: list[str], source: str | None, line_no: int) -> None:
    for text, col in zip(parts, _field_starts(parts)):
        try:
            value = math.nan if "_" in text or not text.isascii() else float(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise InputError(f"expected a finite number, got {text.strip()!r}", source, line_no, col)


def read_angles_file(path: str, degrees: bool = False
                     ) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """The angles of ``path`` (``-``: stdin): an .npz archive (radians) or an angle CSV, as
    `read_angles_csv` returns them; ``degrees`` applies to a CSV only (InputError for an .npz)."""
    from .npz import is_npz, read_angles_bytes, read_npz_file
    from .constants import MAX_CSV_LINE_BYTES
    from .text_input import ANGLES_TEXT, read_text, source_name

    name = source_name(path)
    if is_npz(path):
        if degrees:
            raise InputError("--degrees applies to an angle CSV; an .npz archive holds radians",
                             name)
        return read_angles_bytes(read_npz_file(path), name)
    return read_angles_text(read_text(path, MAX_CSV_LINE_BYTES, expected=ANGLES_TEXT),
                            name, degrees)


def read_angles_text(text: str, source: str | None, degrees: bool = False
                     ) -> tuple[np.ndarray, list[str], np.ndarray, np.ndarray]:
    """`read_angles_csv` of a file's whole ``text``; a file of another kind (an L-system, a
    tree file) is named by what it is (`formats.kinds`)."""
    import io

    from .kinds import named_by_kind

    with named_by_kind(text, source, "csv"):
        return read_angles_csv(io.StringIO(text), source, degrees=degrees)
