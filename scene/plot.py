"""`scene --plot`: the scene from above, trees coloured by level, the camera's view cone; and
the branch-steps per frame at the chosen levels against full detail (matplotlib, Agg)."""

from __future__ import annotations

import io
import math

import numpy as np

from .file import Scene


def scene_png(scene: Scene, levels: np.ndarray, spent_per_step: float, full_per_step: float) -> bytes:
    """PNG bytes. levels: (N,) each tree's level; *_per_step: branch-steps per time step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, cost) = plt.subplots(1, 2, figsize=(11, 5), gridspec_kw={"width_ratios": [3, 2]})
    xy = np.array([t.position[:2] for t in scene.trees])
    shown = top.scatter(xy[:, 0], xy[:, 1], c=levels, cmap="viridis_r", s=6, vmin=0)
    fig.colorbar(shown, ax=top, label="level (0 = full tree)")
    cam = scene.camera
    view = (cam.target - cam.position)[:2]
    heading = math.atan2(view[1], view[0])
    # the horizontal half-angle from the vertical field of view at a 16:9 image
    half = math.atan(math.tan(math.radians(cam.fov_deg) / 2) * 16 / 9)
    reach = float(np.abs(xy - cam.position[:2]).max()) * 1.5 if len(xy) else 10.0
    for side in (-1, 1):
        a = heading + side * half
        top.plot([cam.position[0], cam.position[0] + reach * math.cos(a)],
                 [cam.position[1], cam.position[1] + reach * math.sin(a)], color="tab:red", lw=1)
    top.plot(*cam.position[:2], marker="^", color="tab:red", ms=9)
    pad = 0.05 * max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1]), 1.0)
    top.set_xlim(min(xy[:, 0].min(), cam.position[0]) - pad, max(xy[:, 0].max(), cam.position[0]) + pad)
    top.set_ylim(min(xy[:, 1].min(), cam.position[1]) - pad, max(xy[:, 1].max(), cam.position[1]) + pad)
    top.set_aspect("equal")
    top.set_title(f"{len(scene.trees):,} trees, budget {scene.budget_px:g} px")
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    frames = np.arange(max(scene.steps, 1)) * scene.dt
    cost.plot(frames, np.full_like(frames, full_per_step), label="full detail")
    cost.plot(frames, np.full_like(frames, spent_per_step), label="at the chosen levels")
    cost.set_yscale("log")
    cost.set_xlabel("t (s)")
    cost.set_ylabel("branch-steps per time step")
    cost.legend()
    cost.set_title(f"{full_per_step / max(spent_per_step, 1):.1f}x fewer")
    fig.tight_layout()
    out = io.BytesIO()
    fig.savefig(out, format="png", dpi=100, metadata={"Software": None})
    plt.close(fig)
    return out.getvalue()
