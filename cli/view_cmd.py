"""`plantlod view`: one self-contained HTML page playing glTF trees side by side."""

from __future__ import annotations

import click

from plantlod.lsys.words import counted
from plantlod.formats.kinds import OUTPUT_KINDS

from .io import check_output_kind, distinct_paths, open_output, say


@click.command(name="view")
@click.argument("gltf_paths", metavar="ORIGINAL.glb [LEVEL.glb ...]", nargs=-1, required=True)
@click.option("-o", "--output", required=True, metavar="PAGE.html",
              help="The page to write (- for stdout).")
@click.option("--wind-direction", type=float, default=0.0, show_default=True,
              help="Where the wind arrow points, in degrees (0 = +x, 90 = +y), as simulate's.")
@click.option("--title", default=None, help="The page's title.")
def view(gltf_paths, output, wind_direction, title):
    """Write one HTML page that plays the trees of ORIGINAL.glb and LEVEL.glb ... side by
    side (play/pause, a time slider, the wind as an arrow, each tree's branch count). The
    page needs no network: three.js and the trees are inside it.

    \b
    Example:
      plantlod simulate examples/stalk8.lsys --dt 0.01 --duration 5 --wind-speed 8 -o s.csv
      plantlod export examples/stalk8.lsys s.csv -o stalk8.glb
      plantlod view stalk8.glb -o stalk8.html
    """
    import math

    from plantlod.api import write_view

    if not math.isfinite(wind_direction):
        raise click.BadParameter("expected a finite number of degrees", param_hint="--wind-direction")
    if "-" in gltf_paths:                     # (it said "-: no such file")
        raise click.UsageError("view reads .glb or .gltf files by name (a .gltf's buffers lie "
                               "beside it); standard input ('-') is not read")
    from plantlod.export.view import files_read

    inputs = {}
    for k, p in enumerate(gltf_paths):           # (a .gltf's buffer file is read too)
        for b, name in enumerate(files_read(p)):
            inputs[f"input {k + 1}" + (f"'s buffer {b}" if b else "")] = name
    distinct_paths({"-o": output}, inputs)
    check_output_kind(output, "-o", *OUTPUT_KINDS["page"])
    with open_output(output) as out:          # refuses a bad target before any work
        write_view(list(gltf_paths), out, wind_direction=wind_direction, title=title)
    say(f"view: {counted(len(gltf_paths), 'tree')} -> {output}")
