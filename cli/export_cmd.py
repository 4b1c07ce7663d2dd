"""`plantlod export`: one tree's motion as glTF or OpenUSD (docs/export.md)."""

from __future__ import annotations

import click

from .io import (check_output_path, display_name, distinct_paths, large_file_angles, say, warn,
                 write_errors)
from .loading import load_tree
from plantlod.lsys.words import counted


@click.command(name="export")
@click.argument("tree_path", metavar="TREE")
@click.argument("angles_path", metavar="ANGLES.csv")
@click.option("-o", "--output", required=True, metavar="OUT",
              help="OUT.glb, OUT.gltf, OUT.usda, OUT.usdc or OUT.usd (binary USD): the format from "
                   "the extension.")
@click.option("--fps", type=click.FloatRange(min=0, min_open=True, max=1000), default=30.0,
              show_default=True, help="Frames per second (angles resampled linearly).")
@click.option("--frames", "frames_text", default=None, metavar="A:B",
              help="Only frames A to B-1 (time restarts at 0).")
@click.option("--degrees", is_flag=True, help="ANGLES holds degrees.")
def export(tree_path, angles_path, output, fps, frames_text, degrees):
    """Write the motion of TREE (an .lsys, a level file, or a tree file) from ANGLES.csv
    (`plantlod simulate`'s output) as glTF 2.0 or OpenUSD.

    \b
    Example:
      plantlod simulate examples/stalk8.lsys --dt 0.01 --duration 5 --wind-speed 5 -o s.csv
      plantlod export examples/stalk8.lsys s.csv -o stalk8.glb
    """
    from plantlod.export.files import export_animation
    from plantlod.formats.angles_csv import read_angles_file
    from plantlod.compare.runs import angles_in_tree_order

    if output == "-":                             # (README: - is stdout elsewhere)
        raise click.UsageError("-o -: export takes the format from the file name's extension, "
                               "and standard output has none; expected -o OUT.glb (or .gltf, "
                               ".usda, .usdc, .usd)")
    check_output_path(output)                     # a missing folder is refused before any work
    distinct_paths({"-o": output}, {"TREE": tree_path, "ANGLES": angles_path})
    frames = None
    if frames_text is not None:
        try:
            a, b = (int(x) for x in frames_text.split(":"))
        except ValueError:
            raise click.BadParameter("expected A:B, two whole numbers", param_hint="--frames") from None
        if not 0 <= a < b:
            raise click.BadParameter("expected 0 <= A < B", param_hint="--frames")
        frames = (a, b)
    tree, _ = load_tree(tree_path)
    times, addresses, bend, rot = read_angles_file(angles_path, degrees)
    bend, rot = angles_in_tree_order(tree, addresses, bend, rot, display_name(angles_path))
    with write_errors(output):                    # (a name the system refuses: bad input, as
        export_animation(output, tree, times, bend, rot, fps, frames,   # every command's -o)
                         display_name(angles_path), display_name(tree_path))
    # (after the export: an angle file it refuses gets its one error line alone)
    large = large_file_angles(times, bend, rot, tree.address, display_name(angles_path), degrees)
    if large is not None:
        warn(large)
    span = (f"{times[-1]:g} s at {fps:g} fps" if frames is None else      # (time restarts at 0)
            f"frames {frames[0]}:{frames[1]} ({frames[1] - frames[0]:,} frames, "
            f"{(frames[1] - frames[0] - 1) / fps:g} s) at {fps:g} fps")
    say(f"export: {display_name(tree_path)}: {counted(tree.n_branches, 'branch')}, {span} -> {output}")
