"""Reading the inputs commands share: .lsys files and tree files (by content, not name)."""

from __future__ import annotations

from plantlod.lsys.errors import InputError

from .io import display_name, read_text


def load_system(path: str):
    """Parse an .lsys file (``-``: stdin) into an `LSystem` (a tree file is refused by what
    it is, `formats.lsys_file.parse_lsys_text`)."""
    from plantlod.formats.lsys_file import parse_lsys_text

    return parse_lsys_text(read_text(path), display_name(path))


def looks_like_tree_file(text: str) -> bool:
    """Tree files are JSON Lines: their first non-blank character is ``{``."""
    stripped = text.lstrip()
    return stripped.startswith("{")


def load_tree(path: str, steps: int | None = None, max_modules: int | None = None):
    """A `Tree` from an .lsys file (derived here) or a tree file; ``-`` reads stdin.

    Returns (tree, system): system is None for a tree file.
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

    system = parse_lsys_text(text, name)
    built = build(system, steps, max_modules=max_modules or DEFAULT_MAX_MODULES)
    from .io import warn_once_running

    for message in built.warnings:
        warn_once_running(f"{name}: {message}")
    return built.tree, system
