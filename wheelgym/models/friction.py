"""Smoothed Coulomb friction (docs/physics/conventions.md, skid-steer notes), and the fast
branch-free ``atan`` and ``sincos`` that it and the dynamic models' derivatives use.

``sincos`` and ``atan`` give libm's values to within 2 ulp (tested against ``math``) at about
half the cost of the libm calls: one shared argument reduction for sin and cos, and a rational
arctan without libm's extra-precision paths (the standard Cephes algorithms). Both are written
without branches (every case computed, one selected), so a loop over a block of robots
vectorises (``integrators.rk4_block``); libm's calls would stop it.
"""

from __future__ import annotations

import math

import numpy as np

from wheelgym.integrators import fma, llvm_inline

PIO2_1 = 1.57079625129699707031  # pi/2 in three parts (Cody-Waite; k * PIO2_1 exact
PIO2_2 = 7.54978941586159635336e-8  # for |k| < 2^27, so |x| < 2e8 rad)
PIO2_3 = 5.39030285815811905290e-15
TWO_OVER_PI = 0.63661977236758134308
TAN_3PI_8 = 2.41421356237309504880
ATAN_MOREBITS = 6.123233995736765886130e-17


@llvm_inline
def sincos(x):  # pragma: no cover - compiled
    """``(sin x, cos x)`` to 2 ulp for ``|x| < 2e8`` (near the zeros to ``1e-31 |x|``, the
    accuracy of the reduction); Cephes polynomials on ``|r| <= pi/4``, by fused
    multiply-adds."""
    # np.floor, not math.floor: numba's math.floor returns an int (Python's semantics), and
    # the float -> int -> float round trip has no vector instruction, so every lane of the block
    # kernels went through scalar conversions (ThreeWheel's block derivative 47.4 -> 35.4 ns a
    # robot with np.floor; the same values)
    k = np.floor(x * TWO_OVER_PI + 0.5)
    r = fma(-k, PIO2_3, fma(-k, PIO2_2, fma(-k, PIO2_1, x)))
    z = r * r
    ps = fma(fma(fma(fma(fma(1.58962301576546568060e-10, z, -2.50507477628578072866e-8), z,
                         2.75573136213857245213e-6), z, -1.98412698295895385996e-4), z,
                 8.33333333332211858878e-3), z, -1.66666666666666307295e-1)
    s = fma(r * z, ps, r)
    pc = fma(fma(fma(fma(fma(-1.13585365213876817300e-11, z, 2.08757008419747316778e-9), z,
                         -2.75573141792967388112e-7), z, 2.48015872888517045348e-5), z,
                 -1.38888888888730564116e-3), z, 4.16666666666665929218e-2)
    c = fma(z * z, pc, fma(-0.5, z, 1.0))
    # quadrant q = k mod 4 picks (s, c), (c, -s), (-s, -c), (-c, s): selects on floats (no
    # branch, no int conversion), so the block kernels vectorise (integrators.rk4_block)
    q = k - 4.0 * np.floor(0.25 * k)
    swap = q == 1.0 or q == 3.0
    a = c if swap else s
    b = s if swap else c
    a = -a if q >= 2.0 else a
    b = -b if (q == 1.0 or q == 2.0) else b
    return a, b


@llvm_inline
def atan(x):  # pragma: no cover - compiled
    """``arctan x`` to 1 ulp (Cephes: reduction to ``|t| <= 0.66``, rational 4/5 fit, by fused
    multiply-adds)."""
    ax = abs(x)
    # the three reductions computed and selected (branch-free, so the block kernels
    # vectorise); no division by zero
    big = ax > TAN_3PI_8
    mid = ax > 0.66
    # one division for the three reductions: -1 / ax, (ax - 1) / (ax + 1), or ax / 1 (exact,
    # the same bits as ax)
    t = ((-1.0 if big else (ax - 1.0 if mid else ax))
         / (ax if big else (ax + 1.0 if mid else 1.0)))
    y = 0.5 * math.pi if big else (0.25 * math.pi if mid else 0.0)
    extra = ATAN_MOREBITS if big else (0.5 * ATAN_MOREBITS if mid else 0.0)
    z = t * t
    num = fma(fma(fma(fma(-8.750608600031904122785e-1, z, -1.615753718733365076637e1), z,
                      -7.500855792314704667340e1), z, -1.228866684490136173410e2), z,
              -6.485021904942025371773e1)
    den = fma(fma(fma(fma(z + 2.485846490142306297962e1, z, 1.650270098316988542046e2), z,
                      4.328810604912902668951e2), z, 4.853903996359136964868e2), z,
              1.945506571482613964425e2)
    r = y + (fma(t, z * num / den, t) + extra)
    return r if x >= 0.0 else -r


@llvm_inline
def sgn_s(s, k_s):  # pragma: no cover - compiled
    """Smoothed sign ``(2/pi) arctan(k_s s)`` (docs/physics/conventions.md); in (-1, 1)."""
    return TWO_OVER_PI * atan(k_s * s)


@llvm_inline
def dsgn_s(s, k_s):  # pragma: no cover - compiled
    """Derivative of :func:`sgn_s` with respect to ``s``; largest, ``2 k_s / pi``, at 0."""
    ks = k_s * s
    return TWO_OVER_PI * k_s / (1.0 + ks * ks)
