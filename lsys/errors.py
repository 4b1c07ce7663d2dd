"""Error types shared by every package.

`InputError` is a user's mistake (bad file, bad option value): the CLI prints it as
one line ``file:line:col: error: message`` and exits 2, never with a traceback.
`RunFailure` is a failure while running on valid input (a diverging simulation):
exit 1 with one clear line.
"""

from __future__ import annotations


class PlantlodError(Exception):
    """Base class of every error plantlod reports to a user."""

    exit_code = 1


class InputError(PlantlodError):
    """Bad input, located in a file where possible (exit code 2)."""

    exit_code = 2

    def __init__(self, message: str, file: str | None = None,
                 line: int | None = None, col: int | None = None):
        super().__init__(message)
        self.message = message
        self.file = file
        self.line = line
        self.col = col

    def __reduce__(self):
        """Pickled with its location (a worker process's error, `simplify.chain_workers`)."""
        return (type(self), (self.message, self.file, self.line, self.col))

    def __str__(self) -> str:
        # a file name with a line break or other control character is shown quoted, so the
        # message stays one line (the API's read_tree("\n"))
        where = [shown(str(p)) for p in (self.file, self.line, self.col) if p is not None]
        prefix = ":".join(where)
        return f"{prefix}: {self.message}" if prefix else self.message


def shown(name: str, most: int = 200) -> str:
    """A name or value as a message shows it: quoted where it holds a control character, cut
    to ``most`` characters (a 5,000-character string taken for a path made a 5,000-character
    line; a scene value of 4,000 digits) by `cut_middle`."""
    return cut_middle(name if name.isprintable() else repr(name), most)


def cut_middle(text: str, most: int) -> str:
    """``text`` cut to ``most`` characters by leaving out its middle (an ellipsis stands for
    it): the head of a message names the file and the thing, its tail what is wrong and what
    to do, and what lies between is what runs long (a branch address of 600 parts made a
    message that was cut before it said the length was negative)."""
    if len(text) <= most:
        return text
    head = (most - 1) // 2
    return text[:head] + "…" + text[len(text) - (most - 1 - head):]


class RunFailure(PlantlodError):
    """A failure at run time on valid input (exit code 1)."""

    exit_code = 1


class PlantlodWarning(UserWarning):
    """Something worth a word that does not stop the run (a file with no branch symbol,
    angles far outside the small-angle model). The CLI prints each once as a one-line
    ``warning:`` on stderr (exit 0); a library caller sees it through `warnings`."""


def warn_caller(message: str) -> None:
    """Warn ``message`` as a `PlantlodWarning` at the caller's line: the first frame outside
    plantlod's modules, however deep the call is inside them (`plantlod.simplify`, a callable
    package, reached the warning through three of them and named its own line)."""
    import sys
    import warnings

    level, frame = 2, sys._getframe(1)          # (stacklevel 1 is this function)
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] == "plantlod":
        level, frame = level + 1, frame.f_back
    warnings.warn(message, PlantlodWarning, stacklevel=level)
