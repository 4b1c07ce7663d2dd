"""`plantlod derive`: expand an L-system into its branch tree (or its derived string)."""

from __future__ import annotations

import time

import click

from plantlod.lsys.constants import DEFAULT_MAX_MODULES
from plantlod.formats.kinds import OUTPUT_KINDS

from .io import (check_output_kind, check_output_path, count, display_name, distinct_paths,
                 open_output, say, warn_once_running)
from .loading import load_system


@click.command()
@click.argument("file", metavar="FILE|-")
@click.option("-o", "--output", "output", metavar="OUT", default=None,
              help="Write here instead of stdout (atomically).")
@click.option("--format", "fmt", type=click.Choice(["tree", "string"]), default="tree",
              show_default=True,
              help="tree: the branch tree as JSON Lines (docs/tree-format.md); "
                   "string: the derived string in ABOP notation.")
@click.option("-n", "--derivation-length", "--steps", "steps", type=click.IntRange(min=0),
              default=None, help="Derivation length (default: the file's derivation_length; "
              "--derivation-length as simulate and compare name it, --steps its older name).")
@click.option("--max-modules", type=click.IntRange(min=1), default=DEFAULT_MAX_MODULES,
              show_default=True, help="Stop before a step would produce more modules.")
def derive(file, output, fmt, steps, max_modules):
    """Expand an L-system (.lsys) into its branch tree.

    Writes the tree file that `plantlod simulate -` reads, and a one-line summary
    (modules, branches, leaves, depth, seconds) on stderr.

    \b
    Example:
      plantlod derive examples/stalk8.lsys -o stalk8.tree.jsonl
      plantlod derive examples/abop_1_24a.lsys --format string -n 2
      plantlod derive examples/stalk8.lsys | plantlod simulate - --dt 0.01 --steps 400 --wind-speed 5
    """
    from plantlod.formats.npz import is_npz, tree_bytes
    from plantlod.lsys.build import build

    if is_npz(output) and fmt == "string":
        raise click.UsageError("--format string writes text; an .npz archive holds a tree "
                               "(give -o FILE.txt, or drop --format string)")
    distinct_paths({"-o": output}, {"FILE": file})
    if fmt == "string":
        check_output_kind(output, "-o", "the derived string (text)", (".txt",))
    else:
        check_output_kind(output, "-o", *OUTPUT_KINDS["tree"])
    check_output_path(output)                   # (a missing folder: before the derivation)
    start = time.perf_counter()
    system = load_system(file)
    built = build(system, steps, max_modules=max_modules)
    for message in built.warnings:
        warn_once_running(f"{display_name(file)}: {message}")

    if is_npz(output) and fmt == "tree":
        with open_output(output, binary=True) as out:
            out.write(tree_bytes(built.tree))
    else:
        with open_output(output) as out:
            if fmt == "string":
                from plantlod.formats.derived_string import format_derived
                for chunk in format_derived(built.derived):
                    out.write(chunk)
            else:
                from plantlod.formats.treefile import write_tree
                write_tree(built.tree, out)
    tree = built.tree
    seconds = time.perf_counter() - start
    say(f"derive: {count(len(built.derived), 'module')}, {count(tree.n_branches, 'branch')}, "
        f"{count(tree.n_leaves, 'leaf')}, depth {tree.depth()}, {seconds:.3f} s")
