"""What every command shares: opening inputs and outputs, `-`, atomic files, messages.

Data goes to stdout or to the ``-o`` file; everything for people (summaries,
warnings, progress) goes to stderr through `console`. An output file is written
to a temporary file beside it and renamed into place only when the command
succeeds, so a failed run never leaves a partial file behind.
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
from typing import Iterator, TextIO

from plantlod.lsys.errors import InputError

_console = None


def console():
    """The rich console on stderr (created on first use; rich honours NO_COLOR, TERM=dumb)."""
    global _console
    if _console is None:
        from rich.console import Console
        _console = Console(stderr=True, highlight=False, soft_wrap=True)
    return _console


def say(message: str) -> None:
    """One line for people, on stderr (never markup-interpreted)."""
    console().print(message, markup=False)


def warn(message: str) -> None:
    say(f"warning: {message}")


def read_text(path: str) -> str:
    """The whole text of ``path`` (``-`` reads stdin), as UTF-8."""
    try:
        if path == "-":
            data = sys.stdin.buffer.read()
        else:
            with open(path, "rb") as fh:
                data = fh.read()
    except FileNotFoundError:
        raise InputError("no such file", path) from None
    except IsADirectoryError:
        raise InputError("is a directory, not a file", path) from None
    except PermissionError:
        raise InputError("permission denied", path) from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text (byte {exc.start})", path) from None


def display_name(path: str) -> str:
    return "<stdin>" if path == "-" else path


@contextlib.contextmanager
def open_output(path: str | None) -> Iterator[TextIO]:
    """A text stream for ``path``: stdout for None or ``-``, else an atomic file.

    The file appears (by rename) only if the block finishes without an exception.
    Line ends are always ``\\n``.
    """
    if path is None or path == "-":
        out = sys.stdout
        yield out
        out.flush()
        return
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise InputError("output directory does not exist", path)
    fd, tmp = tempfile.mkstemp(prefix=".plantlod-", suffix=".tmp", dir=directory)
    try:
        with io.open(fd, "w", encoding="utf-8", newline="\n") as out:
            yield out
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
