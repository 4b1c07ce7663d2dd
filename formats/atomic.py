"""Files that appear whole or not at all: a temporary file beside the target, renamed over it.

Every temporary made here is registered until it is renamed or removed, so that a signal
handler (`cli.discipline`) can remove whatever is half written (`remove_pending`), whoever
made it: the CLI's outputs, the exporters, the API's writers.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import shutil
from typing import Iterator

_pending: set[str] = set()        # temporary files and folders held right now
_children: set = set()            # worker processes (subprocess.Popen) running right now
_uninterrupted = [0]              # blocks of writes open right now (`uninterrupted`)
_deferred: list[int] = []         # a signal that arrived during one, for `end_deferred`
end_deferred = [None]             # what ends the command on a deferred signal (cli.discipline)
TEMPORARY_PREFIX = ".plantlod-"   # every temporary's name begins so
TEMPORARY_NAME_TRIES = 100        # names tried before a folder is taken to refuse new ones


@contextlib.contextmanager
def uninterrupted() -> Iterator[None]:
    """A block of writes a signal must not cut short. zarr writes chunks on its own I/O
    thread while the caller waits; a signal's handler that removed the pending folder and
    exited during that wait let the chunks in flight land in a folder already removed (a
    ``.plantlod-*.zarr`` left behind). A signal that arrives in the block is held
    (`defer_signal`) and handled as it ends, when no write is in flight."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield                                    # (signals are handled in the main thread)
        return
    _uninterrupted[0] += 1
    try:
        yield
    finally:
        _uninterrupted[0] -= 1
        if not _uninterrupted[0] and _deferred and end_deferred[0] is not None:
            end_deferred[0](_deferred[0])


def defer_signal(signum: int) -> bool:
    """True where a block of `uninterrupted` writes is open: the signal is then held until
    it ends (a signal handler asks this first)."""
    if _uninterrupted[0] and end_deferred[0] is not None:
        _deferred.append(signum)
        return True
    return False


def usual_file_mode(folder: bool = False) -> int:
    """0o666 minus the umask: the mode `open()` would give a new file (a temporary has
    0o600); with ``folder``, 0o777 minus the umask, what `os.mkdir` gives (a temporary folder
    has 0o700)."""
    umask = os.umask(0)
    os.umask(umask)
    return (0o777 if folder else 0o666) & ~umask


def new_temporary(folder: str, suffix: str = "", *, is_folder: bool = False) -> str:
    """A new empty temporary file (or, with ``is_folder``, folder) ``.plantlod-*SUFFIX`` in
    ``folder``, registered for `remove_pending` BEFORE it is made: a signal can then never find
    it made and not yet registered. tempfile.mkstemp made it first and `hold` came after, and
    a signal between the two left it behind (8 of 120 interrupted runs, session 38). Made
    with O_EXCL (mode 0o600) or os.mkdir (0o700), as mkstemp and mkdtemp make theirs; a name
    taken already is passed over. OSError as the system gives it (naming the temporary)."""
    for _ in range(TEMPORARY_NAME_TRIES):
        path = os.path.join(folder, f"{TEMPORARY_PREFIX}{secrets.token_hex(6)}{suffix}")
        hold(path)
        try:
            if is_folder:
                os.mkdir(path, 0o700)
            else:
                os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
            return path
        except FileExistsError:
            release(path)
        except BaseException:
            release(path)
            raise
    raise FileExistsError(errno.EEXIST, "no new temporary name is free", folder)


def hold(path: str) -> None:
    """Register a temporary file or folder for `remove_pending`."""
    _pending.add(path)


def release(path: str) -> None:
    _pending.discard(path)


def hold_child(proc) -> None:
    """Register a worker process (a `subprocess.Popen`) for `remove_pending` to end."""
    _children.add(proc)


def release_child(proc) -> None:
    _children.discard(proc)


def _reap(pid: int, seconds: float = 2.0) -> None:
    """Wait up to ``seconds`` for the killed child ``pid`` to end and reap it: os.waitpid
    itself, since the interrupted thread may hold the Popen's own wait lock (its wait()
    would spin out the time and leave a zombie)."""
    import time

    end = time.monotonic() + seconds
    while True:
        try:
            done, _status = os.waitpid(pid, os.WNOHANG)
        except (ChildProcessError, OSError):     # reaped already (by its Popen)
            return
        if done or time.monotonic() > end:
            return
        time.sleep(0.005)


def remove_pending() -> None:
    """End every registered worker process (killed and reaped, so none outlives the command,
    not even as a zombie its new parent has yet to reap), then remove every registered
    temporary file and folder (a signal handler calls this)."""
    for proc in list(_children):
        with contextlib.suppress(OSError):
            proc.kill()
    for proc in list(_children):
        _reap(proc.pid)
    for path in list(_pending):
        if os.path.isdir(path) and not os.path.islink(path):
            remove_folder(path)
        else:
            with contextlib.suppress(OSError):
                os.unlink(path)


def remove_folder(path: str) -> None:
    """Remove the folder ``path`` and everything in it, where other processes may still be
    writing into it (a Dask worker's chunks of a scene's store, `scene.rooted_store`): it is
    renamed first, atomically, so that a write by its old name finds no folder (and a
    `RootedStore` makes none), and then removed under the new name, where nothing writes.
    A removal in place could meet a file made in a subfolder it had emptied and leave it."""
    gone = f"{path}.removed-{os.getpid()}"
    try:
        os.rename(path, gone)
    except OSError:                            # (gone already, or the name is taken)
        gone = path
    shutil.rmtree(gone, ignore_errors=True)


def special_target(path: str) -> bool:
    """True when ``path`` exists and is not a regular file (``/dev/null``, a FIFO, a tty).

    Such a target must be written in place: renaming a temporary file over it would
    replace the device or pipe with a regular file (as root, /dev/full itself). A
    directory, or a name the system refuses, is an InputError.
    """
    import stat

    from plantlod.lsys.errors import InputError

    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return False
    except (OSError, ValueError) as exc:      # a name too long, a loop of links, a NUL byte
        raise InputError(f"cannot write: {getattr(exc, 'strerror', None) or exc}", path) from None
    if stat.S_ISDIR(mode):
        raise InputError("is a directory; expected the name of a file to write", path)
    return not stat.S_ISREG(mode)


def landing(output: str) -> str:
    """Where writing ``output`` lands: its folder resolved, its own name kept (a temporary is
    renamed over it, so a link there is replaced, not followed)."""
    return os.path.join(os.path.realpath(os.path.dirname(os.path.abspath(output))),
                        os.path.basename(os.path.abspath(output)))


def lands_on(output: str, source: str) -> bool:
    """Whether writing ``output`` would replace the file ``source`` is read from."""
    return os.path.exists(source) and landing(output) == os.path.realpath(source)


@contextlib.contextmanager
def atomic_path(path: str, suffix: str = ".tmp") -> Iterator[str]:
    """A temporary path beside ``path`` to write to; renamed to ``path`` (with the usual
    permissions) when the block ends normally, removed on any exception, and by
    `remove_pending` on a signal. ``suffix`` keeps an extension for writers that choose
    the format by it (OpenUSD). A `special_target` (a device, a pipe) is given itself,
    written in place."""
    if special_target(path):
        yield path
        return
    folder = os.path.dirname(os.path.abspath(path))
    try:
        tmp = new_temporary(folder, suffix)            # (registered for remove_pending)
    except OSError as exc:                  # (named by the target, not the temporary's name)
        raise OSError(exc.errno, exc.strerror, path) from None
    try:
        yield tmp
        os.chmod(tmp, usual_file_mode())
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.filename == tmp:   # a write to the temporary failed
            raise OSError(exc.errno, exc.strerror, path) from None
        raise
    finally:
        release(tmp)


def write_all(stream, data, name: str | None = None) -> None:
    """Write every byte of ``data`` (bytes-like) to the binary ``stream`` or raise OSError: a
    write that takes only part (a short count, a disk filling up) is continued, and one that
    takes nothing is ENOSPC (``name``: the file, for the message)."""
    view = memoryview(data).cast("B")
    while len(view):
        n = stream.write(view)
        if not n:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), *([name] if name else []))
        view = view[n:]


def write_whole(path: str, data: bytes) -> None:
    """Write ``data`` to ``path``, every byte or an OSError naming ``path`` (`write_all`; a
    write to /dev/full raised ENOSPC naming no file)."""
    try:
        with open(path, "wb", buffering=0) as out:
            write_all(out, data, path)
    except OSError as exc:
        if exc.filename is not None:
            raise
        raise OSError(exc.errno, exc.strerror or str(exc), path) from None
