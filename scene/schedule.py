"""Which level each tree runs at, frame by frame (model.md 7; docs/scene.md, "Switching").

At frame f (time f / frame_rate) a tree at distance d from the camera shows level l's tip
error e_l (metres, times the tree's scale) as p_l = e_l H / (2 d tan(fov / 2)) pixels.

- The first frame takes the coarsest level with p_l <= budget.
- Afterwards a tree moves finer at once when its level's p passes the budget (the budget
  is never overspent), and coarser only to a level with p_l <= HYSTERESIS x budget, so a
  tree whose distance hovers at a boundary does not flicker between two levels.
- A tree behind the camera (its base not in front of the image plane) takes the coarsest
  level; at distance 0 (the camera at its base) the full tree.
"""

from __future__ import annotations

import numpy as np

from .constants import HYSTERESIS
from .file import Scene


def frame_times(scene: Scene, every: int) -> np.ndarray:
    """(F,) s: the start of each frame, a frame being ``every`` steps (the last may be short)."""
    frames = -(-scene.steps // every)                  # ceil: the last partial frame counts
    return np.arange(frames) * every * scene.dt


def distances(scene: Scene, members: list[int], times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (n, F) m from the camera to each member's base, and whether it is ahead."""
    pos, tgt = scene.camera.at(times)                                      # (F, 3) each
    base = np.array([scene.trees[k].position for k in members], dtype=np.float64)   # (n, 3)
    offset = base[:, None, :] - pos[None]                                   # (n, F, 3)
    d = np.linalg.norm(offset, axis=-1)
    ahead = np.einsum("nfi,fi->nf", offset, tgt - pos) > 0.0
    return d, ahead


def level_schedule(scene: Scene, members: list[int], tip_error_m: np.ndarray,
                   times: np.ndarray, budget: float) -> np.ndarray:
    """(n, F) int16: the level of each member (trees of one chain) at each frame.

    tip_error_m : (L,) the chain's tip error (max) per level, non-decreasing, metres
    """
    d, ahead = distances(scene, members, times)
    scale = np.array([scene.trees[k].scale for k in members])[:, None]
    ppm = scene.camera.pixels_per_metre(d)                                  # (n, F), inf at 0
    last = len(tip_error_m) - 1
    with np.errstate(invalid="ignore"):
        px = tip_error_m[None, None, :] * (scale * ppm)[..., None]          # (n, F, L)
    px[..., 0] = 0.0                                                        # level 0: exact
    px = np.where(np.isnan(px), np.inf, px)                                 # 0 m x inf px
    fits = px <= budget
    fits_well = px <= HYSTERESIS * budget
    levels = np.arange(len(tip_error_m))
    coarsest = np.where(fits, levels, 0).max(axis=-1)                       # (n, F)
    coarsest_well = np.where(fits_well, levels, 0).max(axis=-1)
    out = np.empty(d.shape, dtype=np.int16)
    current = coarsest[:, 0].copy()
    for f in range(d.shape[1]):
        if f:
            over = ~fits[np.arange(len(members)), f, current]               # must go finer
            current = np.where(over, coarsest[:, f], np.maximum(current, coarsest_well[:, f]))
        current = np.where(ahead[:, f], current, last)                      # behind: coarsest
        current = np.where(d[:, f] == 0.0, 0, current)                      # at its base: full
        out[:, f] = current
    return out
