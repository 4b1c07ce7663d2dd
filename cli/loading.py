"""Reading the inputs commands share: .lsys files and tree files (by content, not name)."""

from __future__ import annotations

import dataclasses

from plantlod.formats.kinds import looks_like_tree_file
from plantlod.lsys.errors import InputError

from .io import display_name, read_text


def load_system(path: str):
    """Parse an .lsys file (``-``: stdin) into an `LSystem` (a tree file is refused by what
    it is, `formats.lsys_file.parse_lsys_text`)."""
    from plantlod.formats.lsys_file import parse_lsys_text

    return parse_lsys_text(read_text(path), display_name(path))


def load_tree(path: str, steps: int | None = None, max_modules: int | None = None,
              run=None):
    """A `Tree` from an .lsys file (derived here) or a tree file; ``-`` reads stdin.

    Returns (tree, system): system is None for a tree file. ``run``: the settings
    (`sim_options.SimulationSettings`) the tree is about to be simulated with; where the
    file is a level whose simplify header says it was fitted at another dt or damping
    ratio (`formats.level_header`), a warning says so once the run goes on.
    """
    name = display_name(path)
    from plantlod.formats.npz import is_npz

    if is_npz(path):
        if steps is not None:
            raise InputError("-n applies to .lsys input, not to a tree archive", name)
        from plantlod.formats.npz import read_npz_file, read_tree_bytes

        return read_tree_bytes(read_npz_file(path), name).named(name), None
    text = read_text(path)
    if looks_like_tree_file(text):
        if steps is not None:
            raise InputError("-n applies to .lsys input, not to a tree file", name)
        from plantlod.formats.treefile import read_tree_text

        return read_tree_text(text, name).named(name), None
    from plantlod.formats.lsys_file import parse_lsys_text
    from plantlod.lsys.build import build
    from plantlod.lsys.constants import DEFAULT_MAX_MODULES

    from plantlod.formats.level_header import leading_comment

    # (the header simplify wrote, kept as an `LSystem` from `plantlod.simplify` keeps it: its
    # fit conditions and source are read from it, the file read once)
    system = dataclasses.replace(parse_lsys_text(text, name), comment=leading_comment(text))
    if run is not None:
        _warn_fitted_otherwise(system.comment, name, run)
    built = build(system, steps, max_modules=max_modules or DEFAULT_MAX_MODULES)
    from .io import warn_once_running

    for message in built.warnings:
        warn_once_running(f"{name}: {message}")
    return built.tree, system


def _warn_fitted_otherwise(comment: str, name: str, run) -> None:
    """A warning where a level's header ``comment`` (`formats.level_header`) names another dt
    or damping ratio than ``run``'s: a level holds under the conditions it was fitted at
    (its periods move with dt, model.md 4), and the file's parameters cannot say them."""
    from plantlod.formats.level_header import CLI_SPELLING, comment_conditions

    fitted = comment_conditions(comment)
    if fitted is None:
        return
    message = fitted.said(name, run.dt, float(getattr(run.damping, "c", 0.0)),
                          float(getattr(run.damping, "ratio", 0.0)), CLI_SPELLING)
    if message is not None:
        from .io import warn_once_running

        warn_once_running(message)
