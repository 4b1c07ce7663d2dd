"""Signals that arrive while the command is still starting (importing click and its own
modules), before `discipline.install_signal_handlers` takes over.

`install` is the first thing the console script does (`cli.entry`), with nothing loaded but
the standard library and the signal list: a SIGINT in that window printed a
KeyboardInterrupt traceback, and a SIGTERM or SIGHUP ended the process without a line. No
file can be half written yet, so the handler only says why and exits 128 + n. (Importing
`cli.main`, as tests and benchmarks do, installs nothing.)
"""

from __future__ import annotations

import os
import signal

from plantlod.sim.constants import CAUGHT_SIGNALS


def _end_early(signum, _frame) -> None:
    why = "interrupted" if signum == signal.SIGINT else f"ended by {signal.Signals(signum).name}"
    try:
        os.write(2, f"plantlod: {why}\n".encode())
    except OSError:
        pass
    os._exit(128 + signum)


def install() -> None:
    """`_end_early` for every caught signal the parent did not ignore (nohup's SIGHUP)."""
    for signum in CAUGHT_SIGNALS:
        if signal.getsignal(signum) != signal.SIG_IGN:
            signal.signal(signum, _end_early)
