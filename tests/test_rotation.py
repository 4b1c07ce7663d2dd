"""Rotations and ZYZ angles (lsys/rotation.py, model.md section 2).

Expected values are closed forms worked out by hand (cos/sin entries, axis
images, the ZYZ angles of simple products), never the module's own output.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from plantlod.lsys.constants import ZYZ_DEGENERATE_TOL
from plantlod.lsys.rotation import (matrix_from_zyz, rodrigues, rot_x, rot_y, rot_z,
                                    zyz_from_matrix)

E_X, E_Y, E_Z = np.eye(3)
RNG = np.random.default_rng(20030101)


def wrap(a):
    """Angle difference mapped to (-pi, pi]."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize("rot", [rot_x, rot_y, rot_z])
def test_orthonormal_and_proper(rot):
    angles = RNG.uniform(-10, 10, 200)
    m = rot(angles)
    assert m.shape == (200, 3, 3)
    eye = np.broadcast_to(np.eye(3), m.shape)
    assert np.abs(m @ np.swapaxes(m, 1, 2) - eye).max() < 1e-15
    assert np.abs(np.linalg.det(m) - 1.0).max() < 1e-14
    assert rot(0.3).shape == (3, 3)
    assert rot(np.zeros((2, 4))).shape == (2, 4, 3, 3)


def test_closed_forms():
    a = 0.7
    c, s = math.cos(a), math.sin(a)
    assert np.array_equal(rot_x(a), [[1, 0, 0], [0, c, -s], [0, s, c]])
    assert np.array_equal(rot_y(a), [[c, 0, s], [0, 1, 0], [-s, 0, c]])
    assert np.array_equal(rot_z(a), [[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_right_handed():
    # model.md: +(a) rotates about local y and tips the heading z toward +x.
    assert np.allclose(rot_y(math.pi / 2) @ E_Z, E_X, atol=1e-16)
    assert (rot_y(0.1) @ E_Z)[0] > 0
    # x -> y about z, y -> z about x, z -> x about y (cyclic right-handed rule).
    assert np.allclose(rot_z(math.pi / 2) @ E_X, E_Y, atol=1e-16)
    assert np.allclose(rot_x(math.pi / 2) @ E_Y, E_Z, atol=1e-16)
    assert np.allclose(np.cross(E_X, E_Y), E_Z)


def test_rodrigues_matches_axis_rotations_and_permutation():
    a = RNG.uniform(-4, 4, 50)
    for axis, rot in ((E_X, rot_x), (E_Y, rot_y), (E_Z, rot_z)):
        assert np.abs(rodrigues(np.broadcast_to(axis, (50, 3)), a) - rot(a)).max() < 1e-15
    # 120 degrees about (1,1,1)/sqrt(3) permutes the axes x -> y -> z -> x.
    r = rodrigues(np.ones(3) / math.sqrt(3), 2 * math.pi / 3)
    assert np.allclose(r @ E_X, E_Y, atol=1e-15)
    assert np.allclose(r @ E_Y, E_Z, atol=1e-15)
    assert np.allclose(r @ E_Z, E_X, atol=1e-15)


def test_matrix_from_zyz_is_the_product():
    phi, alpha, psi = 0.3, 1.1, -2.0
    expected = rot_z(phi) @ rot_y(alpha) @ rot_z(psi)
    assert np.array_equal(matrix_from_zyz(phi, alpha, psi), expected)
    # heading (third column) = (cos phi sin alpha, sin phi sin alpha, cos alpha)
    z = matrix_from_zyz(phi, alpha, psi)[:, 2]
    assert np.allclose(z, [math.cos(phi) * math.sin(alpha), math.sin(phi) * math.sin(alpha),
                           math.cos(alpha)], atol=1e-15)


def test_zyz_round_trip_random():
    n = 2000
    phi = RNG.uniform(-math.pi, math.pi, n)
    alpha = RNG.uniform(1e-3, math.pi - 1e-3, n)
    psi = RNG.uniform(-math.pi, math.pi, n)
    got = zyz_from_matrix(matrix_from_zyz(phi, alpha, psi))
    assert np.abs(wrap(got[0] - phi)).max() < 1e-12
    assert np.abs(got[1] - alpha).max() < 1e-12
    assert np.abs(wrap(got[2] - psi)).max() < 1e-12
    assert np.all((got[1] >= 0) & (got[1] <= math.pi))


def test_zyz_conventions_by_hand():
    a = 0.6
    # Ry(a): a pure branching angle.
    assert np.allclose(zyz_from_matrix(rot_y(a)), (0.0, a, 0.0), atol=1e-15)
    # Ry(-a) = Rz(pi) Ry(a) Rz(-pi): alpha stays positive, phi = pi, psi = -pi.
    phi, alpha, psi = zyz_from_matrix(rot_y(-a))
    assert alpha == pytest.approx(a, abs=1e-15)
    assert abs(wrap(phi - math.pi)) < 1e-15 and abs(wrap(psi + math.pi)) < 1e-15
    # Rx(a) = Rz(-pi/2) Ry(a) Rz(pi/2): tilt about local x.
    assert np.allclose(zyz_from_matrix(rot_x(a)), (-math.pi / 2, a, math.pi / 2), atol=1e-15)
    # Rz(b) Ry(a): phi is the rotation about the parent's axis.
    assert np.allclose(zyz_from_matrix(rot_z(1.2) @ rot_y(a)), (1.2, a, 0.0), atol=1e-15)
    # Ry(a) Rz(c): psi is the twist about the branch's own axis.
    assert np.allclose(zyz_from_matrix(rot_y(a) @ rot_z(-0.4)), (0.0, a, -0.4), atol=1e-15)
    # Scalars in, floats out.
    assert all(type(v) is float for v in zyz_from_matrix(rot_y(a)))


@pytest.mark.parametrize("phi,psi", [(0.0, 0.0), (0.4, 1.9), (-2.5, 2.9), (3.0, 3.0)])
def test_zyz_degenerate_alpha_zero(phi, psi):
    phi_out, alpha, psi_out = zyz_from_matrix(matrix_from_zyz(phi, 0.0, psi))
    assert alpha == 0.0 and phi_out == 0.0          # exactly
    assert abs(wrap(psi_out - (phi + psi))) < 1e-14  # Rz(phi) Rz(psi) = Rz(phi + psi)


@pytest.mark.parametrize("phi,psi", [(0.0, 0.0), (0.4, 1.9), (-2.5, 2.9)])
def test_zyz_degenerate_alpha_pi(phi, psi):
    # Rz(phi) Ry(pi) Rz(psi) = Rz(phi - psi) Ry(pi) = Rz(0) Ry(pi) Rz(psi - phi).
    q = rot_z(phi) @ rot_y(math.pi) @ rot_z(psi)
    phi_out, alpha, psi_out = zyz_from_matrix(q)
    assert alpha == math.pi and phi_out == 0.0      # exactly
    assert abs(wrap(psi_out - (psi - phi))) < 1e-14


@pytest.mark.parametrize("alpha", [1e-12, -1e-12, math.pi - 1e-12, 0.5 * ZYZ_DEGENERATE_TOL])
def test_zyz_near_degenerate_snaps(alpha):
    phi, psi = 0.8, -1.3
    q = matrix_from_zyz(phi, alpha, psi)
    phi_out, alpha_out, psi_out = zyz_from_matrix(q)
    assert alpha_out in (0.0, math.pi) and phi_out == 0.0
    # The snapped angles describe the same rotation to within the snap.
    assert np.abs(matrix_from_zyz(phi_out, alpha_out, psi_out) - q).max() < 1e-9


def test_zyz_just_above_tolerance_is_regular():
    alpha = 10 * ZYZ_DEGENERATE_TOL
    phi_out, alpha_out, _ = zyz_from_matrix(matrix_from_zyz(0.5, alpha, 0.1))
    assert alpha_out == pytest.approx(alpha, rel=1e-6)
    assert phi_out == pytest.approx(0.5, abs=1e-6)


def test_zyz_vectorised_mixes_cases():
    q = np.stack([rot_y(0.3), np.eye(3), rot_y(math.pi), rot_x(2.0)])
    phi, alpha, psi = zyz_from_matrix(q)
    assert alpha.shape == (4,)
    assert np.allclose(alpha, [0.3, 0.0, math.pi, 2.0], atol=1e-15)
    assert alpha[1] == 0.0 and alpha[2] == math.pi
