"""Reading a text input file (or stdin) with errors that say where and what.

Every reader of user files goes through `read_text`, so a missing file, a
directory, or bytes that are not UTF-8 give the same one-line `InputError`
whichever command read them. A UTF-8 byte-order mark is accepted and dropped.
"""

from __future__ import annotations

import codecs
import contextlib
import re
import sys
from typing import BinaryIO, Iterator

from plantlod.lsys.errors import InputError

from .constants import MAX_LINE_BYTES, MAX_TEXT_BYTES, READ_CHUNK_BYTES, ZIP_MAGIC
from .kinds import USDC_MAGIC

_BOM = b"\xef\xbb\xbf"
_LINE_BREAK = re.compile(rb"\r\n?|\n")     # where a line ends (lsys.parse.LINE_BREAK, in bytes)
# Binary files a user may hand to a text reader: (magic, what it is, what to do instead).
BINARY_KINDS = (
    (ZIP_MAGIC, "a zip archive (an .npz?)", "archives are read by their .npz extension, so "
                                               "give the file a name ending in .npz"),
    (b"glTF", "a binary glTF (.glb)", "`plantlod view` reads those"),
    (USDC_MAGIC, "a binary OpenUSD file (.usdc)", "`plantlod export` writes those for other "
                                                 "programs; plantlod reads none"),
)


def binary_kind(data: bytes) -> tuple[str, str] | None:
    """(what it is, what to do instead) where ``data`` starts as a binary kind of
    BINARY_KINDS does, else None."""
    return next(((what, hint) for magic, what, hint in BINARY_KINDS if data.startswith(magic)),
                None)


def source_name(path: str) -> str:
    """How messages name an input: the path as given, stdin as ``<stdin>``."""
    return "<stdin>" if path == "-" else path


def refuse_empty(text: str, name: str, expected: str) -> None:
    """InputError at ``name``:1:1 where ``text`` holds nothing but white space, saying what was
    ``expected`` ("an L-system (docs/lsys-format.md)"); ``name`` as `source_name` gives it."""
    if not text.strip():
        where = "standard input is" if name == "<stdin>" else "the file is"
        raise InputError(f"{where} empty; expected {expected}", name, 1, 1)


LSYS_TEXT = "an .lsys file: simulate, compare and export also read tree archives"
ANGLES_TEXT = "an angle CSV"
ARCHIVE_READERS = (LSYS_TEXT, ANGLES_TEXT)   # the readers whose commands also take an .npz


def read_text(path: str, max_line_bytes: int = MAX_LINE_BYTES,
              max_bytes: int = MAX_TEXT_BYTES, expected: str = LSYS_TEXT) -> str:
    """The whole text of ``path`` (``-``: stdin), decoded as UTF-8; ``expected``: what the
    caller reads, for the message that an .npz archive is not that.

    Read in chunks, each checked as it comes: a line longer than ``max_line_bytes``, more
    than ``max_bytes`` in all, or a byte that is not UTF-8 stops the reading at once
    (`InputError` at file:line[:col]), so a hostile input (/dev/urandom, an endless pipe) is
    never held whole.
    """
    name = source_name(path)
    with reading(name):
        if path == "-":
            return _read_capped(stdin_bytes(name), name, max_line_bytes, max_bytes, expected)
        with open(path, "rb") as handle:
            return _read_capped(handle, name, max_line_bytes, max_bytes, expected)


def not_utf8(data: bytes, offset: int, name: str, expected: str = LSYS_TEXT) -> InputError:
    """The error for the byte at ``offset`` of ``data`` (the file's bytes up to and past it),
    located at its line and column (characters, a leading byte-order mark not counted)."""
    if data.startswith(ZIP_MAGIC) and name.lower().endswith(".npz"):
        return InputError("an .npz archive (a tree or angles), which is not read here; expected "
                          f"a text file ({expected})", name)
    binary = binary_kind(data)
    if binary is not None:          # (what it is, what reads it, and what this reader expected)
        what, hint = binary
        if data.startswith(ZIP_MAGIC) and expected not in ARCHIVE_READERS:
            hint = "this reader takes no archive"       # (a scene, a wind file: text only)
        return InputError(f"not text but {what}: {hint}; expected {expected}", name)
    bom = len(_BOM) if data.startswith(_BOM) else 0
    breaks = list(_LINE_BREAK.finditer(data, 0, offset))   # (\r\n, a lone \r or \n: as the
    line = len(breaks) + 1                                  # .lsys parser and text mode count)
    line_start = max(breaks[-1].end() if breaks else 0, bom)
    col = len(data[line_start:offset].decode("utf-8", errors="replace")) + 1
    return InputError(f"not UTF-8 text (byte {offset}), 0x{data[offset]:02x} cannot be "
                      "decoded; expected a UTF-8 file", name, line, col)


@contextlib.contextmanager
def reading(name: str) -> Iterator[None]:
    """An input that cannot be read is an `InputError` naming it (one message per cause,
    whichever reader opened it)."""
    try:
        yield
    except FileNotFoundError:
        raise InputError("no such file", name) from None
    except IsADirectoryError:
        raise InputError("is a directory, not a file", name) from None
    except PermissionError:
        raise InputError("permission denied", name) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", name) from None


def stdin_bytes(name: str = "<stdin>") -> BinaryIO:
    """Standard input as bytes; a closed one is an `InputError`."""
    if sys.stdin is None:
        raise InputError("standard input is closed; expected a file name or data on stdin", name)
    return sys.stdin.buffer


def _read_capped(handle: BinaryIO, name: str, max_line_bytes: int,
                 max_bytes: int = MAX_TEXT_BYTES, expected: str = LSYS_TEXT) -> str:
    """The text of ``handle``: its bytes decoded as UTF-8 (a leading byte-order mark
    dropped), refusing a line longer than ``max_line_bytes``, more than ``max_bytes`` in
    all, and the first byte that is not UTF-8, each as soon as its chunk is read.

    Chunks are no longer than the line cap, so only the line running across a chunk
    boundary (the run before a chunk's first newline plus the carry) can exceed it.
    """
    chunk_size = max(1, min(max_line_bytes, READ_CHUNK_BYTES))
    decoder = codecs.getincrementaldecoder("utf-8")()
    chunks: list[bytes] = []
    text: list[str] = []
    total = 0         # bytes read before this chunk
    run = 0           # bytes since the last newline
    lines = 0         # newlines read so far
    while chunk := handle.read(chunk_size):
        if total + len(chunk) > max_bytes:
            raise InputError(f"more than {max_bytes:,} bytes; expected a smaller file "
                             "(docs/errors.md, \"Limits\")", name)
        first = chunk.find(b"\n")
        if first < 0:
            run += len(chunk)
            end = total + len(chunk)          # (where the bytes counted in run end)
        else:
            run += first
            end = total + first
            if run <= max_line_bytes:
                run = len(chunk) - chunk.rfind(b"\n") - 1
        if run > max_line_bytes:              # (placed at the first character past the cap)
            data = b"".join(chunks) + chunk
            start = end - run
            start += len(_BOM) if start == 0 and data.startswith(_BOM) else 0
            within = data[start:start + max_line_bytes].decode("utf-8", errors="ignore")
            raise InputError(f"line longer than {max_line_bytes:,} bytes; expected shorter "
                             "lines (docs/errors.md, \"Limits\")", name, lines + 1,
                             len(within) + 1)
        lines += chunk.count(b"\n")
        chunks.append(chunk)
        fed = chunk[len(_BOM):] if total == 0 and chunk.startswith(_BOM) else chunk
        try:
            text.append(decoder.decode(fed))
        except UnicodeDecodeError as exc:   # exc.object: the decoder's carried bytes + fed
            raise not_utf8(b"".join(chunks), total + len(chunk) - len(exc.object) + exc.start,
                            name, expected) from None
        total += len(chunk)
    try:
        text.append(decoder.decode(b"", final=True))
    except UnicodeDecodeError as exc:       # a sequence cut short by the end of the file
        raise not_utf8(b"".join(chunks), total - len(exc.object) + exc.start, name,
                        expected) from None
    return "".join(text)
