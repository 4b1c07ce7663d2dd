"""Rotation matrices and the ZYZ Euler angles of model.md section 2.

Every function works on one rotation or on many at once: an angle argument may
be a float or an array of any shape S, and the result then has shape S + (3, 3)
(matrices) or S (angles). Angles are radians. All rotations are right-handed
and act on world-frame column vectors: ``rot_y(a) @ e_z`` tips toward +x for
a > 0, ``rot_z(a) @ e_x`` toward +y, ``rot_x(a) @ e_y`` toward +z.
"""

from __future__ import annotations

import numpy as np

from .constants import ZYZ_DEGENERATE_TOL


def _cos_sin(a) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cos a, sin a, zeros) as float64 arrays of a's shape; (S,) -> three (S,)."""
    a = np.asarray(a, dtype=np.float64)
    return np.cos(a), np.sin(a), np.zeros_like(a)


def _matrices(rows) -> np.ndarray:
    """Stack a 3x3 nested list of equally shaped arrays into an (S, 3, 3) array."""
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def rot_x(a) -> np.ndarray:
    """Rotation by ``a`` about the x axis: shape S -> S + (3, 3)."""
    c, s, z = _cos_sin(a)
    one = z + 1.0
    return _matrices([[one, z, z], [z, c, -s], [z, s, c]])


def rot_y(a) -> np.ndarray:
    """Rotation by ``a`` about the y axis (takes +z toward +x): S -> S + (3, 3)."""
    c, s, z = _cos_sin(a)
    one = z + 1.0
    return _matrices([[c, z, s], [z, one, z], [-s, z, c]])


def rot_z(a) -> np.ndarray:
    """Rotation by ``a`` about the z axis (takes +x toward +y): S -> S + (3, 3)."""
    c, s, z = _cos_sin(a)
    one = z + 1.0
    return _matrices([[c, -s, z], [s, c, z], [z, z, one]])


def rodrigues(axis, angle) -> np.ndarray:
    """Rotation by ``angle`` about the unit vector ``axis`` (Rodrigues' formula).

    R = cos(a) I + sin(a) [u]x + (1 - cos(a)) u u^T.
    axis: S + (3,) unit vectors (not normalised here); angle: S (or broadcastable
    to S). Returns S + (3, 3).
    """
    u = np.asarray(axis, dtype=np.float64)
    c, s, _ = _cos_sin(angle)
    t = 1.0 - c
    x, y, z = u[..., 0], u[..., 1], u[..., 2]
    return _matrices([
        [c + t * x * x, t * x * y - s * z, t * x * z + s * y],
        [t * y * x + s * z, c + t * y * y, t * y * z - s * x],
        [t * z * x - s * y, t * z * y + s * x, c + t * z * z],
    ])


def matrix_from_zyz(phi, alpha, psi) -> np.ndarray:
    """Rz(phi) Ry(alpha) Rz(psi): three angle arrays of shape S -> S + (3, 3)."""
    return rot_z(phi) @ rot_y(alpha) @ rot_z(psi)


def zyz_from_matrix(q) -> tuple:
    """ZYZ Euler angles (phi, alpha, psi) of rotations ``q`` (model.md section 2).

    ``q = Rz(phi) Ry(alpha) Rz(psi)`` with alpha in [0, pi]. q: S + (3, 3);
    returns three arrays of shape S (floats when S is ()). With
    h = hypot(q[0,2], q[1,2]):

    - alpha = atan2(h, q[2,2]), phi = atan2(q[1,2], q[0,2]),
      psi = atan2(q[2,1], -q[2,0]);
    - where h < ZYZ_DEGENERATE_TOL: alpha is exactly 0 (q[2,2] > 0) or exactly
      pi, phi = 0, and psi = atan2(q[1,0], q[0,0]) (alpha = 0) or
      atan2(q[1,0], -q[0,0]) (alpha = pi).
    """
    q = np.asarray(q, dtype=np.float64)
    h = np.hypot(q[..., 0, 2], q[..., 1, 2])
    degenerate = h < ZYZ_DEGENERATE_TOL
    up = q[..., 2, 2] > 0
    alpha = np.where(degenerate, np.where(up, 0.0, np.pi), np.arctan2(h, q[..., 2, 2]))
    phi = np.where(degenerate, 0.0, np.arctan2(q[..., 1, 2], q[..., 0, 2]))
    psi_regular = np.arctan2(q[..., 2, 1], -q[..., 2, 0])
    psi_flat = np.arctan2(q[..., 1, 0], np.where(up, q[..., 0, 0], -q[..., 0, 0]))
    psi = np.where(degenerate, psi_flat, psi_regular)
    if q.ndim == 2:
        return float(phi), float(alpha), float(psi)
    return phi, alpha, psi
