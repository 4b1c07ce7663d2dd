"""Shared fixtures: paths to the bundled examples and a CLI runner."""

from __future__ import annotations

import pathlib

import pytest

import plantlod  # noqa: F401  (first, before numpy: it pins OpenBLAS's kernels, plantlod/blas_kernels.py)

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


def _signals_as_a_terminal_has_them() -> None:
    """SIGHUP, SIGINT, SIGQUIT and SIGTERM back to their defaults where the shell that started
    the tests ignored them (``nohup make test &``: nohup ignores SIGHUP, and a non-interactive
    shell's background job SIGINT and SIGQUIT). An ignored signal stays ignored in every child,
    and plantlod keeps it ignored, as a command started with nohup should, so the tests that
    send a command a signal and expect exit 128 + n saw exit 0 instead, or waited out their
    timeout for a run that went on (SIGQUIT, session 32: two fresh-clone runs started in the
    background)."""
    import signal

    for signum in (signal.SIGHUP, signal.SIGINT, signal.SIGQUIT, signal.SIGTERM):
        if signal.getsignal(signum) == signal.SIG_IGN:
            signal.signal(signum, signal.default_int_handler if signum == signal.SIGINT
                          else signal.SIG_DFL)


_signals_as_a_terminal_has_them()


@pytest.fixture
def examples_dir() -> pathlib.Path:
    return EXAMPLES


@pytest.fixture
def runner():
    from click.testing import CliRunner

    return CliRunner()


def pytest_addoption(parser):
    parser.addoption("--run-long", action="store_true", default=False,
                     help="also run the tests marked long (make test-slow)")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--run-long"):
        return
    skip = pytest.mark.skip(reason="takes minutes: make test-slow (pytest --run-long)")
    for item in items:
        if "long" in item.keywords:
            item.add_marker(skip)
