"""Shared fixtures: paths to the bundled examples and a CLI runner."""

from __future__ import annotations

import pathlib

import pytest

import plantlod  # noqa: F401  (first, before numpy: it pins OpenBLAS's kernels, plantlod/blas_kernels.py)

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"


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
