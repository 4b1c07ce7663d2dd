"""The ``plantlod`` command: a click group whose subcommands live in their own modules.

Exit codes: 0 success; 1 runtime failure (a diverging simulation, a bound exceeded
in `compare`); 2 bad input or usage (one line naming file, line and column).
"""

from __future__ import annotations

import signal
import sys

import click

from plantlod.lsys.errors import InputError, PlantlodError

from .compare_cmd import compare
from .derive_cmd import derive
from .simplify_cmd import simplify
from .simulate_cmd import simulate


class PlantlodGroup(click.Group):
    """Turns every `PlantlodError` into one line on stderr and its exit code."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except PlantlodError as exc:
            click.echo(f"{format_error(exc, ctx)}", err=True)
            ctx.exit(exc.exit_code)
        except BrokenPipeError:
            _quiet_broken_pipe()


def format_error(exc: PlantlodError, ctx) -> str:
    """One line: ``file:line:col: error: message`` (compiler style, so editors can
    jump to it) when the error has a place, else ``plantlod CMD: error: message``."""
    if isinstance(exc, InputError) and exc.file:
        loc = ":".join(str(p) for p in (exc.file, exc.line, exc.col) if p is not None)
        return f"{loc}: error: {exc.message}"
    name = ctx.invoked_subcommand or ctx.info_name or "plantlod"
    return f"plantlod {name}: error: {exc}"


def _quiet_broken_pipe() -> None:
    """The reader went away (``| head``): stop quietly, as other Unix tools do."""
    try:
        sys.stdout.close()
    except Exception:
        pass
    sys.exit(0)


@click.group(cls=PlantlodGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="plantlod")
def cli():
    """Wind-blown L-system trees with levels of detail.

    \b
    A pipeline of four commands:
      derive    L-system -> branch tree (JSON Lines)
      simulate  wind model -> angle CSV
      simplify  level-n L-system that sways like the original
      compare   amplitude, period and tip errors; OBJ frames and pictures

    \b
    Example:
      plantlod derive examples/stalk8.lsys | plantlod simulate - --dt 0.01 --steps 1000 --wind-speed 5
      plantlod simplify examples/stalk8.lsys --level 1 -o stalk4.lsys
      plantlod compare examples/stalk8.lsys stalk4.lsys --dt 0.01 --duration 20 --wind-speed 5
    """


for command in (derive, simulate, simplify, compare):
    cli.add_command(command)


def main() -> None:
    # Writing into a closed pipe ends the process quietly instead of raising.
    if hasattr(signal, "SIGPIPE"):
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    cli(prog_name="plantlod")


if __name__ == "__main__":
    main()
