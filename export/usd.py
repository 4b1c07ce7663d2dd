"""OpenUSD out (usd-core, `pxr`): the branch hierarchy as Xforms with time-sampled orientations.

    /plantlod (Xform)                        upAxis Z, metersPerUnit 1, timeCodesPerSecond = fps
      /plantlod/b0 (Xform)                   translate = base in the parent's frame,
        /plantlod/b0/b3 ...                  orient (quatd) = R_parent^T R_i, one time sample a frame
        /plantlod/b0/geom (Cylinder)         radius r, height L, axis Z, centred at L/2

Prim names are `b<index>` (USD names cannot hold the dots of an address); each Xform
carries its address in the custom attribute `plantlod:address`. Time code k is frame k.
"""

from __future__ import annotations

import os

import numpy as np

from plantlod.lsys.tree import Tree

from .gltf import local_transforms, quaternions, resample


def write_usd(path: str, tree: Tree, times: np.ndarray, bend: np.ndarray, rot: np.ndarray,
              fps: float = 30.0, frames: tuple[int, int] | None = None) -> None:
    """Write ``path`` (.usda text or .usdc binary, by its extension)."""
    from pxr import Gf, Sdf, Usd, UsdGeom

    t_frames, b = resample(times, bend, fps)
    _, r = resample(times, rot, fps)
    if frames is not None:
        b, r = b[frames[0]:frames[1]], r[frames[0]:frames[1]]
    local, translation = local_transforms(tree, b, r)
    quats = quaternions(local)                               # (F, B, 4) x, y, z, w
    text = path.lower().endswith(".usda")
    # .usda: made in memory and written by plantlod (OpenUSD's text writer looped on a full
    # disk, its memory growing without end); .usdc: OpenUSD's own file, which says so
    stage = Usd.Stage.CreateInMemory(os.path.basename(path)) if text else Usd.Stage.CreateNew(path)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetTimeCodesPerSecond(fps)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(len(b) - 1)
    root = UsdGeom.Xform.Define(stage, "/plantlod")
    stage.SetDefaultPrim(root.GetPrim())
    parent = np.asarray(tree.parent, dtype=np.int64)
    paths: list[str] = []
    for i in range(tree.n_branches):
        base = "/plantlod" if parent[i] < 0 else paths[parent[i]]
        prim_path = f"{base}/b{i}"
        paths.append(prim_path)
        xf = UsdGeom.Xform.Define(stage, prim_path)
        xf.GetPrim().CreateAttribute("plantlod:address", Sdf.ValueTypeNames.String).Set(tree.address[i])
        xf.AddTranslateOp().Set(Gf.Vec3d(*map(float, translation[i])))
        orient = xf.AddOrientOp(UsdGeom.XformOp.PrecisionDouble)
        for k in range(len(b)):
            x, y, z, w = map(float, quats[k, i])
            orient.Set(Gf.Quatd(w, x, y, z), Usd.TimeCode(k))
        geom = UsdGeom.Cylinder.Define(stage, f"{prim_path}/geom")
        geom.CreateRadiusAttr(float(tree.radius[i]))
        geom.CreateHeightAttr(float(tree.length[i]))
        geom.CreateAxisAttr(UsdGeom.Tokens.z)
        geom.AddTranslateOp().Set(Gf.Vec3d(0.0, 0.0, float(tree.length[i]) / 2))
    if text:
        from plantlod.formats.atomic import write_whole

        write_whole(path, stage.GetRootLayer().ExportToString().encode("utf-8"))
        return
    saved = False
    try:
        saved = stage.GetRootLayer().Save()
    except Exception as exc:              # pxr.Tf.ErrorException: its own lines, its own type
        raise UsdWriteError(_usd_reason(exc)) from None
    if not saved:
        raise UsdWriteError("OpenUSD did not save the layer")


class UsdWriteError(Exception):
    """OpenUSD could not save a layer (a full disk, a file too large); the reason, one line.
    `export.files` names the file the user asked for (this one writes a temporary)."""


def _usd_reason(exc: BaseException) -> str:
    """What OpenUSD's error says, one line: the quoted message of its first error ("Could not
    close …"), without the C++ function and source line around it."""
    import re

    text = " ".join(str(exc).split())
    quoted = re.search(r" : '(.*?)'(?: |$)", text)
    reason = (quoted.group(1) if quoted else text).rstrip(",. ")
    return f"OpenUSD could not save it ({reason[:160]})" if reason else "OpenUSD could not save it"
