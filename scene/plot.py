"""`scene --plot`: the scene from above, trees coloured by level, the camera's view cone; and
the branch-steps per frame at the chosen levels against full detail (matplotlib, Agg)."""

from __future__ import annotations

import io
import math

import numpy as np

from plantlod.lsys.errors import RunFailure

from .file import Scene
from plantlod.lsys.words import counted


def scene_png(scene: Scene, levels: np.ndarray, in_use: np.ndarray, full: int,
              frame_s: float) -> bytes:
    """PNG bytes. levels: (N, F) each tree's level per frame (the map shows frame 0);
    in_use: (F,) branches simulated during each frame; full: branches at full detail;
    frame_s: seconds per frame."""
    levels = np.asarray(levels)
    first = levels[:, 0] if levels.ndim == 2 and levels.shape[1] else np.zeros(len(scene.trees))
    from plantlod.compare.plot import require_matplotlib

    plt = require_matplotlib()

    fig, (top, cost) = plt.subplots(1, 2, figsize=(11, 5), gridspec_kw={"width_ratios": [3, 2]})
    xy = np.array([t.position[:2] for t in scene.trees])
    shown = top.scatter(xy[:, 0], xy[:, 1], c=first, cmap="viridis_r", s=6, vmin=0,
                        vmax=max(int(levels.max()) if levels.size else 0, 1))
    fig.colorbar(shown, ax=top, label="level (0 = full tree)")
    cam = scene.camera
    view = (cam.target - cam.position)[:2]
    # the horizontal half-angle from the vertical field of view at a 16:9 image
    half = math.atan(math.tan(math.radians(cam.fov_deg) / 2) * 16 / 9)
    reach = float(np.abs(xy - cam.position[:2]).max()) * 1.5 if len(xy) else 10.0
    if np.hypot(*view) > 1e-9 * max(1.0, float(np.linalg.norm(cam.target - cam.position))):
        heading = math.atan2(view[1], view[0])
        for side in (-1, 1):
            a = heading + side * half
            top.plot([cam.position[0], cam.position[0] + reach * math.cos(a)],
                     [cam.position[1], cam.position[1] + reach * math.sin(a)], color="tab:red",
                     lw=1)
    # (a camera looking straight down or up has no heading in the plan: its cone was drawn
    # along +x, atan2(0, 0); a scene fuzzing round. Only its place is drawn)
    top.plot(*cam.position[:2], marker="^", color="tab:red", ms=9)
    if cam.moving:                                     # the camera's path, keys marked
        top.plot(cam.key_position[:, 0], cam.key_position[:, 1], color="tab:red", lw=1,
                 ls="--", marker=".")
    seen = np.vstack([xy, (cam.key_position if cam.moving else cam.position[None])[:, :2]])
    with np.errstate(over="ignore"):
        pad = 0.05 * max(np.ptp(seen[:, 0]), np.ptp(seen[:, 1]), 1.0)
        far = seen.min(axis=0) - pad, seen.max(axis=0) + pad
    if not (np.isfinite(far[0]).all() and np.isfinite(far[1]).all()):
        raise RunFailure("cannot draw the plot: the trees and the camera span more than a "
                         "float can hold (the camera or a tree placed near ±1e308 m)")
    top.set_xlim(far[0][0], far[1][0])
    top.set_ylim(far[0][1], far[1][1])
    top.set_aspect("equal")
    top.set_title(f"{counted(len(scene.trees), 'tree')}, budget {scene.budget_px:g} px "
                  "(levels at t = 0)")
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    t = np.arange(len(in_use)) * frame_s
    cost.step(t, np.full_like(t, float(full)), where="post", label="full detail")
    cost.step(t, in_use, where="post", label="at the chosen levels")
    if full > 0 or np.any(in_use > 0):               # (a tree without branches costs none)
        cost.set_yscale("log")
    cost.set_xlabel("t (s)")
    cost.set_ylabel("branches simulated")
    cost.legend()
    spent = float(np.mean(in_use)) if len(in_use) else float(full)
    cost.set_title(f"{full / max(spent, 1e-9):.1f}x fewer")
    fig.tight_layout()
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    return out.getvalue()
