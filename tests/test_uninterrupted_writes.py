"""A signal during a block of writes that must not be cut (formats.atomic.uninterrupted):
held until the block ends, then handled as any signal (session 26: `scene --angles`
interrupted while zarr wrote chunks on its I/O thread left a `.plantlod-*.zarr` behind,
the chunks in flight landing after the handler had removed the folder)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

from plantlod.formats import atomic


def test_a_signal_in_the_block_is_held_until_it_ends(monkeypatch):
    ended = []
    monkeypatch.setattr(atomic, "end_deferred", [ended.append])
    monkeypatch.setattr(atomic, "_deferred", [])
    assert not atomic.defer_signal(signal.SIGINT)            # no block open: handled now
    with atomic.uninterrupted():
        with atomic.uninterrupted():                         # (blocks nest)
            assert atomic.defer_signal(signal.SIGTERM)
        assert ended == []                                   # the outer block is still open
    assert ended == [signal.SIGTERM]


def test_the_command_ends_after_the_writes_and_removes_what_they_wrote(tmp_path):
    # the CLI's handler, a pending folder, a signal in the middle of an uninterrupted block
    # whose writes go on after it: every write is made (the log beside the folder says so),
    # then exit 130 with one line, and no folder is left (the last write's included)
    script = textwrap.dedent(f"""
        import os, signal, tempfile
        from plantlod.cli import discipline
        from plantlod.formats import atomic
        discipline.set_current_command("scene")
        discipline.install_signal_handlers()
        folder = tempfile.mkdtemp(prefix=".plantlod-", dir={str(tmp_path)!r})
        atomic.hold(folder)
        with atomic.uninterrupted():
            os.kill(os.getpid(), signal.SIGINT)
            for k in range(50):                      # writes after the signal
                with open(os.path.join(folder, f"chunk{{k}}"), "w") as f:
                    f.write("x")
                with open({str(tmp_path / "log.txt")!r}, "a") as log:
                    log.write(f"{{k}}\\n")
        print("not reached")
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 128 + signal.SIGINT, run.stderr
    assert run.stderr.splitlines() == ["plantlod scene: interrupted"]
    assert "not reached" not in run.stdout
    assert (tmp_path / "log.txt").read_text().split() == [str(k) for k in range(50)]
    assert os.listdir(tmp_path) == ["log.txt"]
