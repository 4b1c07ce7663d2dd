"""One error discipline for every command (docs/errors.md), applied by the `plantlod` group.

Every command registered on the group inherits it without code of its own:

- exit 2 and one line for bad input: `InputError` (``file:line:col: error: ...``) and
  click's usage errors (``plantlod CMD: error: ...``, never click's 4-line block);
- exit 1 and one line for a failure at run time: `RunFailure`, an output that cannot
  be written (disk full, read-only, ``/dev/full``, a closed standard output), out of
  memory, and anything unexpected ("internal error", traceback only with
  ``PLANTLOD_DEBUG=1``);
- 128 + the signal's number for SIGINT (130), SIGTERM (143) and SIGHUP (129): the
  handler removes every temporary file `cli.io.open_output` holds, prints one line and
  ends the process at once (``os._exit``). It does not raise: an exception raised by a
  signal handler can land in a ``__del__`` or a finaliser, where Python prints and
  drops it, and the run would go on. A signal the parent set to be ignored (``nohup``)
  stays ignored;
- a reader that goes away (``| head``) ends the command quietly.

Numeric options are bounded here too (`harden_params`): a float option refuses NaN and
infinities, an integer option anything beyond int64, whatever command declares them.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import signal
import sys
from typing import Callable

import click

from plantlod.lsys.errors import InputError, PlantlodError, PlantlodWarning, cut_middle, shown
from plantlod.formats.atomic import defer_signal, end_deferred, remove_pending
from plantlod.sim.constants import CAUGHT_SIGNALS  # (cli.io reads it from here too)

# Signals that end a command: temporary files removed, exit 128 + n.
INT64_MAX = 2**63 - 1
MAX_ERROR_CHARS = 1000       # an error message longer than this is cut
DEBUG_VARIABLE = "PLANTLOD_DEBUG"


class ReaderGone(BaseException):
    """The reader of stdout went away (``| head``): a BrokenPipeError from a write to it, past
    click's own handling (which turns it into exit 1); ends the command quietly with 141."""


class Terminated(BaseException):
    """A signal asked the process to end; a BaseException, so `except Exception` lets it pass."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


_current = {"command": None}     # the subcommand running, for the signal handler's line


def set_current_command(name: str | None) -> None:
    _current["command"] = name


def _end_on_signal(signum, _frame):
    # nothing imported here: a signal while a module loads (cli.io) met a circular import,
    # whose ImportError printed a traceback or was swallowed and the run went on
    for other in CAUGHT_SIGNALS:                # once: a group-wide signal arrives twice
        signal.signal(other, signal.SIG_IGN)
    if defer_signal(signum):                    # writes in flight: ended when they are done
        return
    _end_now(signum)


def _end_now(signum: int) -> None:
    """Remove what is half written, say why, exit 128 + n."""
    remove_pending()
    code, line = describe_failure(_named(Terminated(signum), _current["command"]))
    _say(line)
    os._exit(code)


def _named(exc: BaseException, command: str | None) -> BaseException:
    exc.plantlod_command = command
    return exc


def _done_before_signals() -> None:
    """The command's work is done and its output in place: a signal from here on is too
    late to stop it, so it is ignored and the command ends 0 (a helper's fuzzing, session
    33: one during the interpreter's last 0.2-0.8 s said "interrupted", exit 130, beside a
    whole output, or, once Python's finalisation had put the default actions back, killed
    it with no word). Only where this module's handlers are installed (`main`), never in a
    caller's process (the API, the tests' in-process runs)."""
    for signum in CAUGHT_SIGNALS:
        if signal.getsignal(signum) is _end_on_signal:
            signal.signal(signum, signal.SIG_IGN)


def install_signal_handlers() -> None:
    """The signals of CAUGHT_SIGNALS end the command cleanly (unless ignored by the parent).
    SIGPIPE stays ignored (Python's start-up does so): a reader of stdout that goes away
    (``| head``) raises BrokenPipeError at the next write, which ends the command quietly
    with 141 once its temporary files are removed (`describe_failure`), and stderr is
    `QuietStream` (a reader of stderr that goes away loses the messages, nothing else).
    With SIGPIPE's default action, a closed stderr killed the command at its next message:
    exit 141 where it would have exited 0, and a `--progress` run's temporary file left."""
    end_deferred[0] = _end_now
    for signum in CAUGHT_SIGNALS:
        if signal.getsignal(signum) != signal.SIG_IGN:
            signal.signal(signum, _end_on_signal)
    if sys.stderr is not None and not isinstance(sys.stderr, QuietStream):
        sys.stderr = QuietStream(sys.stderr)


class QuietStream:
    """A text stream whose writes and flushes cannot fail: the first OSError (a closed pipe,
    a full disk) or ValueError (a closed file) ends its output, and the caller goes on
    (docs/errors.md: a stderr that is closed or full loses the messages but never changes
    the exit code). Everything else is the wrapped stream's."""

    def __init__(self, stream):
        self._stream, self._lost = stream, False

    def write(self, text: str) -> int:
        if not self._lost:
            try:
                self._stream.write(text)
            except (OSError, ValueError):
                self._lost = True
        return len(text)

    def flush(self) -> None:
        if not self._lost:
            try:
                self._stream.flush()
            except (OSError, ValueError):
                self._lost = True

    def __getattr__(self, name):
        return getattr(self._stream, name)


# --- numeric options ---------------------------------------------------------------

class _Bounded(click.ParamType):
    """Wraps a float or int option type: the same conversion, then a bound check."""

    def __init__(self, base: click.ParamType):
        self.base = base
        self.name = base.name

    def convert(self, value, param, ctx):
        out = self.base.convert(value, param, ctx)
        if isinstance(out, float) and not math.isfinite(out):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        if isinstance(out, int) and not isinstance(out, bool) and abs(out) > INT64_MAX:
            self.fail(f"{value!r} is too large; expected at most {INT64_MAX:,}", param, ctx)
        return out

    def get_metavar(self, param, ctx=None):
        return self.base.get_metavar(param, ctx) if ctx is not None else None

    def __repr__(self) -> str:
        return repr(self.base)


class ErrorBound(click.ParamType):
    """A relative error bound: a fraction (0.05) or a percentage (5%), finite and >= 0, as a
    fraction. The summaries print percentages (simplify) and fractions (compare), and a
    user who read "5.00 %" typed "5%" (a new user's first hour, session 36)."""

    name = "FRACTION"

    def convert(self, value, param, ctx):
        if isinstance(value, float):
            return value
        text = str(value).strip()
        percent = text.endswith("%")
        try:
            number = float(text[:-1] if percent else text)
        except ValueError:
            number = math.nan
        expected = "a fraction (0.05) or a percentage (5%) >= 0"
        if math.isinf(number) or (math.isnan(number) and "nan" in text.lower()):
            self.fail(f"{value!r} is not a finite number; expected {expected}", param, ctx)
        if not number >= 0:
            self.fail(f"expected {expected}, got {value!r}", param, ctx)
        return number / 100.0 if percent else number


class Metres(click.ParamType):
    """A length in metres, finite and >= 0. A percentage is refused in words: the relative
    bounds take one, a length does not (`compare --max-tip-error-m 5%` was "not a valid float
    range": a new user's first hour, session 42)."""

    name = "METRES"

    def convert(self, value, param, ctx):
        if isinstance(value, float):
            return value
        text = str(value).strip()
        if text.endswith("%"):
            self.fail(f"{value!r} is a percentage; expected a length in metres (such as 0.05), "
                      "as the tip error (max) is measured", param, ctx)
        try:
            number = float(text)
        except ValueError:
            number = math.nan
        if not (number >= 0 and math.isfinite(number)):
            self.fail(f"expected a length in metres >= 0, got {value!r}", param, ctx)
        return number


def harden_params(command: click.Command) -> click.Command:
    """Bound every float and int option of ``command`` (and of its subcommands), once."""
    if getattr(command, "_plantlod_hardened", False):
        return command
    for param in command.params:
        if isinstance(param.type, (click.types.FloatParamType, click.types.IntParamType)):
            param.type = _Bounded(param.type)
    command._plantlod_hardened = True
    return command


# --- options that only work together -------------------------------------------------

def given(ctx: click.Context, name: str) -> bool:
    """True when the parameter ``name`` was given (command line or environment)."""
    from click.core import ParameterSource

    return ctx.get_parameter_source(name) not in (None, ParameterSource.DEFAULT)


def require_together(ctx: click.Context, needs: dict[str, tuple[str, ...]]) -> None:
    """An option given without any of the options it needs has no effect: a usage error.

    ``needs`` maps a parameter name to the names of which one must be given with it
    (``{"evaluations": ("calibrate",)}``).
    """
    for name, partners in needs.items():
        if given(ctx, name) and not any(given(ctx, p) for p in partners):
            def flag(n: str) -> str:
                opts = [o for p in ctx.command.params if p.name == n for o in p.opts]
                return max(opts, key=len) if opts else "--" + n.replace("_", "-")
            raise click.UsageError(f"{flag(name)} has no effect without "
                                   f"{' or '.join(flag(p) for p in partners)}", ctx)


# --- the exit codes ------------------------------------------------------------------

def _command_name(exc: BaseException, fallback: str) -> str:
    ctx = getattr(exc, "ctx", None)
    if ctx is not None:
        return ctx.command_path
    name = getattr(exc, "plantlod_command", None)
    return f"{fallback} {name}" if name else fallback


# what makes each command's run smaller, in its own options (out of memory)
_SMALLER = {
    "derive": "lower --max-modules or --steps",
    "simulate": "fewer --steps, a larger --every, or fewer branches",
    "compare": "a shorter --duration, a larger --every, or fewer branches",
    "export": "fewer --frames, a shorter run, or fewer branches",
    "simplify": "a shorter --duration or a smaller tree",
    "scene": "fewer trees, a shorter duration, or a larger dt",
    "view": "fewer or smaller glTF files",
}


def describe_failure(exc: BaseException, prog: str = "plantlod") -> tuple[int, str | None]:
    """The exit code and the one line (None: quiet) for an exception that ended a command."""
    where = _command_name(exc, prog)
    if isinstance(exc, click.exceptions.Exit):
        return exc.exit_code, None
    if isinstance(exc, getattr(click.exceptions, "NoArgsIsHelpError", ())):
        # `plantlod` (or a group) alone: its help as --help prints it, not one flattened line
        return 2, exc.format_message().rstrip("\n")
    if isinstance(exc, click.UsageError):
        message = " ".join(exc.format_message().split())
        return 2, f"{where}: error: {message} (see '{where} --help')"
    if isinstance(exc, click.exceptions.Abort):
        return 128 + signal.SIGINT, f"{where}: interrupted"
    if isinstance(exc, InputError) and exc.file:
        # (a file name with a line break is shown quoted, as the API's str() shows it: its
        # \n was shown as a space, the name of another file; a fuzzing round)
        loc = ":".join(shown(str(p), MAX_ERROR_CHARS) for p in (exc.file, exc.line, exc.col)
                       if p is not None)       # (whole: a path cut at 200 names no file)
        return 2, _within_cut(f"{_one_line(loc)}: error: ", exc.message)
    if isinstance(exc, PlantlodError):
        return exc.exit_code, _within_cut(f"{where}: error: ", str(exc))
    if isinstance(exc, KeyboardInterrupt):
        return 128 + signal.SIGINT, f"{where}: interrupted"
    if isinstance(exc, Terminated):
        if exc.signum == signal.SIGINT:
            return 128 + exc.signum, f"{where}: interrupted"
        return 128 + exc.signum, f"{where}: ended by {signal.Signals(exc.signum).name}"
    if isinstance(exc, (BrokenPipeError, ReaderGone)):
        return 128 + getattr(signal, "SIGPIPE", 13), None
    if isinstance(exc, FileNotFoundError) and not exc.filename and _working_directory_gone():
        # a relative path in a working directory removed under the shell: "No such file or
        # directory" named nothing (a helper, session 35); a command that needs no relative
        # path still runs there
        return 1, (f"{where}: error: the working directory no longer exists (it was removed "
                   "after the shell entered it); cd to an existing folder and run again")
    if isinstance(exc, OSError):
        target = f"{exc.filename}: " if exc.filename else ""
        reason = exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))
        return 1, f"{where}: error: {target}{reason}"
    if isinstance(exc, MemoryError):
        command = where.split()[-1]
        return 1, (f"{where}: error: out of memory; expected a smaller run "
                   f"({_SMALLER.get(command, 'fewer steps or branches')})")
    if isinstance(exc, RecursionError):
        return 2, f"{where}: error: input nested too deeply"
    return 1, (f"{where}: internal error: {type(exc).__name__}: {_one_line(str(exc))} "
               f"(set {DEBUG_VARIABLE}=1 for the traceback)")


def _working_directory_gone() -> bool:
    try:
        os.getcwd()
    except FileNotFoundError:
        return True
    return False


def _one_line(text: str, most: int = MAX_ERROR_CHARS) -> str:
    """``text`` on one line, control characters (a NUL read from a file) escaped, cut
    to ``most`` characters (`cut_middle`)."""
    text = " ".join(str(text).split())
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return cut_middle(text, most)


def _within_cut(prefix: str, message: str) -> str:
    """``prefix`` and ``message`` on one line of at most MAX_ERROR_CHARS, the message cut in
    its middle to leave the room the prefix takes (the message alone was cut, and a 5,001-digit
    number made a line of 1,064; an L-system fuzzing round). A prefix of more than half the
    line (a path of 600 characters) is cut too."""
    prefix = _one_line(prefix, MAX_ERROR_CHARS // 2) if len(prefix) > MAX_ERROR_CHARS // 2 \
        else prefix
    return prefix + _one_line(message, MAX_ERROR_CHARS - len(prefix))


def run_guarded(call: Callable[[], object], prog: str = "plantlod") -> int:
    """Run ``call`` (a click main in non-standalone mode); map its end to an exit code."""
    from .io import drop_pending_warnings, end_warnings, flush_pending_warnings, forget_checked_outputs

    drop_pending_warnings()
    forget_checked_outputs()
    try:
        with _library_warnings():
            result = call()
        flush_pending_warnings()
        end_warnings()
        _flush_stdout()
        _done_before_signals()
        return result if isinstance(result, int) else 0
    except BaseException as exc:     # noqa: BLE001 -- the one place every failure ends
        if isinstance(exc, SystemExit):
            raise
        try:
            return _ended(exc, prog)
        except BaseException as late:   # noqa: BLE001 -- a signal (or memory running out)
            # while the failure was being said: its own one line, not Python's traceback of
            # both (seen once under a parallel 5 GB run, an L-system fuzzing round)
            return _ended_late(late, exc, prog)


def _ended(exc: BaseException, prog: str) -> int:
    """Say the one line for the failure ``exc`` (`describe_failure`), let what stdout holds
    go, and give the exit code."""
    from .io import drop_pending_warnings, end_warnings

    drop_pending_warnings()
    end_warnings()
    code, line = describe_failure(exc, prog)
    if code != 0 and os.environ.get(DEBUG_VARIABLE) and not isinstance(exc, click.exceptions.Exit):
        import traceback
        traceback.print_exc()
    if line:
        _say(line)
    try:
        _flush_stdout()          # what was written before the failure (compare's JSON)
    except (OSError, ValueError):
        pass
    _discard_stdout()
    return code


def _ended_late(late: BaseException, first: BaseException, prog: str) -> int:
    """The exit code and one line where ``late`` ended the saying of ``first``: a signal's
    (`describe_failure` of it), else the first failure's kind alone."""
    try:
        where = _command_name(first, prog)      # (the late one was raised outside the command)
        code, line = describe_failure(late, where)
        if not isinstance(late, (Terminated, KeyboardInterrupt)):
            code, line = 1, f"{where}: error: {type(first).__name__} (and {type(late).__name__} "\
                            "while saying it)"
        if line:
            _say(line)
    except BaseException:        # noqa: BLE001 -- nothing more can be said
        code = 1
    _discard_stdout()
    return code


@contextlib.contextmanager
def _library_warnings():
    """`PlantlodWarning`s raised by the library become the command's one-line warnings
    (pending until it writes its output or ends well; every one, each once), and so do
    numpy's floating-point RuntimeWarnings ("overflow encountered in multiply": an input
    near a double's range; the command's own checks then refuse what is not finite, and
    the warning is dropped with the run's other warnings); other warnings keep Python's
    handling."""
    import warnings

    from .io import warn_once_running

    with warnings.catch_warnings():
        warnings.simplefilter("always", PlantlodWarning)
        previous = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, PlantlodWarning):
                warn_once_running(str(message))
            elif issubclass(category, RuntimeWarning) and " encountered in " in str(message):
                warn_once_running(f"floating point: {message}")
            else:
                previous(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def _flush_stdout() -> None:
    """Flush stdout now, so that a full disk is reported instead of lost at exit."""
    if sys.stdout is not None:
        sys.stdout.flush()


def _discard_stdout() -> None:
    """After a failure, drop what stdout still buffers (it cannot be written, or must not be)."""
    if sys.stdout is not None and not isinstance(sys.stdout, _NullOut):
        sys.stdout = _NullOut()


class _NullOut:
    """A stdout that writes nothing (keeps the exit-time flush from failing again)."""

    def write(self, text):
        return len(text)

    def flush(self):
        pass

    def isatty(self):
        return False


def _say(line: str) -> None:
    try:
        if sys.stderr is not None:
            sys.stderr.write(line + "\n")
            sys.stderr.flush()
    except OSError:
        pass
