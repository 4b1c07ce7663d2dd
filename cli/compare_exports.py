"""`plantlod compare`'s exports: OBJ frames of the posed trees side by side and the PNG
(docs/compare.md, "OBJ files" and "The plot"). Every picture time is checked and the PNG
rendered (`prepare_pictures`) before the command writes its first output."""

from __future__ import annotations

import os
import re

from plantlod.lsys.errors import InputError
from plantlod.lsys.words import counted
from plantlod.compare.constants import DEFAULT_PLOT_TIME

from .io import open_output, output_folder, say


# the OBJ frames' names (`write_pictures`): at a time (--at), and numbered (--every)
FRAME_AT = "frame_t{:g}.obj"
FRAME_NUMBERED = "frame_{:05d}.obj"
FRAME_NAME = re.compile(r"frame_(t.+|[0-9]{5,})\.obj")


def is_frame_in(path: str, folder: str) -> bool:
    """Whether ``path`` lies in ``folder`` under a name the OBJ frames take (FRAME_NAME)."""
    here = os.path.realpath(os.path.dirname(os.path.abspath(path)))
    return (here == os.path.realpath(folder)
            and FRAME_NAME.fullmatch(os.path.basename(path)) is not None)


def _sample_index(times, t: float, option: str) -> int:
    """The sample nearest to t (the earlier of two equally near); InputError outside the run."""
    import numpy as np

    if not times[0] - 1e-9 <= t <= times[-1] + 1e-9:
        raise InputError(f"{option} {t:g} s is outside the run, {times[0]:g} to {times[-1]:g} s; "
                         f"expected a time inside it")
    k = int(np.searchsorted(times, t))
    if k == len(times) or (k > 0 and t - times[k - 1] <= times[k] - t):
        k -= 1
    return k


def prepare_pictures(runs, at_times, plot_path, plot_at, comparisons, every=None):
    """Check every picture time (and --every) against the run and render the PNG, before
    anything is written.

    Returns (offsets, [(t, sample index)] for --at, the PNG bytes or None).
    """
    from plantlod.export.obj import rest_layout
    from plantlod.sim.kinematics import rest_height

    trees = [r.tree for r in runs]
    offsets = rest_layout(trees, [rest_height(t) for t in trees])
    times = runs[0].times
    at_frames = [(t, _sample_index(times, t, "--at")) for t in at_times]
    after = len(times) - 1                 # (--every past them wrote frame 0 alone: session 34)
    if every is not None and every > max(after, 1):
        raise InputError(f"--every {every:,} is more than the run's {after:,} samples after "
                         f"t = 0; expected at most {max(after, 1):,}")
    png = None
    if plot_path is not None:
        from plantlod.compare.plot import plot_comparison

        if plot_at is None:
            t_plot = at_times[0] if at_times else min(DEFAULT_PLOT_TIME, float(times[-1]))
        else:
            t_plot = plot_at
        k = _sample_index(times, t_plot, "--plot-at")
        png = plot_comparison(comparisons, trees, [os.path.basename(r.name) for r in runs],
                              [r.bend[k] for r in runs], [r.rot[k] for r in runs], offsets,
                              float(times[k]))
    return offsets, at_frames, png


def write_pictures(runs, obj_dir, every, plot_path, pictures, landing) -> list[str]:
    """The OBJ frames and the picture, each held as a temporary in ``landing`` (a
    contextlib.ExitStack): they land, with the command's report, when it closes, and a
    failure or a signal before then leaves none of them. Returns the lines to say once
    they have landed."""
    from plantlod.export.obj import obj_text, posed_meshes

    offsets, at_frames, png = pictures
    trees = [r.tree for r in runs]
    names = ["original"] + [f"simplified_{i}" for i in range(1, len(runs))]
    times = runs[0].times

    def frame(k: int) -> str:
        meshes = posed_meshes(trees, names, [r.bend[k] for r in runs], [r.rot[k] for r in runs],
                              offsets)
        return obj_text(meshes)

    written, lines = 0, []
    if obj_dir is not None:
        # every frame into a temporary folder beside DIR, moved into DIR when the command's
        # outputs land: a failure or a signal leaves neither part of them nor a new empty DIR
        folder = landing.enter_context(output_folder(obj_dir, merge=True))
        for t, k in at_frames:
            with open_output(os.path.join(folder, FRAME_AT.format(t))) as out:
                out.write(frame(k))
            written += 1
        if every is not None:
            for number, k in enumerate(range(0, len(times), every)):
                with open_output(os.path.join(folder, FRAME_NUMBERED.format(number))) as out:
                    out.write(frame(k))
                written += 1
        lines.append(f"compare: wrote {counted(written, 'OBJ file')} to {obj_dir}")
    if png is not None:
        landing.enter_context(open_output(plot_path, binary=True)).write(png)
        lines.append(f"compare: wrote {plot_path}")
    return lines
