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

from collections.abc import Callable
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
    u, bsq, d2, a, b = (np.empty(shape) for _ in range(5))
    w = np.empty(shape, dtype=complex)
    with np.errstate(invalid="ignore"):
        coefficient(np.ascontiguousarray(np.broadcast_to(e, shape)), w, d2, u, a, b, bsq)(half_diff, lik2, sign)
    return zi + w * e, DyadTerms(e, u, a, b, bsq, w)


def coefficient(e: np.ndarray, w: np.ndarray, d2: np.ndarray, u: np.ndarray, a: np.ndarray, b: np.ndarray,
                bsq: np.ndarray | None = None) -> Callable[[np.ndarray, np.ndarray, np.ndarray], None]:
    """The kernel computing w = A + iB (the module docstring's formula, written once) from
    ``e`` = z_j − z_i, every view bound once: called with ``(half_diff, lik2, sign)`` (R, T)
    or (R, 1) each, it forms A and B in ``a`` and ``b`` and copies them into ``w`` (numpy's
    loops over w.real and w.imag, every other double, cost more than the two copies, from a
    few values on).

    ``e``, ``w`` (R, T) complex, C-contiguous (``w`` is scratch for |e|² first); ``d2``, ``u``,
    ``a``, ``b`` (R, T) real buffers, left holding A², 1/d², A and B; ``bsq`` a buffer kept
    holding B² (else B² is formed in ``b``). NaN where the triangle cannot be closed (the
    caller silences numpy's warning: an ``np.errstate`` per call would cost more than a small batch).
    """
    squares, parts, wr, wi = e.view(float), w.view(float), w.real, w.imag
    bsq = b if bsq is None else bsq
    copyto = np.copyto
    one, half = np.array(1.0), np.array(0.5)  # 0-d arrays: a Python float operand costs a conversion per call
    square, add, divide, multiply, subtract, sqrt = np.square, np.add, np.divide, np.multiply, np.subtract, np.sqrt

    def kernel(half_diff: np.ndarray, lik2: np.ndarray, sign: np.ndarray) -> None:
        square(squares, out=parts)
        add(wr, wi, out=d2)  # |e|² = Re² + Im²
        divide(one, d2, out=u)
        multiply(half_diff, u, out=a)
        add(a, half, out=a)
        multiply(lik2, u, out=bsq)
        multiply(a, a, out=d2)
        subtract(bsq, d2, out=bsq)
        sqrt(bsq, out=b)
        multiply(b, sign, out=b)
        copyto(wr, a)
        copyto(wi, b)
    return kernel


@dataclass
class Rates:
    """Scratch buffers of :func:`dyad_rates` for a batch of R dyads over samples S: ``g``, ``c``,
    ``t`` (R, *S) complex; ``P`` (n, R, *S) complex for n derivative orders; ``s``, ``gf``, ``q``
    (R, *S) real. ``c`` holds iω: its real part is zeroed when the kernel is made and the kernel
    writes only its imaginary part, so a ``c`` no one else writes (``kept``) is not zeroed again
    per call. ``s`` may be the kernel's ``b`` (s = u/B is formed in place), ``g`` its ``E[0]``
    (g = f − e is formed in place), ``t``, ``gf``, ``q`` buffers of the positions' terms spent before
    the rates, ``P`` the kernel's ``out`` (each order's product is spent before its rate is
    written): less memory touched per call."""

    g: np.ndarray
    c: np.ndarray
    t: np.ndarray
    P: np.ndarray
    s: np.ndarray
    gf: np.ndarray
    q: np.ndarray
    kept: bool = False


def dyad_rates(E: np.ndarray, f: np.ndarray, u: np.ndarray, a: np.ndarray, b: np.ndarray,
               lik2: np.ndarray, out: np.ndarray, r: Rates) -> None:
    """What the rebuilt joints' velocities (and accelerations) add to joint i's, into ``out``
    (no allocation): one call of :func:`rates`' kernel."""
    rates(E, f, u, a, b, out, r)(lik2)


def rates(E: np.ndarray, f: np.ndarray, u: np.ndarray, a: np.ndarray, b: np.ndarray, out: np.ndarray,
          r: Rates) -> Callable[[np.ndarray], None]:
    """The kernel of a dyad batch's rates, every view bound once: called with ``lik2`` = l_ik²,
    it writes ż_k − ż_i (and z̈_k − z̈_i) into ``out``.

    ``E`` (n+1, R, *S): e = z_j − z_i and its first n derivatives; ``f`` = z_k − z_i, ``u`` =
    1/d², ``a`` = A, ``b`` = B (R, *S) from the positions; ``out`` (n, R, *S) complex; n = 1 or
    2; ``r``'s complex buffers C-contiguous.

    Joint k turns with link (i, k) at the rate ω: ż_k = ż_i + iω·f. With g = z_k − z_j, whose
    length is kept too (g·ġ = 0, · the dot product of the plane), ω = s·(g·ė) with s = u/B,
    since Im(ḡ·f) = −B·d². Differentiating g·ġ = 0 once more: z̈_k = z̈_i + (iω̇ − ω²)·f with
    ω̇ = s·(g·ë + ω²·(g·f) − |ġ|²), ġ = iω·f − ė and g·f = l_ik² − A·d². Linear in the inputs'
    derivatives; every product is complex × complex or real × real (numpy casts mixed ones
    through a buffer, twice as slow). −ω² is the real part of (iω)², exactly: the product
    c·c writes it in place of a square and a negation.
    """
    D, e0, P, c, g, s = E[1:], E[0], r.P[: E.shape[0] - 1], r.c, r.g, r.s
    dot, omega, spin, first = P[0].real, c.imag, c.real, out[0]
    subtract, conjugate, multiply, divide, add, square = (np.subtract, np.conjugate, np.multiply, np.divide,
                                                          np.add, np.square)
    spin.fill(0.0)
    kept = r.kept

    def velocity() -> None:
        subtract(f, e0, out=g)
        conjugate(g, out=g)
        multiply(g, D, out=P)  # Re P = g·ė (, g·ë)
        divide(u, b, out=s)
        multiply(dot, s, out=omega)  # c = iω
        if not kept:
            spin.fill(0.0)
        multiply(c, f, out=first)
    if D.shape[0] < 2:
        return lambda lik2: velocity()
    dg, q, gf, d1, squares, parts, gr, gi = r.t, r.q, r.gf, D[0], r.t.view(float), g.view(float), g.real, g.imag
    dot2, second = P[1].real, out[1]

    def kernel(lik2: np.ndarray) -> None:
        velocity()
        subtract(first, d1, out=dg)  # ġ = iω·f − ė
        square(squares, out=parts)
        add(gr, gi, out=q)  # |ġ|²
        multiply(c, c, out=g)  # g = −ω² + 0i, the real part of iω̇ − ω²
        divide(a, u, out=gf)
        subtract(lik2, gf, out=gf)  # g·f
        multiply(gf, gr, out=gf)  # −ω²·(g·f)
        subtract(dot2, gf, out=gf)
        subtract(gf, q, out=gf)
        multiply(gf, s, out=gi)  # g = iω̇ − ω²
        multiply(g, f, out=second)
    return kernel


def singularity_distance(bsq: np.ndarray, u: np.ndarray, lengths: np.ndarray, tmp: np.ndarray,
                          out: np.ndarray) -> np.ndarray:
    """d_s = sin²α into ``out``, α the angle at the rebuilt joint (LinkEdit Eq. 6); < 0 where it
    cannot close. ``bsq`` = B², ``u`` = 1/d² (R, T), ``lengths`` = l_ik²·l_jk² (R, T) or (R, 1),
    ``tmp`` a real (R, T) buffer.

    With h = |B|·d the triangle's height over i→j, sin α = d·h/(l_ik·l_jk): d_s = B²/(u²·l_ik²·l_jk²).
    """
    np.multiply(u, u, out=tmp)
    tmp *= lengths
    return np.divide(bsq, tmp, out=out)
