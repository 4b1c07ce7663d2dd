"""Golden-file comparison for command outputs.

Usage in a test (the test's name must contain "golden" so that ``make golden``,
which runs ``pytest -k golden`` with PLANTLOD_REGEN_GOLDEN=1, regenerates it)::

    from golden_util import assert_golden, run_cli

    def test_derive_stalk8_golden():
        result = run_cli("derive", "examples/stalk8.lsys")
        assert_golden("derive_stalk8.jsonl", result.stdout)

Behaviour of ``assert_golden(name, text)``:

- ``PLANTLOD_REGEN_GOLDEN=1`` in the environment: (re)write
  ``tests/golden/<name>`` with ``text`` and pass.
- golden file missing: fail, telling the reader to run ``make golden``.
- golden file differs (byte for byte, after UTF-8 encoding; no newline
  translation): write ``tests/golden/<name>.obtained`` beside it (git-ignored)
  and fail with a short unified diff.
- golden file equal: pass, and remove a stale ``.obtained`` file if present.

``run_cli(*args, input=None, exit_code=0)`` runs ``plantlod ARGS`` in-process
(click's CliRunner, stdout and stderr kept apart) from the repository root, so
that paths like ``examples/stalk8.lsys`` (which the tree file's ``source`` and
messages repeat) are the same on every machine; it checks the exit code and
returns the click ``Result``.
"""

from __future__ import annotations

import contextlib
import difflib
import os
import re
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
GOLDEN_DIR = ROOT / "tests" / "golden"
REGEN_VARIABLE = "PLANTLOD_REGEN_GOLDEN"
# Lines of unified diff shown in a failure message before it is cut short.
MAX_DIFF_LINES = 40



def family_tree(kind: str, seed: int):
    """(system, tree) of the generated family's tree ``kind``-``seed`` (bench/tree_family.py)."""
    import sys

    from plantlod.lsys.build import build
    from plantlod.lsys.parse import parse_lsys

    if str(ROOT / "bench") not in sys.path:
        sys.path.insert(0, str(ROOT / "bench"))
    import tree_family

    system = parse_lsys(tree_family.generate(kind, seed), f"{kind}-{seed}")
    return system, build(system).tree

def golden_path(name: str) -> pathlib.Path:
    """Path of the golden file ``tests/golden/<name>`` (``name`` may hold sub-folders)."""
    if not name or pathlib.PurePath(name).is_absolute() or ".." in pathlib.PurePath(name).parts:
        raise ValueError(f"golden name must be a relative path inside tests/golden, got {name!r}")
    return GOLDEN_DIR / name


def regenerating() -> bool:
    """True when golden files are being rewritten (PLANTLOD_REGEN_GOLDEN=1)."""
    return os.environ.get(REGEN_VARIABLE, "") == "1"


def _short_diff(expected: str, obtained: str, name: str) -> str:
    diff = list(
        difflib.unified_diff(
            expected.splitlines(keepends=True),
            obtained.splitlines(keepends=True),
            fromfile=f"golden/{name}",
            tofile=f"golden/{name}.obtained",
            n=1,
        )
    )
    if not diff:  # same lines, different bytes (line endings, final newline)
        return "(texts differ only in line endings or the final newline)\n"
    shown = diff[:MAX_DIFF_LINES]
    if len(diff) > MAX_DIFF_LINES:
        shown.append(f"... ({len(diff) - MAX_DIFF_LINES} more diff lines)\n")
    return "".join(line if line.endswith("\n") else line + "\n" for line in shown)


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def same_but_numbers(expected: str, obtained: str, rel: float) -> bool:
    """True when the two texts are equal once every number is replaced by a
    placeholder, and each pair of numbers agrees within ``rel`` relative to the
    larger of the two (absolute ``rel`` for numbers below 1 in size)."""
    if _NUMBER.sub("#", expected) != _NUMBER.sub("#", obtained):
        return False
    a = [float(x) for x in _NUMBER.findall(expected)]
    b = [float(x) for x in _NUMBER.findall(obtained)]
    return all(abs(x - y) <= rel * max(1.0, abs(x), abs(y)) for x, y in zip(a, b))


def assert_golden(name: str, text: str, rel: float | None = None) -> None:
    """Compare ``text`` with ``tests/golden/<name>`` byte for byte (see module docstring).

    With ``rel``, numbers may differ by that relative amount (the text around them
    must still match exactly): for files whose values come out of an iterative
    optimiser, whose last digits depend on the scipy/BLAS build.
    """
    if not isinstance(text, str):
        raise TypeError(f"assert_golden expects str text, got {type(text).__name__}")
    path = golden_path(name)
    obtained_path = path.with_name(path.name + ".obtained")
    data = text.encode("utf-8")
    if regenerating():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
        obtained_path.unlink(missing_ok=True)
        return
    if not path.exists():
        pytest.fail(
            f"golden file tests/golden/{name} is missing; run `make golden` to create it "
            f"and review it before committing",
            pytrace=False,
        )
    expected = path.read_bytes()
    if expected == data or (rel is not None and same_but_numbers(
            expected.decode("utf-8", errors="replace"), text, rel)):
        obtained_path.unlink(missing_ok=True)
        return
    obtained_path.write_bytes(data)
    diff = _short_diff(expected.decode("utf-8", errors="replace"), text, name)
    pytest.fail(
        f"output differs from golden file tests/golden/{name} "
        f"(obtained output written to tests/golden/{name}.obtained; "
        f"if the change is intended, run `make golden` and review the diff)\n{diff}",
        pytrace=False,
    )


@contextlib.contextmanager
def _working_directory(path: pathlib.Path):
    before = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(before)


def run_cli(*args: str, input: str | bytes | None = None, exit_code: int | None = 0,
            cwd: pathlib.Path | None = None):
    """Run ``plantlod ARGS`` in-process from ``cwd`` (default: the repository root).

    ``exit_code`` None skips the check; otherwise a different exit code fails
    the test with the command's stderr. Returns the click ``Result``
    (``.stdout``, ``.stderr``, ``.exit_code``, ``.exception``).
    """
    from click.testing import CliRunner

    from plantlod.cli.main import cli

    with _working_directory(cwd or ROOT):
        result = CliRunner().invoke(cli, list(args), input=input, catch_exceptions=True,
                                    prog_name="plantlod")
    if exit_code is not None and result.exit_code != exit_code:
        detail = result.stderr.strip() or repr(result.exception)
        pytest.fail(f"plantlod {' '.join(args)} exited {result.exit_code}, expected {exit_code}: "
                    f"{detail}", pytrace=False)
    return result
