"""Constraint rows of a linkage: rigid links, sliders and a linear input, as one batched form.

Every row is bilinear in the joint positions (complex z = x + iy):

    F_r(z) = part_r( conj(D_r)·E_r ) − rhs_r − drive_r·s,      part = Re or Im,

with D_r, E_r affine in z (``dc @ z + d0``, ``ec @ z + e0``) and s the linear input's
displacement. That one form covers a link's distance row (D = E = z_i − z_j, Re), its rigid
rows (D = 1, E = z_k − z_i − c·(z_j − z_i), Re and Im), a pin in a slot (Im of the slot
direction times the joint's offset from the slot line, both in the guide's frame), a
translating link (its rotation equals the guide's, and its first joint is on the line) and the
linear input (Re: the joint's position along the slot equals s). Derivatives are exact and
batched over T samples: the gradient of row r with respect to z_n is
E·conj(dc_rn) + D·conj(ec_rn) (Re) or i·(D·conj(ec_rn) − E·conj(dc_rn)) (Im), and the second
directional derivative along v is 2·part(conj(dc @ v)·(ec @ v)).

Rows of K linkages of one topology (:func:`linkage_rows` at K rest poses) carry a linkage axis
on every coefficient (``dc`` (m, J, K), ``d0`` (m, K), …) and act on positions (J, K, T). The
rows' derivatives along C rest-pose directions (:func:`linkage_rows_tangent`) carry a direction
axis the same way (``dc`` (m, J, C)) and act on one linkage's positions (J, T): terms (m, C, T).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from linkedit.planar.graph import LinkageGraph


@dataclass(frozen=True)
class Rows:
    """m constraint rows over J joints (see module docstring); L: an optional linkage axis (K,)."""

    imag: np.ndarray  # (m,) bool: Im rows (else Re)
    dc: np.ndarray  # (m, J, *L) complex
    d0: np.ndarray  # (m, *L) complex
    ec: np.ndarray  # (m, J, *L) complex
    e0: np.ndarray  # (m, *L) complex
    rhs: np.ndarray  # (m, *L) float
    drive: np.ndarray  # (m,) float: coefficient of the linear input s
    joints: tuple[frozenset[int], ...]  # joints each row involves
    labels: tuple[str, ...]  # what each row keeps ("link rod", "slider piston", …)

    @property
    def m(self) -> int:
        return int(self.imag.size)

    def take(self, which: np.ndarray) -> "Rows":
        """The rows ``which`` (indices or a boolean mask)."""
        idx = np.flatnonzero(which) if np.asarray(which).dtype == bool else np.asarray(which, dtype=int)
        return Rows(self.imag[idx], self.dc[idx], self.d0[idx], self.ec[idx], self.e0[idx], self.rhs[idx],
                    self.drive[idx], tuple(self.joints[i] for i in idx), tuple(self.labels[i] for i in idx))

    def columns(self, cols: np.ndarray) -> "Rows":
        """The same rows over the joints ``cols`` only (the others' coefficients dropped)."""
        return Rows(self.imag, self.dc[:, cols], self.d0, self.ec[:, cols], self.e0, self.rhs, self.drive,
                    self.joints, self.labels)

    def _part(self, w: np.ndarray) -> np.ndarray:
        return np.where(_col(self.imag, w.ndim), w.imag, w.real)

    @staticmethod
    def _times(c: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Σ_j c[:, j]·z[j]: (m, *L, T) from coefficients ``c`` (m, J, *L) and ``z`` (J, *L, T), or
        (m, C, T) from C directions' ``c`` (m, J, C) and one linkage's ``z`` (J, T) (a matrix
        product per direction: the bits of each direction alone)."""
        if z.ndim == 2 and c.ndim == 3:
            return np.moveaxis(np.ascontiguousarray(np.moveaxis(c, 2, 0)) @ z, 0, 1)
        if z.ndim == 2:
            return c @ z
        if c.ndim == 2:
            return np.tensordot(c, z, axes=(1, 0))
        return np.einsum("mjk,jkt->mkt", c, z)

    def terms(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """D and E, (m, *L, T) complex, at joint positions ``z`` (J, *L, T)."""
        d, e = self._times(self.dc, z), self._times(self.ec, z)
        return d + _col(self.d0, d.ndim), e + _col(self.e0, e.ndim)

    def residual(self, z: np.ndarray, s: np.ndarray | float = 0.0) -> np.ndarray:
        """F (m, *L, T) at joint positions ``z`` (J, *L, T) and input displacement ``s`` (*L, T)."""
        d, e = self.terms(z)
        return self._part(np.conj(d) * e) - _col(self.rhs, z.ndim) - _col(self.drive, z.ndim) * s

    def first(self, z: np.ndarray, v: np.ndarray, along: bool = False) -> np.ndarray:
        """Directional derivative dF[v] (m, *L, T) at ``z`` along joint velocities ``v`` (J, *L, T);
        with ``along``, along each of C directions' ``v`` (C, J, T) at one linkage's ``z`` (J, T):
        (m, C, T) (a matrix product per direction)."""
        d, e = self.terms(z)
        if along:
            dv, ev = (np.moveaxis(c @ v, 0, 1) for c in (self.dc, self.ec))
            d, e = d[:, None], e[:, None]
        else:
            dv, ev = self._times(self.dc, v), self._times(self.ec, v)
        return self._part(np.conj(dv) * e + np.conj(d) * ev)

    def second(self, v: np.ndarray) -> np.ndarray:
        """Second directional derivative d²F[v, v] (m, *L, T) (constant in z: the rows are bilinear)."""
        return 2.0 * self._part(np.conj(self._times(self.dc, v)) * self._times(self.ec, v))

    def jacobian(self, z: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """∂F/∂(x, y) of the joints ``cols`` (n,), shape (*L, T, m, 2n): columns x_0, y_0, x_1, …"""
        d, e = self.terms(z)
        dcn, ecn = (_col(np.conj(c[:, cols]), z.ndim + 1) for c in (self.dc, self.ec))
        g_re = e[:, None] * dcn + d[:, None] * ecn
        g_im = 1j * (d[:, None] * ecn - e[:, None] * dcn)
        g = np.where(_col(self.imag, z.ndim + 1), g_im, g_re)  # (m, n, *L, T)
        out = np.stack([g.real, g.imag], axis=2).reshape(self.m, 2 * len(cols), *z.shape[1:])
        return np.moveaxis(out, (0, 1), (-2, -1))


def _col(a: np.ndarray, ndim: int) -> np.ndarray:
    """``a`` with trailing axes of length 1 up to ``ndim`` axes (a row's constant over the samples)."""
    return a.reshape(a.shape + (1,) * (ndim - a.ndim))


Coef = complex | np.ndarray  #: a row's coefficient: one linkage's, or (K,) of K linkages'


class _Builder:
    def __init__(self, n_joints: int, linkages: tuple[int, ...] = ()) -> None:
        self.J = n_joints
        self.L = linkages  #: () or (K,): coefficients of K linkages
        self.rows: list[tuple] = []

    def add(self, imag: bool, d: Mapping[int, Coef], d0: Coef, e: Mapping[int, Coef], e0: Coef,
            label: str, rhs: float | np.ndarray = 0.0, drive: float = 0.0) -> None:
        self.rows.append((imag, d, d0, e, e0, rhs, drive, label))

    def _stack(self, values: list, dtype: type) -> np.ndarray:
        if self.L:
            values = [np.broadcast_to(v, self.L) for v in values]
        return np.array(values, dtype=dtype).reshape(len(values), *self.L)

    def build(self) -> Rows:
        m = len(self.rows)
        dc, ec = (np.zeros((m, self.J, *self.L), dtype=complex) for _ in range(2))
        for r, (_, d, _, e, *_rest) in enumerate(self.rows):
            for j, c in d.items():
                dc[r, j] += c
            for j, c in e.items():
                ec[r, j] += c
        if self.L:  # a joint is in a row where any linkage's coefficient is not 0
            joints = tuple(frozenset(j for j in (*d, *e) if np.any(d.get(j, 0) != 0) or np.any(e.get(j, 0) != 0))
                           for (_, d, _, e, *_r) in self.rows)
        else:
            joints = tuple(frozenset(j for j in (*d, *e) if (d.get(j, 0) != 0 or e.get(j, 0) != 0))
                           for (_, d, _, e, *_r) in self.rows)
        return Rows(imag=np.array([r[0] for r in self.rows], dtype=bool).reshape(m), dc=dc,
                    d0=self._stack([r[2] for r in self.rows], complex), ec=ec,
                    e0=self._stack([r[4] for r in self.rows], complex),
                    rhs=self._stack([r[5] for r in self.rows], float),
                    drive=np.array([r[6] for r in self.rows], dtype=float).reshape(m),
                    joints=joints, labels=tuple(r[7] for r in self.rows))


def _value(c: Coef) -> Coef:
    """One linkage's coefficient as a Python complex (its arithmetic, as the rows were always
    built), K linkages' (K,) as they are."""
    return c if isinstance(c, np.ndarray) else complex(c)


def _frame(graph: LinkageGraph, link: int, z: np.ndarray) -> tuple[int, int, Coef]:
    """(a, b, m): the frame pair of ``link`` and m = z̄_b − z̄_a; (−1, −1, 1) for the frame."""
    if graph.fixed(link):
        return -1, -1, 1.0 + 0j
    a, b = graph.frame_pair(link)
    return a, b, _value(z[b] - z[a])


def _on_guide(graph: LinkageGraph, guide: int, z: np.ndarray, point: Coef, direction: complex):
    """D (the line direction) and E (offset of a point from the line's rest point) in the guide's frame.

    Returns (d, d0, e_guide, e0): dicts of joint coefficients for D and for the guide part of E
    (the moving point is added by the caller with coefficient 1).
    """
    a, b, m = _frame(graph, guide, z)
    if a < 0:
        return {}, direction, {}, -point
    c = (point - z[a]) / m
    alpha = direction / m
    return {b: alpha, a: -alpha}, 0j, {a: -(1 - c), b: -c}, 0j


def _add(e: dict[int, complex], extra: dict[int, complex]) -> dict[int, complex]:
    out = dict(e)
    for j, c in extra.items():
        out[j] = out.get(j, 0) + c
    return out


def link_rows(builder: _Builder, graph: LinkageGraph, z: np.ndarray, li: int) -> None:
    """A link as a rigid body: a distance row for its frame pair, two rigid rows per other joint."""
    name = graph.link_names[li]
    i, j = graph.frame_pair(li)
    d = _value(z[i] - z[j])
    builder.add(False, {i: 1, j: -1}, 0j, {i: 1, j: -1}, 0j, f"link {name}", rhs=abs(d) ** 2)  # type: ignore[operator]
    for k in graph.links[li]:
        if k in (i, j):
            continue
        c = (z[k] - z[i]) / (z[j] - z[i])
        e = {k: 1.0 + 0j, i: -(1 - c), j: -c}
        builder.add(False, {}, 1.0 + 0j, e, 0j, f"link {name}")
        builder.add(True, {}, 1.0 + 0j, e, 0j, f"link {name}")


def slider_rows(builder: _Builder, graph: LinkageGraph, z: np.ndarray, n: int, with_drive: bool) -> None:
    """A slider's rows: one for a pin in a slot, two for a translating link (+1 when driven)."""
    s = graph.sliders[n]
    label = f"slider {s.name}"
    u = np.exp(1j * s.angle)
    if s.joint >= 0:
        d, d0, eg, e0 = _on_guide(graph, s.guide, z, _value(z[s.joint]), u)
        e = _add(eg, {s.joint: 1.0})
        builder.add(True, d, d0, e, e0, label)
        if with_drive and n == graph.drive:
            builder.add(False, d, d0, e, e0, f"linear input {s.name}", drive=1.0)
        return
    i, j = graph.frame_pair(s.link)
    a, b, m = _frame(graph, s.guide, z)
    lij = _value(z[j] - z[i])
    rot_d = ({b: 1 / m, a: -1 / m} if a >= 0 else {}), (0j if a >= 0 else 1.0 + 0j)
    builder.add(True, rot_d[0], rot_d[1], {j: 1 / lij, i: -1 / lij}, 0j, label)  # turns with its guide
    d, d0, eg, e0 = _on_guide(graph, s.guide, z, _value(z[i]), u)
    builder.add(True, d, d0, _add(eg, {i: 1.0}), e0, label)  # its frame joint stays on the line


def linkage_rows(graph: LinkageGraph, with_drive: bool = True, rest: np.ndarray | None = None) -> Rows:
    """Every constraint row of ``graph`` at its rest pose (links of ground joints only are skipped),
    or at the rest poses ``rest`` (J, K) complex of K linkages of its topology (rows with a linkage axis)."""
    z = graph.rest[:, 0] + 1j * graph.rest[:, 1] if rest is None else rest
    builder = _Builder(graph.n_joints, z.shape[1:])
    for li, link in enumerate(graph.links):
        if not graph.fixed(li):
            link_rows(builder, graph, z, li)
    for n in range(len(graph.sliders)):
        slider_rows(builder, graph, z, n, with_drive)
    return builder.build()


def _product(a: Coef, b: np.ndarray) -> np.ndarray:
    """a·b (C,) complex as a complex scalar times each b_c (no fused multiply-add): a tangent along
    C directions at once has the bits of each direction's alone."""
    out = np.empty(b.shape, dtype=complex)
    out.real = a.real * b.real - a.imag * b.imag
    out.imag = a.real * b.imag + a.imag * b.real
    return out


def _on_guide_tangent(graph: LinkageGraph, guide: int, z: np.ndarray, dz: np.ndarray, point: complex,
                      dpoint: np.ndarray, direction: complex):
    """Derivative of :func:`_on_guide`'s coefficients along the rest-pose tangents ``dz`` (J, C)."""
    a, b, m = _frame(graph, guide, z)
    if a < 0:
        return {}, 0j, {}, -dpoint
    dm = dz[b] - dz[a]
    c = (point - z[a]) / m
    dc = ((dpoint - dz[a]) - _product(c, dm)) / m
    dalpha = _product(-direction / m, dm) / m
    return {b: dalpha, a: -dalpha}, 0j, {a: dc, b: -dc}, 0j


def linkage_rows_tangent(graph: LinkageGraph, drest: np.ndarray, with_drive: bool = True) -> Rows:
    """d/dε of every coefficient of :func:`linkage_rows` when the rest pose moves along each of the
    C directions ``drest`` (J, C) complex: rows with a direction axis (``dc`` (m, J, C), …), row
    for row (``rhs`` holds d rhs/dε). With F = part(conj(D)·E) − rhs, the rows' derivative at
    fixed joint positions z is part(conj(D′)·E + conj(D)·E′) − rhs′ (:func:`rows_rest_derivative`)."""
    z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
    dz = np.asarray(drest, dtype=complex)
    builder = _Builder(graph.n_joints, dz.shape[1:])
    for li, link in enumerate(graph.links):
        if graph.fixed(li):
            continue
        name = graph.link_names[li]
        i, j = graph.frame_pair(li)
        d = complex(z[i] - z[j])
        builder.add(False, {}, 0j, {}, 0j, f"link {name}", rhs=2.0 * _product(d.conjugate(), dz[i] - dz[j]).real)
        for k in link:
            if k in (i, j):
                continue
            c = (z[k] - z[i]) / (z[j] - z[i])
            dc = ((dz[k] - dz[i]) - _product(c, dz[j] - dz[i])) / (z[j] - z[i])
            e = {i: dc, j: -dc}
            builder.add(False, {}, 0j, e, 0j, f"link {name}")
            builder.add(True, {}, 0j, e, 0j, f"link {name}")
    for n, s in enumerate(graph.sliders):
        label = f"slider {s.name}"
        u = np.exp(1j * s.angle)
        if s.joint >= 0:
            d, d0, e, e0 = _on_guide_tangent(graph, s.guide, z, dz, complex(z[s.joint]), dz[s.joint], u)
            builder.add(True, d, d0, e, e0, label)
            if with_drive and n == graph.drive:
                builder.add(False, d, d0, e, e0, f"linear input {s.name}")
            continue
        i, j = graph.frame_pair(s.link)
        a, b, m = _frame(graph, s.guide, z)
        lij = complex(z[j] - z[i])
        turn = np.array([complex(v) / lij / lij for v in dz[j] - dz[i]])  # Python's complex quotient, as always
        rot = {b: -(dz[b] - dz[a]) / m / m, a: (dz[b] - dz[a]) / m / m} if a >= 0 else {}
        builder.add(True, rot, 0j, {j: -turn, i: turn}, 0j, label)
        d, d0, e, e0 = _on_guide_tangent(graph, s.guide, z, dz, complex(z[i]), dz[i], u)
        builder.add(True, d, d0, e, e0, label)
    return builder.build()


def rows_rest_derivative(rows: Rows, tangent: Rows, z: np.ndarray) -> np.ndarray:
    """∂F/∂(rest pose)·ṙ (m, C, T) along C directions at joint positions ``z`` (J, T): ``tangent``
    from :func:`linkage_rows_tangent` (aligned with ``rows``)."""
    d, e = rows.terms(z)
    dd, de = tangent.terms(z)
    w = np.conj(dd) * e[:, None] + np.conj(d)[:, None] * de
    return rows._part(w) - _col(tangent.rhs, w.ndim)
