"""Which level each tree runs at, frame by frame (model.md 7; docs/scene.md, "Switching").

At frame f (time f / frame_rate) a tree at distance d from the camera shows level l's tip
error e_l (metres, times the tree's scale) as p_l = e_l H / (2 d tan(fov / 2)) pixels.

What scenes run is `two_way_schedule`: at each frame a tree is judged at its current
distance; it starts at the coarsest level with p_l <= budget, goes finer as soon as its
level passes the budget, and coarser only to a level with p_l <= HYSTERESIS x budget (so
it does not flicker between two levels) that it will not have to leave for a finer one
through a switch that would overspend the budget, nor starts coarser than such a level
(`held_levels`: a camera turning away and back, or coming nearer, in a strong wind).
Going finer is affordable because the finer
level's state is predicted from the tree's wind history (`switch.Transfer.predicted`), so
the coarser level's error is not carried into it; going coarser carries the state.

`coarsest_levels` (the coarsest level within the budget at each frame, switching free) is
the report's ``speedup_bound``. `level_schedule` is the earlier one-way rule, kept for its
tests: the camera's path is known in advance (keyed), so each frame is judged by the
**nearest the tree will come from then on**, where it is in view,

    p_l(f) = e_l · max over f' >= f of pixels_per_metre(d(f')), taken where the tree is ahead

(0 for a tree that stays behind the camera, infinite for one the camera will stand on);
that bound only falls with time, so trees only switch coarser. Carrying a coarser level's
error into finer levels made it necessary (forest_walk: a tree jumping from a single
branch to level 1 and then to full detail as the camera passed it was 58.8 px off); the
prediction made it unnecessary, and it cost a moving camera half its speed-up.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .constants import HYSTERESIS
from .file import Scene


def frame_times(scene: Scene, every: int) -> np.ndarray:
    """(F,) s: the start of each frame, a frame being ``every`` steps (the last may be short)."""
    frames = -(-scene.steps // every)                  # ceil: the last partial frame counts
    return np.arange(frames) * every * scene.dt


def frame_bounds(scene: Scene, times: np.ndarray) -> np.ndarray:
    """(F + 1,) s: the starts of the frames that start at ``times`` (`frame_times`) and the
    scene's end: frame f runs from bound f to bound f + 1."""
    return np.append(np.asarray(times, dtype=np.float64), scene.steps * scene.dt)


def frame_ends(scene: Scene, times: np.ndarray) -> np.ndarray:
    """(F,) s: the end of each frame that starts at ``times`` (`frame_times`), the time of
    the pose it shows (a store's row, a verified tip): the next frame's start, the scene's
    end for the last."""
    return frame_bounds(scene, times)[1:]


def distances(scene: Scene, members: list[int], times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (n, F) m from the camera to each member's base, and whether it is ahead."""
    pos, tgt = scene.camera.at(times)                                      # (F, 3) each
    base = np.array([scene.trees[k].position for k in members], dtype=np.float64)   # (n, 3)
    offset = base[:, None, :] - pos[None]                                   # (n, F, 3)
    d = np.linalg.norm(offset, axis=-1)
    ahead = np.einsum("nfi,fi->nf", offset, tgt - pos) > 0.0
    return d, ahead


def level_pixels(scene: Scene, members: list[int], tip_error_m: np.ndarray, times: np.ndarray,
                 look_ahead: bool = False) -> np.ndarray:
    """(n, F, L) px: each level's tip error (max) on screen for each member at each frame
    (model.md 7), 0 for level 0 and while the tree is behind the camera, infinite where the
    camera stands on its base. ``look_ahead``: at the nearest the tree comes from then on."""
    seen = seen_scale(scene, members, times, look_ahead)                  # (n, F)
    with np.errstate(invalid="ignore"):
        px = tip_error_m[None, None, :] * seen[..., None]                   # (n, F, L)
    px[..., 0] = 0.0                                                        # level 0: exact
    return np.where(np.isnan(px), np.inf, px)                               # 0 m x inf px


def seen_scale(scene: Scene, members: list[int], times: np.ndarray, look_ahead: bool = False
               ) -> np.ndarray:
    """(n, F) px per metre of tip error (model.md 7, times the member's scale) at each
    frame, 0 while the tree is behind the camera, infinite where the camera stands on its
    base. ``look_ahead``: at the nearest the tree comes from then on.

    A frame is judged at both its ends, the nearer counting: its level runs from its start
    and shows its pose at its end (`frame_ends`), so a camera that jumps nearer within a
    frame (keys 1 ms apart) had the frame's pose shown near at the level chosen far (a
    scene fuzzing round: 4.6 px against a 1 px budget, verified as 0.51 px at the start's
    distance)."""
    scale = np.array([scene.trees[k].scale for k in members])[:, None]
    d, ahead = distances(scene, members, frame_bounds(scene, times))     # (n, F + 1)
    at = np.where(ahead | (d == 0.0), scene.camera.pixels_per_metre(d), 0.0) * scale
    seen = np.maximum(at[:, :-1], at[:, 1:])                              # each frame's nearer end
    if look_ahead:
        seen = np.maximum.accumulate(seen[:, ::-1], axis=1)[:, ::-1]        # nearest from f on
    return seen


def level_schedule(scene: Scene, members: list[int], tip_error_m: np.ndarray,
                   times: np.ndarray, budget: float) -> np.ndarray:
    """(n, F) int16: the level of each member (trees of one chain) at each frame.

    tip_error_m : (L,) the chain's tip error (max) per level, non-decreasing, metres
    """
    px = level_pixels(scene, members, tip_error_m, times, look_ahead=True)
    first = _coarsest(px[:, 0], budget)                                                # (n,)
    coarsest_well = _coarsest(px, HYSTERESIS * budget)                                 # (n, F)
    # each frame: the level so far, or a coarser one within HYSTERESIS x budget
    return np.maximum(first[:, None], np.maximum.accumulate(coarsest_well, axis=1)).astype(np.int16)


def _coarsest(px: np.ndarray, limit: float) -> np.ndarray:
    """(n, F) the coarsest level whose error ``px`` (n, F, L) is within ``limit`` px."""
    return np.where(px <= limit, np.arange(px.shape[-1]), 0).max(axis=-1)


def coarsest_levels(scene: Scene, members: list[int], tip_error_m: np.ndarray,
                    times: np.ndarray, budget: float) -> np.ndarray:
    """(n, F) int16: at each frame the coarsest level whose error at the member's *current*
    distance is within ``budget`` px (no look-ahead, no hysteresis): what each frame could
    use if switching cost nothing. The scene report's `speedup_bound` counts its branch-steps.
    """
    return schedules(scene, members, tip_error_m, times, budget)[1]


def two_way_schedule(scene: Scene, members: list[int], tip_error_m: np.ndarray,
                     times: np.ndarray, budget: float) -> np.ndarray:
    """(n, F) int16: levels that follow the current distance both ways (model.md 7).

    A tree starts at the coarsest level within ``budget`` at its first frame; at each frame
    it goes finer as soon as its level passes the budget at the current distance, and
    coarser only to a level within HYSTERESIS x budget (against flicker). Going finer is
    affordable because the finer level's state is predicted from the tree's wind history
    (`switch.Transfer.predicted`), so the coarser level's error is not carried into it.
    """
    return schedules(scene, members, tip_error_m, times, budget)[0]


def schedules(scene: Scene, members: list[int], tip_error_m: np.ndarray, times: np.ndarray,
              budget: float,
              switch_error_m: "np.ndarray | Callable[[set[int]], np.ndarray] | None" = None
              ) -> tuple[np.ndarray, np.ndarray]:
    """(`two_way_schedule`, `coarsest_levels`), both (n, F) int16, from one `level_pixels`
    array (n, F, L): a scene of many trees builds it once.

    switch_error_m: (L,) metres, each level's tip error after a switch into it
    (`switch.switch_errors`; 0 where not measured), or a function giving it for the levels
    the schedule switches into from a coarser one (`finer_switches`), called only where it
    has such switches. A tree then goes coarser only to levels it will not have to come
    back from to one whose switch would overspend, and starts no coarser than a level its
    first such switch would overspend (`held_levels`).
    """
    px = level_pixels(scene, members, tip_error_m, times)
    within = _coarsest(px, budget)                                          # (n, F)
    if within.shape[1] == 0:
        return within.astype(np.int16), within.astype(np.int16)
    well = _coarsest(px, HYSTERESIS * budget)
    out = _walk(px, within, well, budget)
    if callable(switch_error_m):
        into = finer_switches(out)
        switch_error_m = switch_error_m(into) if into else None
    if switch_error_m is not None:
        held = held_levels(scene, members, tip_error_m, switch_error_m, times, budget, out)
        out = _walk(px, within, np.minimum(well, held), budget, start=held[:, 0])
    return out, within.astype(np.int16)


def _walk(px: np.ndarray, within: np.ndarray, well: np.ndarray, budget: float,
          start: np.ndarray | None = None) -> np.ndarray:
    """(n, F) int16: each frame's level, from the coarsest within ``budget`` at the first
    frame (no coarser than ``start`` (n,) where given), finer at once where the level
    overspends (to ``within``), coarser to ``well``."""
    out = np.empty(within.shape, dtype=np.int16)
    current = within[:, 0].copy() if start is None else np.minimum(within[:, 0], start)
    rows = np.arange(within.shape[0])
    for f in range(out.shape[1]):
        over = px[rows, f, current] > budget
        current = np.where(over, within[:, f], np.maximum(current, well[:, f]))
        out[:, f] = current
    return out


def held_levels(scene: Scene, members: list[int], tip_error_m: np.ndarray,
                switch_error_m: np.ndarray, times: np.ndarray, budget: float,
                levels: np.ndarray) -> np.ndarray:
    """(n, F): the coarsest level each member may move to at each frame, so that it never
    has to switch to a finer level whose switch overspends the budget. ``levels`` (n, F):
    the schedule without the hold, whose switches to a finer level are the ones judged.

    A switch into level l at frame f' is *dear* where max(e_l, s_l) times the pixels per
    metre at the nearest the tree comes within SWITCH_FOLLOW_S of f' exceeds ``budget`` (e
    the tip error, s the tip error after a switch, both (L,) m, s measured against the full
    tree over that time after a switch, `switch.switch_errors`; a later switch to a finer
    level starts from a new prediction);
    l = ``levels`` at f', a frame where they go finer. At frame f a tree may go no coarser
    than the finest level needed at a dear frame from f on: it keeps running there, and
    comes back without a switch; where the dear switch is a tree's first to that level
    (a camera coming nearer in a strong wind), it starts there (`schedules`: the first
    frame's level is capped too), and runs it from rest, which needs no prediction. One
    that leaves for good is not held. (Judged at the nearest the tree comes from f' on,
    the tip error alone was over the budget wherever the tree came nearer later, and any
    switch error held it; a review, session 30.)"""
    from scipy.ndimage import maximum_filter1d

    from .constants import SWITCH_FOLLOW_S

    seen = seen_scale(scene, members, times)
    if len(times) > 1 and seen.size:
        size = int(np.searchsorted(times - times[0], SWITCH_FOLLOW_S, side="right"))
        seen = maximum_filter1d(seen, size, axis=1, mode="nearest", origin=-(size // 2))
    levels = np.asarray(levels, dtype=np.int64)
    cost = np.maximum(np.asarray(tip_error_m), np.asarray(switch_error_m))[levels]  # (n, F) m
    finer = np.zeros(levels.shape, dtype=bool)
    finer[:, 1:] = levels[:, 1:] < levels[:, :-1]
    with np.errstate(invalid="ignore"):
        dear = finer & (cost * seen > budget) & (np.asarray(switch_error_m)[levels] > 0)
    last = len(tip_error_m) - 1
    need = np.where(dear, levels, last)
    return np.minimum.accumulate(need[:, ::-1], axis=1)[:, ::-1]


def finer_switches(levels: np.ndarray) -> set[int]:
    """The levels that some row of ``levels`` (n, F) switches into from a coarser one: the
    switches `held_levels` judges, whose switch errors a scene measures."""
    if levels.shape[1] < 2:
        return set()
    finer = levels[:, 1:] < levels[:, :-1]
    return {int(v) for v in np.unique(levels[:, 1:][finer])}
