"""The ``plantlod`` command: a click group whose subcommands live in their own modules.

Exit codes: 0 success; 1 runtime failure (a diverging simulation, a bound exceeded
in `compare`); 2 bad input or usage (one line naming file, line and column).
"""

from __future__ import annotations

import importlib
import signal
import sys
from collections.abc import MutableMapping

import click

from .discipline import (
    ReaderGone, Terminated, harden_params, install_signal_handlers, run_guarded,
    set_current_command,
)

# command -> the module of cli/ that defines it; a command's module (and what it
# imports) loads only when that command runs or --help lists them all
COMMAND_MODULES = {"derive": "derive_cmd", "simulate": "simulate_cmd",
                   "simplify": "simplify_cmd", "compare": "compare_cmd", "scene": "scene_cmd",
                   "export": "export_cmd", "view": "view_cmd"}


class LazyCommands(MutableMapping):
    """The group's name -> command mapping, importing a command's module on first use."""

    def __init__(self, modules: dict[str, str]):
        self._modules = dict(modules)
        self._loaded: dict[str, click.Command] = {}

    def __getitem__(self, name):
        if name not in self._loaded:
            if name not in self._modules:
                raise KeyError(name)
            module = importlib.import_module(f"{__package__}.{self._modules[name]}")
            self._loaded[name] = getattr(module, name)
        return self._loaded[name]

    def __setitem__(self, name, command):
        self._loaded[name] = command
        self._modules.setdefault(name, "")

    def __delitem__(self, name):
        del self._modules[name]
        self._loaded.pop(name, None)

    def __iter__(self):
        return iter(self._modules)

    def __len__(self):
        return len(self._modules)

    def __contains__(self, name):
        return name in self._modules


class PlantlodGroup(click.Group):
    """The group every command hangs on; it applies the error discipline of
    `cli.discipline` to all of them (exit codes, one-line messages, signals,
    bounded numeric options), so a new command inherits it by being added."""

    def resolve_command(self, ctx, args):
        name, command, rest = super().resolve_command(ctx, args)
        set_current_command(name)
        return name, (_checks_first(harden_params(command)) if command is not None else None), rest

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            # as a signal, past click's Abort (which would print a blank line first)
            raise _named(Terminated(signal.SIGINT), ctx) from None
        except BrokenPipeError:
            # stdout's reader went away (stderr cannot raise: `discipline.QuietStream`); past
            # click, which would make it exit 1
            raise _named(ReaderGone(), ctx) from None
        except BaseException as exc:
            raise _named(exc, ctx)

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True,
             **extra):
        code = run_guarded(lambda: super(PlantlodGroup, self).main(
            args, prog_name, complete_var, standalone_mode=False, **extra),
            prog_name or "plantlod")
        if standalone_mode:
            sys.exit(code)
        return code


def _checks_first(command: click.Command) -> click.Command:
    """``command`` running `sim.engine_env.check_environment` once its options are parsed (so that --help
    still answers), before its own code: every command refuses the same bad settings alike."""
    if getattr(command, "_plantlod_env_checked", False):
        return command
    own = command.invoke

    def invoke(ctx):
        from plantlod.sim.engine_env import check_environment

        check_environment()
        return own(ctx)

    command.invoke = invoke
    command._plantlod_env_checked = True
    return command


def _named(exc: BaseException, ctx) -> BaseException:
    """Tag an exception with the subcommand it ended, for its one-line message."""
    if getattr(exc, "plantlod_command", None) is None:
        exc.plantlod_command = ctx.invoked_subcommand
    return exc


@click.group(cls=PlantlodGroup, commands=LazyCommands(COMMAND_MODULES),
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="plantlod")
def cli():
    """Wind-blown L-system trees with levels of detail.

    \b
    The commands (each `plantlod CMD --help` says more):
      derive    L-system -> branch tree (JSON Lines)
      simulate  wind model -> angle CSV
      simplify  level-n L-system that sways like the original
      compare   amplitude, period and tip errors; OBJ frames and pictures
      scene     many trees, each at the level its camera distance allows
      export    one tree's motion as glTF or OpenUSD
      view      an HTML page playing exported trees side by side

    \b
    Example:
      plantlod derive examples/stalk8.lsys | plantlod simulate - --dt 0.01 --steps 1000 --wind-speed 5
      plantlod simplify examples/stalk8.lsys --level 1 -o stalk4.lsys
      plantlod compare examples/stalk8.lsys stalk4.lsys --dt 0.01 --duration 20 --wind-speed 5
    """


def main() -> None:
    from plantlod.sim.heap import return_large_arrays

    install_signal_handlers()
    return_large_arrays()          # a command's freed arrays go back to the system (sim/heap.py)
    cli(prog_name="plantlod")


if __name__ == "__main__":
    main()
