"""A PNG for `plantlod compare --plot` (matplotlib, the optional extra ``plantlod[plot]``).

Top: for every simplified tree, the original's combined angles against the
simplified branch's angles over time, for its worst groups (where the largest
amplitude, period and tip errors are). Bottom: the posed trees at one time,
side by side as in the OBJ files, projected onto the world xz-plane (branch
segments; line width after radius). Angles are plotted in degrees.

matplotlib is imported only here and only when a plot is asked for, with the
Agg backend; the PNG carries no software or date metadata, so the same input
gives the same bytes on one machine (font rendering may differ between
matplotlib versions).
"""

from __future__ import annotations

import io
import math

import numpy as np

from plantlod.lsys.errors import InputError
from plantlod.lsys.tree import Tree
from plantlod.sim.kinematics import pose
from .runs import Comparison

# Figure layout: presentation choices of this one module, kept here with it.
PLOT_DPI = 100
PLOT_WIDTH_IN = 10.0            # figure width, inches
PLOT_ROW_HEIGHT_IN = 2.6        # height per angle panel
PLOT_TREES_HEIGHT_IN = 4.5      # height of the tree panel
LINE_WIDTH_RANGE = (0.4, 4.0)   # points, thinnest to thickest branch
# The thickest branch is drawn at most this / sqrt(branches drawn) points wide,
# so that crowns of thousands of branches do not turn into blots.
LINE_WIDTH_DENSITY = 60.0
PLOT_MARGIN = 0.08              # tree panel margin, x the drawing's size
INSTALL_HINT = "pip install 'plantlod[plot]'"


def require_matplotlib():
    """The matplotlib.pyplot module on the Agg backend, or an InputError with the install hint
    (`compare --plot`, `scene --plot`).

    While matplotlib is first imported: MPLBACKEND is set aside (matplotlib validates it at
    import, and a bogus one ended the run in an internal error after all its work; the plot
    is Agg whatever it says) and put back after; and matplotlib's log is held to errors (a
    config folder it cannot write, $HOME read-only, printed two unprefixed lines of its own).
    The temporary config folder matplotlib then makes instead (it sets MPLCONFIGDIR to it and
    removes it at exit) is held for `formats.atomic.remove_pending`, so that a signal, which
    skips matplotlib's exit handler, removes it too; only a folder made by this import, never
    one the user or a parent process named (a helper, session 35)."""
    import logging
    import os
    import sys

    first = "matplotlib" not in sys.modules
    named = os.environ.get("MPLCONFIGDIR")
    backend = os.environ.pop("MPLBACKEND", None) if first else None
    log = logging.getLogger("matplotlib")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        import matplotlib

        matplotlib.use("Agg", force=True)
        import matplotlib.pyplot as plt
    except ImportError:
        raise InputError(f"--plot needs matplotlib, which is not installed; "
                         f"run: {INSTALL_HINT}") from None
    finally:
        log.setLevel(level)
        if backend is not None:
            os.environ["MPLBACKEND"] = backend
    made = os.environ.get("MPLCONFIGDIR")
    if first and named is None and made:
        from plantlod.formats.atomic import hold

        hold(made)
    return plt


def worst_series(comparison: Comparison) -> list[tuple[int, str, str]]:
    """(group index, component, why) of the worst groups, without repeats, at most three.

    In the order amplitude error, period error, tip error (the tip error's
    component is the group's larger original amplitude).
    """
    r = comparison.report
    index = {g.address: j for j, g in enumerate(r.groups)}
    out: list[tuple[int, str, str]] = []
    for worst, why in ((r.amplitude_error_at, "amplitude"), (r.period_error_at, "period"),
                       (r.tip_error_at, "tip")):
        if worst is None:
            continue
        j = index[worst.address]
        component = worst.component
        if component is None:
            g = r.groups[j]
            component = ("bend" if g.bend.amplitude_original >= g.rotation.amplitude_original
                         else "rotation")
        if all((j, component) != (k, c) for k, c, _ in out):
            out.append((j, component, why))
    return out


def plot_comparison(comparisons: list[Comparison], trees: list[Tree], names: list[str],
                    bends: list[np.ndarray], rots: list[np.ndarray], offsets: list[float],
                    t_trees: float) -> bytes:
    """The PNG file's bytes.

    trees, names, bends, rots, offsets : the trees to draw side by side (original
    first), each with its angles (B,) rad at time ``t_trees`` (s) and its x offset (m).
    """
    plt = require_matplotlib()
    from matplotlib.collections import LineCollection

    rows = len(comparisons)
    heights = [PLOT_ROW_HEIGHT_IN] * rows + [PLOT_TREES_HEIGHT_IN]
    fig, axes = plt.subplots(rows + 1, 1, figsize=(PLOT_WIDTH_IN, sum(heights)),
                             gridspec_kw={"height_ratios": heights}, dpi=PLOT_DPI)
    deg = 180.0 / math.pi
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, comp in zip(axes[:-1], comparisons):
        t = comp.original.times
        for n, (j, component, why) in enumerate(worst_series(comp)):
            x = comp.combined_bend if component == "bend" else comp.combined_rot
            y = comp.simplified.bend if component == "bend" else comp.simplified.rot
            address = comp.simplified.tree.address[j]
            colour = colours[n % len(colours)]
            ax.plot(t, x[:, j] * deg, color=colour, linewidth=1.2,
                    label=f"{address} {component}: original (combined) [worst {why}]")
            ax.plot(t, y[:, j] * deg, color=colour, linewidth=1.2, linestyle="--",
                    label=f"{address} {component}: simplified")
        r = comp.report
        ax.axvspan(r.t0, r.t1, color="0.93", zorder=0)
        ax.set_title(f"{comp.simplified.name} against {comp.original.name}", fontsize=10)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("angle (deg)")
        ax.grid(True, linewidth=0.4, color="0.85")
        if ax.lines:
            ax.legend(fontsize=7, loc="upper right", ncol=1, frameon=False)

    ax = axes[-1]
    all_radius = np.concatenate([np.asarray(tr.radius, np.float64) for tr in trees])
    r_max = float(all_radius.max()) if all_radius.size and all_radius.max() > 0 else 1.0
    extents = []                                    # (2B, 2) x, z of every drawn point per tree
    for number, (tree, bend, rot, dx) in enumerate(zip(trees, bends, rots, offsets), start=1):
        posed = pose(tree, np.asarray(bend, np.float64), np.asarray(rot, np.float64))
        seg = np.stack([posed.base[:, [0, 2]], posed.tip[:, [0, 2]]], axis=1)   # (B, 2, 2) x, z
        seg[:, :, 0] += dx
        lo, hi = LINE_WIDTH_RANGE
        hi = max(lo, min(hi, LINE_WIDTH_DENSITY / math.sqrt(len(all_radius))))
        widths = lo + (hi - lo) * np.asarray(tree.radius, np.float64) / r_max
        ax.add_collection(LineCollection(seg, linewidths=widths, colors="saddlebrown",
                                         capstyle="round"))
        if tree.n_leaves:
            tips = posed.tip[np.asarray(tree.leaf_branch, np.int64)]
            ax.plot(tips[:, 0] + dx, tips[:, 2], "o", color="forestgreen", markersize=2,
                    alpha=0.6, markeredgewidth=0)
        ends = np.concatenate([posed.base[:, 0], posed.tip[:, 0]])
        extents.append(np.concatenate([posed.base, posed.tip])[:, [0, 2]] + [dx, 0.0])
        ax.annotate(str(number), ((float(ends.min()) + float(ends.max())) / 2 + dx, 0.0),
                    xytext=(0, -4), textcoords="offset points", fontsize=9, ha="center", va="top")
    key = "   ".join(f"{n}: {name}" for n, name in enumerate(names, start=1))
    ax.set_title(f"posed trees at t = {t_trees:g} s, projected onto xz, left to right\n{key}",
                 fontsize=10)
    _fit_equal(ax, np.concatenate(extents))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    fig.tight_layout()
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=PLOT_DPI, metadata={"Software": None})
    plt.close(fig)
    return out.getvalue()


def _fit_equal(ax, points: np.ndarray) -> None:
    """Limits around points (N, 2) (x, z in m) with a margin; equal scales, the panel shrunk to fit."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    pad = PLOT_MARGIN * max(float((hi - lo).max()), 1e-9)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(min(lo[1], 0.0) - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
