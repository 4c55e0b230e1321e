"""Rebuild a joint from two known neighbours: the law of cosines, batched.

Positions are complex numbers z = x + iy. With e = z_j − z_i and d² = |e|², joint k at
distances l_ik, l_jk from i, j is

    z_k = z_i + w·e,   w = A + iB,
    A = ½ + (l_ik² − l_jk²) / (2d²)            (projection of i→k on i→j, in units of d)
    B = s·sqrt(l_ik²/d² − A²)                   (height over i→j, in units of d)

which is LinkEdit's x_k = x_i + R(±φ)·l_ik·(x_j − x_i)/|x_j − x_i| with φ from the law of
cosines, written without trigonometry. s = ±1 is the orientation of triangle (i, j, k) at the
rest pose and never changes. B² < 0 means the triangle cannot be closed (lock-up).
A **rigid** rule (i, j, k on one link) has the constant w = (z̄_k − z̄_i)/(z̄_j − z̄_i).

Every function works on arrays of shape (R, T): R rules of one batch, T time samples; the
per-rule constants have shape (R, 1). Derivatives are with respect to the motor angle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class DyadTerms:
    """Intermediate values of a dyad batch, kept for derivatives and diagnostics. (R, T) each."""

    e: np.ndarray  # z_j − z_i (complex)
    u: np.ndarray  # 1 / d²
    a: np.ndarray  # A
    b: np.ndarray  # B (signed); NaN where the triangle cannot be closed
    bsq: np.ndarray  # B² (negative where the triangle cannot be closed)
    w: np.ndarray  # A + iB


def dyad(zi: np.ndarray, zj: np.ndarray, half_diff: np.ndarray, lik2: np.ndarray,
         sign: np.ndarray) -> tuple[np.ndarray, DyadTerms]:
    """Positions of the rebuilt joints, (R, T) complex, and the terms for derivatives.

    ``half_diff`` = (l_ik² − l_jk²)/2, ``lik2`` = l_ik², ``sign`` = s: each (R, 1).
    """
    e = zj - zi
    shape = np.broadcast_shapes(e.shape, np.shape(half_diff))
    u, a, bsq, b = (np.empty(shape) for _ in range(4))
    with np.errstate(invalid="ignore"):
        w = dyad_coefficient(e, half_diff, lik2, sign, np.empty(shape, dtype=complex), np.empty(shape), u, a, b, bsq)
    return zi + w * e, DyadTerms(e, u, a, b, bsq, w)


def dyad_coefficient(e: np.ndarray, half_diff: np.ndarray, lik2: np.ndarray, sign: np.ndarray,
                     w: np.ndarray, d2: np.ndarray, u: np.ndarray, a: np.ndarray, b: np.ndarray,
                     bsq: np.ndarray | None = None) -> np.ndarray:
    """w = A + iB (the module docstring's formula, written once), computed into the given
    buffers (no allocation); returns ``w``.

    ``e`` = z_j − z_i (R, T) complex; ``w`` (R, T) complex and ``d2``, ``u``, ``a``, ``b`` (R, T)
    real buffers, left holding 1/d², A and B; ``bsq`` a buffer kept holding B² (else B² is
    formed in ``b``). NaN where the triangle cannot be closed (the caller silences numpy's
    warning: an ``np.errstate`` per call would cost more than a small batch).
    """
    bsq = b if bsq is None else bsq
    np.multiply(e.real, e.real, out=d2)
    np.multiply(e.imag, e.imag, out=u)
    d2 += u
    np.divide(1.0, d2, out=u)
    np.multiply(half_diff, u, out=a)
    a += 0.5
    np.multiply(lik2, u, out=bsq)
    np.multiply(a, a, out=d2)
    bsq -= d2
    np.sqrt(bsq, out=b)
    b *= sign
    w.real = a
    w.imag = b
    return w


def dyad_velocity(t: DyadTerms, dzi: np.ndarray, dzj: np.ndarray, half_diff: np.ndarray,
                  lik2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """First derivative of a dyad: returns (dz_k, de, du, dw) for the second derivative."""
    de = dzj - dzi
    dd2 = 2.0 * (t.e.real * de.real + t.e.imag * de.imag)
    du = -dd2 * t.u * t.u
    da = half_diff * du
    dbsq = lik2 * du - 2.0 * t.a * da
    db = dbsq / (2.0 * t.b)
    dw = da + 1j * db
    return dzi + dw * t.e + t.w * de, de, du, dw


def dyad_acceleration(t: DyadTerms, de: np.ndarray, du: np.ndarray, dw: np.ndarray,
                      ddzi: np.ndarray, ddzj: np.ndarray, half_diff: np.ndarray,
                      lik2: np.ndarray) -> np.ndarray:
    """Second derivative of a dyad's rebuilt joint, (R, T) complex."""
    dde = ddzj - ddzi
    dd2 = 2.0 * (t.e.real * de.real + t.e.imag * de.imag)
    ddd2 = 2.0 * (de.real * de.real + de.imag * de.imag + t.e.real * dde.real + t.e.imag * dde.imag)
    ddu = -ddd2 * t.u * t.u + 2.0 * dd2 * dd2 * t.u ** 3
    da = dw.real
    db = dw.imag
    dda = half_diff * ddu
    ddbsq = lik2 * ddu - 2.0 * da * da - 2.0 * t.a * dda
    ddb = (ddbsq - 2.0 * db * db) / (2.0 * t.b)
    ddw = dda + 1j * ddb
    return ddzi + ddw * t.e + 2.0 * dw * de + t.w * dde


def rigid(zi: np.ndarray, zj: np.ndarray, coef: np.ndarray) -> np.ndarray:
    """A joint fixed in the frame of link (i, j): z_k = z_i + c·(z_j − z_i); also for derivatives."""
    return zi + coef * (zj - zi)


def singularity_distance(t: DyadTerms, lik2: np.ndarray, ljk2: np.ndarray) -> np.ndarray:
    """d_s = sin²α, α the angle at the rebuilt joint (LinkEdit Eq. 6); < 0 where it cannot close.

    With h = |B|·d the triangle's height over i→j, sin α = d·h/(l_ik·l_jk).
    """
    return t.bsq / (t.u * t.u * lik2 * ljk2)
