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
    w = np.empty(shape, dtype=complex)
    with np.errstate(invalid="ignore"):
        dyad_coefficient(e, half_diff, lik2, sign, w, np.empty(shape), u, a, b, bsq)
    return zi + w * e, DyadTerms(e, u, a, b, bsq, w)


def dyad_coefficient(e: np.ndarray, half_diff: np.ndarray, lik2: np.ndarray, sign: np.ndarray,
                     w: np.ndarray | None, d2: np.ndarray, u: np.ndarray, a: np.ndarray, b: np.ndarray,
                     bsq: np.ndarray | None = None) -> None:
    """w = A + iB (the module docstring's formula, written once), computed into the given
    buffers (no allocation). With ``w`` None, ``a`` and ``b`` are the caller's
    w.real and w.imag (views): w is then written in place with no copy.

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
    if w is not None:
        w.real = a
        w.imag = b


@dataclass
class Rates:
    """Scratch buffers of :func:`dyad_rates` for a batch of R dyads over samples S: ``g``, ``c``,
    ``t`` (R, *S) complex; ``P`` (n, R, *S) complex for n derivative orders; ``s``, ``gf``,
    ``w2``, ``q`` (R, *S) real."""

    g: np.ndarray
    c: np.ndarray
    t: np.ndarray
    P: np.ndarray
    s: np.ndarray
    gf: np.ndarray
    w2: np.ndarray
    q: np.ndarray


def dyad_rates(E: np.ndarray, Zi: np.ndarray, f: np.ndarray, u: np.ndarray, a: np.ndarray, b: np.ndarray,
               lik2: np.ndarray, out: np.ndarray, r: Rates) -> None:
    """Velocities (and accelerations) of a dyad batch's rebuilt joints, into ``out`` (no allocation).

    ``E`` (n+1, R, *S): e = z_j − z_i and its first n derivatives; ``Zi`` (n+1, R, *S): z_i and
    its derivatives; ``f`` = z_k − z_i, ``u`` = 1/d², ``a`` = A, ``b`` = B (R, *S) from the
    positions, ``lik2`` = l_ik²; ``out`` (n, R, *S) complex receives ż_k (and z̈_k); n = 1 or 2.

    Joint k turns with link (i, k) at the rate ω: ż_k = ż_i + iω·f. With g = z_k − z_j, whose
    length is kept too (g·ġ = 0, · the dot product of the plane), ω = s·(g·ė) with s = u/B,
    since Im(ḡ·f) = −B·d². Differentiating g·ġ = 0 once more: z̈_k = z̈_i + (iω̇ − ω²)·f with
    ω̇ = s·(g·ë + ω²·(g·f) − |ġ|²), ġ = iω·f − ė and g·f = l_ik² − A·d². Linear in the inputs'
    derivatives; every product is complex × complex or real × real (numpy casts mixed ones
    through a buffer, twice as slow).
    """
    D, P, c = E[1:], r.P[: E.shape[0] - 1], r.c
    np.subtract(f, E[0], out=r.g)
    np.conjugate(r.g, out=r.g)
    np.multiply(r.g, D, out=P)  # Re P = g·ė (, g·ë)
    np.divide(u, b, out=r.s)
    np.multiply(P[0].real, r.s, out=c.imag)  # c = iω
    c.real.fill(0.0)
    np.multiply(c, f, out=r.t)
    np.add(Zi[1], r.t, out=out[0])
    if D.shape[0] < 2:
        return
    dg, q, w2 = r.t, r.q, r.w2
    dg -= D[0]  # ġ = iω·f − ė
    np.multiply(dg.real, dg.real, out=q)
    np.multiply(dg.imag, dg.imag, out=w2)
    q += w2  # |ġ|²
    np.divide(a, u, out=r.gf)
    np.subtract(lik2, r.gf, out=r.gf)  # g·f
    np.multiply(c.imag, c.imag, out=w2)  # ω²
    r.gf *= w2
    r.gf += P[1].real
    r.gf -= q
    np.multiply(r.gf, r.s, out=c.imag)  # ω̇
    np.negative(w2, out=c.real)
    np.multiply(c, f, out=r.t)
    np.add(Zi[2], r.t, out=out[1])


def singularity_distance(bsq: np.ndarray, u: np.ndarray, lik2: np.ndarray, ljk2: np.ndarray,
                          tmp: np.ndarray, out: np.ndarray) -> np.ndarray:
    """d_s = sin²α into ``out``, α the angle at the rebuilt joint (LinkEdit Eq. 6); < 0 where it
    cannot close. ``bsq`` = B², ``u`` = 1/d² (R, T), ``tmp`` a real (R, T) buffer.

    With h = |B|·d the triangle's height over i→j, sin α = d·h/(l_ik·l_jk).
    """
    np.multiply(u, u, out=tmp)
    tmp *= lik2
    tmp *= ljk2
    return np.divide(bsq, tmp, out=out)
