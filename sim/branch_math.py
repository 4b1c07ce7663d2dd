"""The arithmetic of one branch and one step (model.md 3-4), shared by every kernel.

`kernel.py` (one run, compiled or interpreted) and `lanes_kernel.py` (W runs as
`vec4.Vec4` lanes) call these functions, so all do the same operations in the same
order and give the same bits. They are plain Python, written without branches on
values (a `select` instead), so they take floats and vectors alike; `plantlod.sim.jit`
registers them with numba (inlined at the call). Matrices are 9-tuples, row-major.
"""

from __future__ import annotations

import math

from .ops import select


def times_rest(a, q):
    """M = A Q: the parent's branch frame A times the rest rotation Q_i = Rz(phi) Ry(alpha)."""
    return (a[0] * q[0] + a[1] * q[3] + a[2] * q[6],
            a[0] * q[1] + a[1] * q[4] + a[2] * q[7],
            a[0] * q[2] + a[1] * q[5] + a[2] * q[8],
            a[3] * q[0] + a[4] * q[3] + a[5] * q[6],
            a[3] * q[1] + a[4] * q[4] + a[5] * q[7],
            a[3] * q[2] + a[4] * q[5] + a[5] * q[8],
            a[6] * q[0] + a[7] * q[3] + a[8] * q[6],
            a[6] * q[1] + a[7] * q[4] + a[8] * q[7],
            a[6] * q[2] + a[7] * q[5] + a[8] * q[8])


def swing(m, tb, tr, theta, c, s):
    """S = M Rot(u, theta), u = (-tr, tb, 0) / theta (Rodrigues), c = cos theta, s = sin theta;
    S = M where theta = 0 (a select: every element of M as it is, whatever u would be).
    Rot = [[r00, r01, r02], [r01, r11, r12], [-r02, -r12, c]]."""
    rest = theta == 0.0
    t = select(rest, 1.0, theta)
    ux = -tr / t
    uy = tb / t
    oc = 1.0 - c
    r00 = c + oc * ux * ux
    r01 = oc * ux * uy
    r02 = s * uy
    r11 = c + oc * uy * uy
    r12 = -s * ux
    return (select(rest, m[0], m[0] * r00 + m[1] * r01 - m[2] * r02),
            select(rest, m[1], m[0] * r01 + m[1] * r11 - m[2] * r12),
            select(rest, m[2], m[0] * r02 + m[1] * r12 + m[2] * c),
            select(rest, m[3], m[3] * r00 + m[4] * r01 - m[5] * r02),
            select(rest, m[4], m[3] * r01 + m[4] * r11 - m[5] * r12),
            select(rest, m[5], m[3] * r02 + m[4] * r12 + m[5] * c),
            select(rest, m[6], m[6] * r00 + m[7] * r01 - m[8] * r02),
            select(rest, m[7], m[6] * r01 + m[7] * r11 - m[8] * r12),
            select(rest, m[8], m[6] * r02 + m[7] * r12 + m[8] * c))


def twist(s, cp, sp):
    """R = S Rz(psi): x' = c x + s y, y' = -s x + c y, z' = z (cp, sp: cos and sin psi)."""
    return (cp * s[0] + sp * s[1], cp * s[1] - sp * s[0], s[2],
            cp * s[3] + sp * s[4], cp * s[4] - sp * s[3], s[5],
            cp * s[6] + sp * s[7], cp * s[7] - sp * s[6], s[8])


def drag_magnitude(s, hx, hy, hz, area, speed2):
    """C_d 2 pi r L v^2 |R e_z x V^| with R e_z = (s2, s5, s8); 0 where there is no wind."""
    cx = s[5] * hz - s[8] * hy
    cy = s[8] * hx - s[2] * hz
    cz = s[2] * hy - s[5] * hx
    return area * speed2 * math.sqrt(cx * cx + cy * cy + cz * cz)


def gained_forces(gbx, gby, gbz, grx, gry, grz, fb, fr, fa):
    """The gain matrix of model.md 5 applied to the force in the swing frame f = (fb, fr, fa):
    (G_bx fb + G_by fr + G_bz fa, G_rx fb + G_ry fr + G_rz fa)."""
    return gbx * fb + gby * fr + gbz * fa, grx * fb + gry * fr + grz * fa


def advance_angle(angle, velocity, kfa, force, k, damping, dt):
    """The semi-implicit update of one angle: v += k_FA f - theta k / 1000 - c v; theta += v dt."""
    v = velocity + kfa * force - angle * k - damping * velocity
    return angle + v * dt, v
