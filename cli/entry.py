"""The console script ``plantlod`` (pyproject.toml): a signal while the command is still
starting ends it with one line (`early_signals`), then the click group runs (`main`)."""

from __future__ import annotations


def main() -> None:
    from . import early_signals

    early_signals.install()
    from .main import main as run

    run()
