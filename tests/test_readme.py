"""The README runs as written (issue 24): every ```sh and ```python block, in order, from a
folder holding the repository's examples (as a fresh clone's root does), with the
virtual environment's `plantlod` on PATH as the README says. ```text blocks are
synopses and are not run.

A block after a line ``<!-- readme-test: long -->`` takes minutes (a first scene, `make
demo`); it runs only in `make test-slow` (pytest --run-long), in a fresh clone of HEAD.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest

from golden_util import ROOT

BLOCK = re.compile(r"(<!-- readme-test: (\w+) -->\n)?```(sh|python)\n(.*?)```", re.S)


def blocks(long: bool) -> list[tuple[str, str, int]]:
    """(language, code, line) of the README's runnable blocks, long or not."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    out = []
    for m in BLOCK.finditer(text):
        if (m.group(2) == "long") == long:
            out.append((m.group(3), m.group(4), text.count("\n", 0, m.start(3)) + 1))
    return out


def run_block(language: str, code: str, line: int, cwd, timeout: int, root=ROOT) -> None:
    """Run one block in ``cwd`` with ``root``'s .venv/bin first on PATH."""
    venv = root / ".venv" / "bin"
    env = dict(os.environ, PATH=f"{venv}{os.pathsep}{os.environ['PATH']}")
    env.pop("PLANTLOD_DEBUG", None)
    env.pop("VIRTUAL_ENV", None)
    python = str(venv / "python") if (venv / "python").exists() else sys.executable
    command = (["bash", "-e", "-c", code] if language == "sh" else [python, "-c", code])
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)
    assert done.returncode == 0, (f"README.md:{line}: the {language} block ended "
                                  f"{done.returncode}:\n{done.stdout[-2000:]}\n"
                                  f"{done.stderr[-3000:]}")
    assert "Traceback" not in done.stderr and "error:" not in done.stderr, done.stderr[-3000:]


def test_the_readme_has_runnable_blocks():
    assert len(blocks(False)) >= 4 and blocks(True)
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    for m in re.finditer(r"```text\n(.*?)```", text, re.S):     # synopses, not commands
        for line in m.group(1).splitlines():
            assert not re.match(r"\s*plantlod \w+ (examples/|[\w.-]+\.(lsys|glb|csv))", line), (
                f"a runnable command in a ```text block (make it ```sh): {line}")


def test_every_short_block_runs_as_written(tmp_path):
    # what a fresh clone's root holds after `make`: the examples, the bench scripts, .venv
    for name in ("examples", "bench", ".venv"):
        (tmp_path / name).symlink_to(ROOT / name)
    for language, code, line in blocks(False):
        run_block(language, code, line, tmp_path, timeout=600)


@pytest.mark.long
def test_every_long_block_runs_as_written_in_a_fresh_clone(tmp_path):
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
    # the first long block is the quick start: its `make demo` builds the clone's .venv
    for language, code, line in blocks(True):
        run_block(language, code, line, clone, timeout=3600, root=clone)


def test_the_forest_figures_in_the_prose_are_the_tables():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    prose = re.search(r"forest\.toml --verify --report -` \(1,000 trees.*?\): ([\d.]+)× fewer "
                      r"branch-steps than full detail at a\s+verified largest error of ([\d.]+) px"
                      r".*?simulated ([\d.]+)× faster than real time", text, re.S)
    assert prose, "the forest sentence of the scene section"
    speedup = re.search(r"\| forest \(examples/forest\.toml.*?full / spent \| ([\d.]+) ×", text)
    error = re.search(r"\| forest: verified max error \(`--verify`\) \| ([\d.]+) px", text)
    rate = re.search(r"\| forest at its levels: simulated seconds per wall second \| ([\d.]+) \|",
                     text)
    assert (speedup.group(1), error.group(1), rate.group(1)) == prose.groups()
