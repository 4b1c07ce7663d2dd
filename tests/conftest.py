"""Shared fixtures: paths to the bundled examples and a CLI runner."""

from __future__ import annotations

import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


@pytest.fixture
def examples_dir() -> pathlib.Path:
    return EXAMPLES


@pytest.fixture
def runner():
    from click.testing import CliRunner

    return CliRunner()
