"""What every command shares: opening inputs and outputs, `-`, atomic files, messages.

Data goes to stdout or to the ``-o`` file; everything for people (summaries,
warnings, progress) goes to stderr through `console`. An output file is written
to a temporary file beside it and renamed into place only when the command
succeeds, so a failed run never leaves a partial file behind.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import stat
import sys
import threading
from typing import IO, Callable, Iterator

import click

# Re-exported: every command reads its inputs through formats.text_input.
from plantlod.formats.text_input import read_text  # noqa: F401
from plantlod.formats.text_input import source_name as display_name  # noqa: F401
from plantlod.formats.atomic import (atomic_path, landing, lands_on, new_temporary, release,
                                     remove_folder, remove_pending, special_target,
                                     usual_file_mode, write_all)
from plantlod.lsys.errors import InputError, RunFailure, cut_middle

_console = None
DEFAULT_CONSOLE_WIDTH = 80    # characters, where COLUMNS=0 would give rich none


def rich_console(**options):
    """A rich Console with ``options``, whose width ignores COLUMNS=0: rich takes any digits
    there for the width, and a width of 0 drew nothing, not even a command's summary or
    compare's table (a helper, session 35). COLUMNS of 1 or more is honoured as set."""
    from rich.console import Console

    columns = os.environ.get("COLUMNS", "")
    if columns.isdigit() and int(columns) == 0:
        options.setdefault("width", DEFAULT_CONSOLE_WIDTH)
    return Console(**options)


def console():
    """The rich console on stderr (created on first use; rich honours NO_COLOR, TERM=dumb)."""
    global _console
    if _console is None:
        _console = rich_console(stderr=True, highlight=False, soft_wrap=True)
    return _console


def progress_bar():
    """A transient rich progress display on the stderr console (`console`), which leaves
    stdout and stderr alone (a command's data and its one-line messages); for a terminal,
    or where `--progress` forces it on a stderr that is none (a file, a pipe): there rich
    would draw nothing, so the bar is drawn as on a terminal, with its control codes."""
    from rich.progress import Progress

    shown = console()
    if not is_terminal(sys.stderr):
        shown = rich_console(stderr=True, highlight=False, soft_wrap=True, force_terminal=True)
    return Progress(console=shown, transient=True, redirect_stdout=False,
                    redirect_stderr=False)


COMPILING = "compiling the engine (once after an install or upgrade)"


@contextlib.contextmanager
def compiling_shown(bar) -> Iterator[None]:
    """While numba compiles a kernel, a line of its own in ``bar`` (a rich `Progress`) says
    so, and goes when the compiling ends: the first run after an install compiles for up
    to half a minute, during which the stage's bar stood still (a new user's first hour,
    session 36). Kernels loaded from numba's cache fire no compile event and show nothing.
    Compile events nest (a kernel compiles what it calls) and may come from any thread."""
    from numba.core import event

    lock = threading.Lock()

    class Shown(event.Listener):
        depth = 0
        task = None

        def on_start(self, _event) -> None:
            with lock:
                self.depth += 1
                if self.depth == 1:
                    self.task = bar.add_task(COMPILING, total=None)

        def on_end(self, _event) -> None:
            with lock:
                self.depth -= 1
                if self.depth == 0 and self.task is not None:
                    bar.remove_task(self.task)
                    self.task = None

    listener = Shown()
    event.register("numba:compile", listener)
    try:
        yield
    finally:
        event.unregister("numba:compile", listener)


def say(message: str) -> None:
    """One line for people, on stderr (never markup-interpreted). A stderr that cannot be
    written (closed, a full disk) loses the line but never fails the command: it is
    not the command's data."""
    if sys.stderr is None:               # closed (2>&-): the line has nowhere to go
        return
    if not message.isprintable():        # a file name holding a line break: still one line
        message = "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)
    try:
        if _console is None and not is_terminal(sys.stderr):
            # what rich would write to a file or pipe, without importing it (~0.1 s)
            sys.stderr.write(message + "\n")
            sys.stderr.flush()
        else:
            console().print(message, markup=False)
    except OSError:
        pass


def is_terminal(stream) -> bool:
    """Whether ``stream`` is a terminal (False where it is closed: ``2>&-`` makes it None)."""
    try:
        return stream is not None and stream.isatty()
    except (AttributeError, ValueError, OSError):
        return False


MAX_WARNINGS = 20            # warnings shown per command; the rest are counted
MAX_MESSAGE_CHARS = 400      # a longer warning is cut (an address of 400,000 parts)
_shown = {"warnings": 0, "hidden": 0}


def warn(message: str) -> None:
    """One warning line on stderr; at most MAX_WARNINGS per command, each cut to a line."""
    if _shown["warnings"] >= MAX_WARNINGS:
        _shown["hidden"] += 1
        return
    _shown["warnings"] += 1
    text = cut_middle(" ".join(message.split()), MAX_MESSAGE_CHARS)
    say(f"warning: {text}")


def end_warnings() -> None:
    """Say how many warnings were not shown, and start counting again (next command)."""
    if _shown["hidden"]:
        say(f"warning: {_shown['hidden']:,} more warnings not shown")
    _shown.update(warnings=0, hidden=0)


_pending: list[str] = []


def large_file_angles(times, bend, rot, addresses, name: str, degrees: bool) -> str | None:
    """The warning where an angle file's branch tilts beyond the model's range
    (`sim.angle_range`), as `simulate` warns of its own run, or None: a file written with
    `simulate --degrees` and read without --degrees swings 57 times too far, and the file
    cannot say its unit (`export`, `compare`)."""
    from plantlod.sim.angle_range import first_large_angle

    first = first_large_angle(times, bend, rot, addresses)
    if first is None:
        return None
    hint = "" if degrees else "; if the file holds degrees (simulate --degrees), give --degrees"
    return first.message(name) + hint


def warn_once_running(message: str) -> None:
    """A warning that only matters if the command goes on: printed when it starts writing
    its output (`open_output`) or ends well, dropped when it fails, so that a refused
    run still ends in exactly one line."""
    if message not in _pending:
        _pending.append(message)


def flush_pending_warnings() -> None:
    while _pending:
        warn(_pending.pop(0))


def drop_pending_warnings() -> None:
    _pending.clear()


_PLURALS = {"branch": "branches", "leaf": "leaves"}


def count(n: int, noun: str) -> str:
    """``n`` and ``noun`` for a summary line: "1 leaf", "1,563 leaves", "8 branches"."""
    return f"{n:,} {noun if n == 1 else _PLURALS.get(noun, noun + 's')}"


def check_output_path(path: str | None, folder: bool = False) -> None:
    """Refuse now what `open_output` would refuse later (a missing directory, a directory
    as the target, a file name ending in / unless ``folder``), so that a command can check
    every output before writing the first."""
    if path is None or path == "-":
        return
    if not path:
        raise InputError("the output file name is empty; expected a file name, or - for standard "
                         "output")
    if not folder and path.endswith(("/", os.sep)):   # (abspath drops it: found after the work)
        raise InputError("names a folder (it ends in /); expected a file name", path)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise InputError("output directory does not exist", path)
    mode = _mode(path)                          # a device or a pipe is written in place
    if mode is None or stat.S_ISREG(mode) or not os.access(path, os.W_OK):
        _refuse_unwritable(parent, path, "its folder")
    special_target(path)
    _checked.add(os.path.abspath(path))


def _refuse_unwritable(folder: str, path: str, where: str) -> None:
    """Before any work: ``path``'s output, made in ``folder`` (``where`` names it), cannot be
    written there. A read-only folder failed after all the work (exit 1) where one that
    cannot be entered was refused first (exit 2; a fuzzing round): a folder the user may not
    write in is now bad usage (exit 2), a read-only file system a failure (exit 1, as
    docs/errors.md has it), both before the work."""
    try:
        read_only = bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except OSError:
        read_only = False
    if read_only:
        raise RunFailure(f"cannot write {display_name(path)}: {where} is on a read-only file "
                         "system")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"cannot write in {where}: permission denied", path)


def _mode(path: str) -> int | None:
    """``path``'s file mode (symbolic links followed); None where it does not exist or
    cannot be looked at."""
    try:
        return os.stat(path).st_mode
    except (OSError, ValueError):
        return None


# outputs whose folder `check_output_path` found before the command's work: one missing when
# it is written was removed meanwhile (`_folder_gone`); emptied as each command starts
_checked: set[str] = set()


def forget_checked_outputs() -> None:
    _checked.clear()


def check_output_folder(path: str, option: str, writes: str, parents: bool = True) -> None:
    """Refuse (before any work) a folder output (``option`` writes ``writes`` into it) named
    "" or "-", which name no folder (`--levels ""` was told of an empty *file* name,
    `--levels -` made a folder named "-": session 34); with ``parents`` False also one whose
    folder does not exist (else the folders on its way are made with it, `output_folder`)."""
    if path in ("", "-"):
        raise click.UsageError(f"{option} writes {writes}, a folder: "
                               f"{'standard output' if path else 'an empty name'} cannot hold "
                               "one; expected the name of a folder")
    if not parents and not os.path.lexists(path):
        check_output_path(path, folder=True)
    made_in = os.path.abspath(path)            # the folder itself, or the first that exists on
    while not os.path.isdir(made_in):          # its way (where it is made)
        above = os.path.dirname(made_in)
        if above == made_in or (os.path.lexists(made_in) and not os.path.isdir(made_in)):
            return                             # (a file on the way: the writer says)
        made_in = above
    _refuse_unwritable(made_in, path, "it" if made_in == os.path.abspath(path) else made_in)


def check_output_kind(path: str | None, option: str, writes: str, accepted: tuple[str, ...]) -> None:
    """Refuse (bad usage, before any work) an output whose extension names a kind of file
    other than what the option writes: ``writes`` says what it writes, ``accepted`` the
    extensions that hold it. Names without a known extension (``out``, ``/dev/null``,
    ``-``) pass."""
    from plantlod.formats.kinds import output_kind_problem

    if path is None or path == "-":
        return
    problem = output_kind_problem(path, writes, accepted)
    if problem is not None:
        raise click.UsageError(f"{option} {display_name(path)}: {problem}")


def distinct_paths(outputs: dict[str, str | None], inputs: dict[str, str | None] | None = None) -> None:
    """Refuse, before any work, two outputs naming one path (one would overwrite the other,
    or a failure of the second would leave the first's file where the second wanted a
    folder), and an output naming an input (the input would be written over: `derive x.lsys
    -o x.lsys` replaced its own L-system), and two inputs read from standard input (the
    second read nothing, and was called empty: `compare - -`). ``outputs`` and
    ``inputs`` map an option's name to its path (None or ``-``: none); a device or a pipe
    (``/dev/null``) may take several outputs."""
    to_stdout = [option for option, path in outputs.items() if path == "-"]
    if len(to_stdout) > 1:                  # (a PNG and a JSON report mixed in one stream)
        raise click.UsageError(f"{to_stdout[0]} and {to_stdout[1]} both write to standard output "
                               "(-); give one of them a file")
    from_stdin = [what for what, source in (inputs or {}).items() if source == "-"]
    if len(from_stdin) > 1:
        raise click.UsageError(f"{from_stdin[0]} and {from_stdin[1]} both read standard input (-), "
                               "which can be read once; give one of them a file")
    piped: dict[tuple[int, int], str] = {}  # (the same named pipe twice: the second open
    for what, source in (inputs or {}).items():     # waited for a writer for ever)
        pipe = _pipe_identity(source)
        if pipe is not None and pipe in piped:
            raise click.UsageError(f"{piped[pipe]} and {what} both read the pipe {source}, "
                                   "which can be read once; give one of them a file")
        if pipe is not None:
            piped[pipe] = what
    seen: dict[str, str] = {}
    for option, path in outputs.items():
        if path is None or path == "-":
            continue
        key = landing(path)             # (a link at the path is replaced, not followed)
        if key in seen and not _device(path):
            raise click.UsageError(f"{seen[key]} and {option} name the same file {path}; "
                                   "expected a path for each")
        seen[key] = option
    for what, source in (inputs or {}).items():
        if source is None or source == "-" or _device(source):
            continue
        for option, path in outputs.items():
            if path not in (None, "-") and lands_on(path, source):
                raise click.UsageError(f"{option} would write over the input {source} ({what}); "
                                       "expected another path")


def _pipe_identity(path: str | None) -> tuple[int, int] | None:
    """(device, inode) of the named pipe (FIFO) at ``path``, standard input's for ``-``;
    None for anything else."""
    if path is None:
        return None
    try:
        info = os.fstat(0) if path == "-" else os.stat(path)
    except (OSError, ValueError):
        return None
    return (info.st_dev, info.st_ino) if stat.S_ISFIFO(info.st_mode) else None


def _device(path: str) -> bool:
    """Whether ``path`` is a device or a pipe (not a file, not a folder, not missing)."""
    mode = _mode(path)
    return mode is not None and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


@contextlib.contextmanager
def open_output(path: str | None, binary: bool = False) -> Iterator[IO]:
    """A stream for ``path``: stdout for None or ``-``, else an atomic file.

    A regular file appears (by rename of a temporary file beside it, with the
    usual permissions) only if the block finishes without an exception, so a
    failed run never leaves a partial file; the temporary file is removed on
    every way out, signals included (`cli.discipline` turns SIGTERM and SIGHUP
    into exceptions). A target that exists and is not a regular file
    (``/dev/null``, a named pipe) is written in place. Text streams are UTF-8
    with ``\\n`` line ends; ``binary=True`` gives a bytes stream. An output that
    cannot be written (disk full, read-only, closed stdout) is a `RunFailure`.
    """
    flush_pending_warnings()
    if path is None or path == "-":
        if sys.stdout is None:
            raise RunFailure("standard output is closed; give -o FILE or redirect it")
        with write_errors("standard output"):
            sys.stdout.flush()                  # what click or print left there goes first
            buffer = getattr(sys.stdout, "buffer", None)
            if buffer is None:                  # a text-only stdout (a StringIO in a test)
                yield sys.stdout
                sys.stdout.flush()
                return
            out = WholeWrites(buffer, text=not binary, name="standard output")
            yield out
            out.flush()
        return
    if _gone_since_checked(path):
        raise _folder_gone(path)
    check_output_path(path)
    with write_errors(path), atomic_path(path) as tmp:    # (a device or a pipe: in place)
        with _open_stream(tmp, binary, display_name(path)) as out:
            yield out


class WholeWrites:
    """A binary stream's writer that writes every byte or raises: a buffered stream may
    accept part of a large write and report it by a short count (a disk that fills up
    mid-write), which a text layer drops without a word. ``text``: write() takes str
    (UTF-8, no newline translation; a character UTF-8 cannot hold, such as the lone
    surrogate that stands for an undecodable byte of a file name, is written as its
    escape ``\\udcff``, which a JSON reader turns back into it)."""

    def __init__(self, stream: IO[bytes], text: bool, name: str | None = None):
        self.stream, self.text = stream, text
        if name is not None:
            self.name = name        # (what an API writer names in an error: "standard output")

    def write(self, data) -> int:
        write_all(self.stream, data.encode("utf-8", "backslashreplace") if self.text else data)
        return len(data)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        self.stream.flush()

    def close(self) -> None:
        self.stream.close()

    def isatty(self) -> bool:
        return self.stream.isatty()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


_FULL_ERRORS = (errno.ENOSPC, errno.EDQUOT)     # a write's own failures: no file to name


@contextlib.contextmanager
def output_folder(path: str, suffix: str = "", merge: bool = False) -> Iterator[str]:
    """A new, empty temporary folder ``.plantlod-*SUFFIX`` to fill, beside ``path`` (or
    beside its nearest existing ancestor, when folders on the way are still missing).

    When the block ends normally the missing folders on the way are made and the temporary
    one becomes ``path`` (renamed), or with ``merge`` and an existing folder ``path``, its
    files are moved into that folder; on any exception, and on a signal
    (`formats.atomic.remove_pending`), it is removed with everything in it, so a failed run leaves
    no folder behind, not even the ones on the way. A failure where the temporary folder itself
    is gone (its parent removed while the command ran) is `_folder_gone`, naming ``path``.
    """
    if not path:
        raise InputError("the output folder name is empty")
    if os.path.lexists(path) and not (merge and os.path.isdir(path)):
        raise InputError("is not a folder" if merge else "exists; expected a new path", path)
    if merge and os.path.isdir(path):
        # inside the folder filled, so that the moves stay on its file system (beside it,
        # a folder that is a mount point failed them all after the work: session 42)
        base = os.path.abspath(path)
    else:
        base = os.path.dirname(os.path.abspath(path))
        while not os.path.lexists(base):
            base = os.path.dirname(base)
        if not os.path.isdir(base):
            raise InputError(f"{base} is not a folder", path)
    with write_errors(path):
        tmp = new_temporary(base, suffix, is_folder=True)   # (registered for remove_pending)
    try:
        try:
            yield tmp
        except (InputError, RunFailure, OSError) as exc:
            if not os.path.isdir(tmp):       # (named as the user named it, not as tmp)
                raise _folder_gone(path) from None
            if isinstance(exc, OSError) and (       # (a full disk's write names no file)
                    str(getattr(exc, "filename", "")).startswith(tmp)
                    or (not getattr(exc, "filename", None) and exc.errno in _FULL_ERRORS)):
                raise RunFailure(f"cannot write {display_name(path)}: "
                                 f"{exc.strerror or exc}") from None
            if isinstance(exc, RunFailure) and tmp in str(exc):    # (a full disk, mid-fill)
                raise RunFailure(str(exc).replace(tmp, display_name(path))) from None
            raise
        with write_errors(path):
            if merge and os.path.isdir(path):
                names = sorted(os.listdir(tmp))
                check_merge_targets(path, names)     # before the first move: all or none
                for name in names:
                    os.replace(os.path.join(tmp, name), os.path.join(path, name))
                os.rmdir(tmp)
            else:
                os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
                os.chmod(tmp, usual_file_mode(folder=True))
                os.replace(tmp, path)
    finally:
        remove_folder(tmp)                     # (nothing where it was renamed into place)
        release(tmp)


def check_merge_targets(path: str, names: list[str]) -> None:
    """InputError where one of ``names`` in the folder ``path`` is a folder (a file cannot
    replace it), so that nothing is moved in when not everything can be."""
    for name in names:
        target = os.path.join(path, name)
        if os.path.isdir(target) and not os.path.islink(target):
            raise InputError(f"{name} in it is a folder; expected a file of that name or none",
                             path)


@contextlib.contextmanager
def write_errors(name: str) -> Iterator[None]:
    """OSError while writing ``name`` -> RunFailure naming it (a broken pipe passes: quiet)."""
    try:
        yield
    except BrokenPipeError:
        raise
    except OSError as exc:
        reason = exc.strerror or str(exc)
        if exc.errno == errno.ENOENT and _gone_since_checked(name):
            raise _folder_gone(name) from None
        if exc.errno in _BAD_NAME_ERRORS:      # the name given is wrong: bad input
            raise InputError(f"cannot write: {reason}", name) from None
        raise RunFailure(f"cannot write {name}: {reason}") from None


def reader_gone_after(write: Callable[[], None]) -> BrokenPipeError | None:
    """Run ``write`` (of standard output, inside a block whose side outputs land when it
    ends) and return the BrokenPipeError of a reader gone (`| head`, quitting a pager) in
    place of raising it: the caller lets its side outputs land, whole, and then raises it, so
    the command ends quietly (141) with its pictures and frames written, since the reader cut
    only the table, by choice. Any other failure (a full disk, a closed standard output)
    raises at once, and nothing lands (session 35)."""
    try:
        write()
    except BrokenPipeError as exc:
        return exc
    return None


def _gone_since_checked(path: str) -> bool:
    """Whether ``path``'s folder, there when `check_output_path` looked, is missing now."""
    try:
        full = os.path.abspath(path)
    except OSError:                          # (the working directory removed)
        return False
    return full in _checked and not os.path.isdir(os.path.dirname(full))


def _folder_gone(path: str) -> RunFailure:
    """An output whose folder was there when the command checked its outputs, before its
    work (`check_output_path`), and is missing when it is written: removed while the command
    ran, a run-time failure, not bad input (it was exit 2, session 35). An output no check
    saw keeps check_output_path's exit 2. `output_folder` says the same of its folder output
    where the temporary folder it fills went while the command ran."""
    return RunFailure(f"cannot write {display_name(path)}: its folder no longer exists "
                      "(removed while the command ran?)")


_BAD_NAME_ERRORS = {errno.ENAMETOOLONG, errno.ENOTDIR, errno.ENOENT, errno.EISDIR}


def _open_stream(target, binary: bool, name: str | None = None) -> WholeWrites:
    """Open a path for writing: bytes, or UTF-8 text with \\n line ends; every write whole.
    ``name``: what an error names (the output as the user gave it, not its temporary: an API
    writer said "cannot write the stream", session 42's fuzzing)."""
    return WholeWrites(io.open(target, "wb"), text=not binary, name=name)
