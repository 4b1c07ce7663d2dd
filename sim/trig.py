"""sin and cos of one angle, the same bits in every kernel, lane and machine.

`sincos(x)` returns (sin x, cos x). It is a plain Python function that
`plantlod.sim.jit` registers with numba (inlined where it is called), for a float or
a `vec4.Vec4` (4 angles at once): the same formula, operation for operation, so a
lane of a vector kernel equals the scalar kernel bit for bit, and both equal the
interpreted formula (tests/test_trig.py).

Why not math.sin: numba calls libm's sin one value at a time (no SVML from LLVM 20
on), which keeps a lane loop scalar, and glibc's result is not guaranteed to be the
same across versions. This formula uses only + - * floor and selects, no branch, no
fused multiply-add (numba does not contract without fast-math; the tests check the
generated code has no ``vfmadd``), so it vectorises and is reproducible.

The formula (fdlibm, Sun Microsystems 1993, as kept in FreeBSD's msun:
lib/msun/src/k_sin.c, k_cos.c, e_rem_pio2.c; coefficients and split constants
copied from there, checked against their hex forms):

1. Reduction by pi/2 (Cody-Waite, fdlibm's "medium" path, always taking its second
   round): n = floor(|x| 2/pi + 1/2), |x| - n pi/2 = y0 + y1 with pi/2 split in three
   parts (pio2_1 and pio2_2 of 33 bits each, so n pio2_1 and n pio2_2 are exact for
   n < 2^20, and the tail pio2_2t). fdlibm's first round alone (pio2_1 + pio2_1t, two
   terms) loses the relative accuracy of sin next to multiples of pi (sin of the double
   nearest pi would be wrong in its 10th digit); the second round costs five flops.
2. fdlibm's kernel polynomials on [-pi/4, pi/4] (degree 13 for sin, 14 for cos, Remez
   error below 2^-58), with the tail y1 as __kernel_sin(y0, y1, 1) and
   __kernel_cos(y0, y1) use it.
3. The quadrant n mod 4 chooses among +-sin and +-cos of the reduced angle by selects;
   sin(x) = -sin(-x) and cos(x) = cos(-x) hold exactly because the work is done on |x|;
   sin x = x for |x| < 2^-27 (which also keeps sin(-0) = -0).

Accuracy (tests/test_trig.py, against glibc's sin and cos, which are within about half
an ulp of the exact value): at most 1 ulp over 10^6 points of [-4pi, 4pi], small
angles 1e-300 .. 1e-3, 10^5 points of [-1e5, 1e5] and the doubles nearest k pi/2 for
|k| <= 1000; exactly 0 and 1 at 0. The range: |x| <= 1e5 is tested and documented
(the kernels' angles are hypot(theta_b, theta_r), a few radians at most). The
reduction stays exact in its products up to |x| ~ 2^20 pi/2 ~ 1.6e6; beyond that the
error grows with |x| (nothing raises), and inf or nan give nan.
"""

from __future__ import annotations

from .ops import floor, select

# fdlibm e_rem_pio2.c
INVPIO2 = 6.36619772367581382433e-01     # 0x3FE45F30 6DC9C883, 53 bits of 2/pi
PIO2_1 = 1.57079632673412561417e+00      # 0x3FF921FB 54400000, first 33 bits of pi/2
PIO2_2 = 6.07710050630396597660e-11      # 0x3DD0B461 1A600000, second 33 bits
PIO2_2T = 2.02226624879595063154e-21     # 0x3BA3198A 2E037073, pi/2 - (pio2_1 + pio2_2)
# fdlibm k_sin.c
S1 = -1.66666666666666324348e-01         # 0xBFC55555 55555549
S2 = 8.33333333332248946124e-03          # 0x3F811111 1110F8A6
S3 = -1.98412698298579493134e-04         # 0xBF2A01A0 19C161D5
S4 = 2.75573137070700676789e-06          # 0x3EC71DE3 57B1FE7D
S5 = -2.50507602534068634195e-08         # 0xBE5AE5E6 8A2B9CEB
S6 = 1.58969099521155010221e-10          # 0x3DE5D93A 5ACFD57C
# fdlibm k_cos.c
C1 = 4.16666666666666019037e-02          # 0x3FA55555 5555554C
C2 = -1.38888888888741095749e-03         # 0xBF56C16C 16C15177
C3 = 2.48015872894767294178e-05          # 0x3EFA01A0 19CB1590
C4 = -2.75573143513906633035e-07         # 0xBE927E4F 809C52AD
C5 = 2.08757232129817482790e-09          # 0x3E21EE9E BDB4B1C4
C6 = -1.13596475577881948265e-11         # 0xBDA8FAE9 BE8838D4
TINY = 7.450580596923828125e-09          # 2^-27: sin x = x below it
TESTED_RANGE = 1.0e5                     # |x| up to which the accuracy is tested


def sincos(x):
    """(sin x, cos x) for a float or a Vec4 x; see the module's docstring for accuracy."""
    ax = abs(x)
    # reduction: ax - n pi/2 = y0 + y1
    n = floor(ax * INVPIO2 + 0.5)
    t = ax - n * PIO2_1
    w = n * PIO2_2
    r = t - w
    w = n * PIO2_2T - ((t - r) - w)
    y0 = r - w
    y1 = (r - y0) - w
    ks, kc = _kernels(y0, y1)
    # quadrant n mod 4 (exact: n is a whole number below 2^53)
    q = n - 4.0 * floor(n * 0.25)
    s = select(q == 0.0, ks, select(q == 1.0, kc, select(q == 2.0, -ks, -kc)))
    c = select(q == 0.0, kc, select(q == 1.0, -ks, select(q == 2.0, -kc, ks)))
    s = select(ax < TINY, x, select(x < 0.0, -s, s))
    return s, c


def sincos1(x):
    """`sincos` of one float, the same bits, faster where n = 0 (|x| below about pi/4):
    there the reduction is the identity (y0 = |x|, y1 = 0 exactly) and is skipped. A
    branch, so for scalar code only (the single-run and tips kernels)."""
    ax = abs(x)
    if ax * INVPIO2 + 0.5 < 1.0:          # exactly when floor(ax 2/pi + 1/2) = n = 0
        ks, kc = _kernels(ax, 0.0)
        return select(ax < TINY, x, select(x < 0.0, -ks, ks)), kc
    return sincos(x)


def _kernels(y0, y1):
    """fdlibm's __kernel_sin(y0, y1, 1) and __kernel_cos(y0, y1): sin and cos of
    y0 + y1, |y0 + y1| <= pi/4 (y1 the tail of the reduction)."""
    z = y0 * y0
    zz = z * z
    rs = S2 + z * (S3 + z * S4) + z * zz * (S5 + z * S6)
    v = z * y0
    ks = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * S1)
    rc = z * (C1 + z * (C2 + z * C3)) + zz * zz * (C4 + z * (C5 + z * C6))
    hz = 0.5 * z
    wc = 1.0 - hz
    kc = wc + (((1.0 - wc) - hz) + (z * rc - y0 * y1))
    return ks, kc
