"""Reading a text input file (or stdin) with errors that say where and what.

Every reader of user files goes through `read_text`, so a missing file, a
directory, or bytes that are not UTF-8 give the same one-line `InputError`
whichever command read them. A UTF-8 byte-order mark is accepted and dropped.
"""

from __future__ import annotations

import sys

from plantlod.lsys.errors import InputError

_BOM = b"\xef\xbb\xbf"


def source_name(path: str) -> str:
    """How messages name an input: the path as given, stdin as ``<stdin>``."""
    return "<stdin>" if path == "-" else path


def read_text(path: str) -> str:
    """The whole text of ``path`` (``-``: stdin), decoded as UTF-8."""
    name = source_name(path)
    try:
        if path == "-":
            data = sys.stdin.buffer.read()
        else:
            with open(path, "rb") as handle:
                data = handle.read()
    except FileNotFoundError:
        raise InputError("no such file", name) from None
    except IsADirectoryError:
        raise InputError("is a directory, not a file", name) from None
    except PermissionError:
        raise InputError("permission denied", name) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", name) from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        bom = len(_BOM) if data.startswith(_BOM) else 0
        offset = exc.start + bom
        line = data.count(b"\n", 0, offset) + 1
        line_start = max(data.rfind(b"\n", 0, offset) + 1, bom)
        col = len(data[line_start:offset].decode("utf-8", errors="replace")) + 1
        raise InputError(f"not UTF-8 text (byte {offset}), 0x{data[offset]:02x} cannot be "
                         "decoded; expected a UTF-8 file", name, line, col) from None
