"""The comparison workflow behind ``linkedit features`` and ``linkedit compare-curves``.

Loaded curves → one :class:`~linkedit.curves.descriptors.Descriptors` → term matrices → weighted
distance, nearest neighbours, rankings and learned weights.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import cast

import numpy as np

from linkedit.curves.descriptors import DEFAULT_HARMONICS, DEFAULT_SAMPLES, Descriptors, describe_ragged
from linkedit.curves.distance import alignment, term_distances, term_names, weighted
from linkedit.curves.partial import partial_placement, partial_placement3
from linkedit.curves.smooth import smooth as smooth_curve
from linkedit.curves.learn import Inseparable, LearnedWeights, learn_weights
from linkedit.curves.sources import Curve
from linkedit.errors import InputError
from linkedit.spec.common import HARMONICS_RANGE, SAMPLES_RANGE, require_count


def describe_curves(curves: list[Curve], *, samples: int = DEFAULT_SAMPLES, harmonics: int = DEFAULT_HARMONICS,
                    anchor: np.ndarray | None = None, smooth: float = 0.0) -> Descriptors:
    """Describe loaded curves (all 2D or all 3D); ``anchor`` applies to curves without their own;
    ``smooth`` > 0 smooths every curve first (σ as a fraction of its points, :mod:`linkedit.curves.smooth`).
    InputError for no curves, or ``samples`` / ``harmonics`` outside the CLI's ranges (``specs/curve-set.md``)."""
    if not curves:
        raise InputError("no curves to describe: give at least one curve")
    require_count(samples, "samples", *SAMPLES_RANGE)
    require_count(harmonics, "harmonics", *HARMONICS_RANGE)
    dims = {c.points.shape[1] for c in curves}
    if len(dims) > 1:
        two = next(c for c in curves if c.points.shape[1] == 2)
        three = next(c for c in curves if c.points.shape[1] == 3)
        raise InputError(f"2D and 3D curves cannot be compared together ({two.name} is 2D, {three.name} is 3D)",
                         file=three.origin)
    dim = dims.pop()
    if anchor is not None and len(anchor) != dim:
        raise InputError(f"a {len(anchor)}D anchor for {dim}D curves", field="--anchor")
    anchors = [c.anchor if c.anchor is not None else anchor for c in curves]
    if any(a is None for a in anchors) and any(a is not None for a in anchors):
        missing = next(c for c, a in zip(curves, anchors) if a is None)
        raise InputError("some curves have an anchor and this one has none (give --anchor for the rest)",
                         file=missing.origin)
    with np.errstate(all="ignore"):  # a non-finite result is reported below, naming the curve
        desc = describe_ragged([smooth_curve(c.points, c.closed, smooth) for c in curves], [c.closed for c in curves],
                               samples=samples, harmonics=harmonics,
                               anchors=None if anchors[0] is None else cast(list[np.ndarray], anchors))
    check_finite(curves, desc)
    return desc


def check_finite(curves: list[Curve], desc: Descriptors) -> None:
    """Every descriptor of every curve a finite number, or an InputError naming the first curve that is not."""
    n = desc.normalized
    parts = [desc.features, desc.turning, desc.efd, n.points, n.centroid, n.frame, n.scale]
    finite = np.logical_and.reduce([np.isfinite(a.reshape(len(curves), -1)).all(axis=1) for a in parts])
    if not finite.all():
        c = curves[int(np.argmin(finite))]
        bad = [name for name, v in zip(desc.names, desc.features[int(np.argmin(finite))]) if not np.isfinite(v)]
        raise InputError(f"curve {c.name}: its descriptors are not finite numbers"
                         + (f" ({', '.join(bad)})" if bad else "") + " — the coordinates (or the anchor) span more "
                         "than the floating-point range", file=c.origin)


def resolve_weights(desc: Descriptors, weights: Mapping[str, float] | None, *, field: str = "--weights") -> dict[str, float]:
    """The weights of every term of ``desc`` (default all 1); terms of another kind of curve are an error."""
    terms = term_names(desc)
    if weights is None:
        return dict.fromkeys(terms, 1.0)
    for name in weights:
        if name not in terms:
            raise InputError(f"term {name!r} does not apply to these curves (their terms: {', '.join(terms)})",
                             field=(field, name))
    out = {name: float(weights.get(name, 0.0)) for name in terms}
    if not any(out.values()):
        raise InputError("every weight is 0", field=field)
    return out


def distances(desc: Descriptors, weights: Mapping[str, float], other: Descriptors | None = None, *,
              mirror: bool = False, partial: bool = False) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Weighted distance matrix (C, C) of ``desc`` (or (C, C') against ``other``) and the term matrices."""
    terms = term_distances(desc, other, mirror=mirror, partial=partial)
    return weighted(terms, weights), terms


def placements(query: Descriptors, library: Descriptors, *, mirror: bool = False, partial: bool = False) -> list[dict]:
    """The similarity transform placing each library curve onto the (one) query, in input units:
    p_query ≈ translation + scale · matrix · p_library, and where the query's start meets the
    library curve (``phase``: a fraction of the library curve's length from its canonical start,
    ``reversed``: travelled the other way). ``partial``: an open query is placed on the best-fitting
    stretch of each closed library curve (:func:`~linkedit.curves.partial.partial_placement`)."""
    al = alignment(query.points[0], bool(query.closed[0]), library.points, library.closed, mirror=mirror)
    qn, ln = query.normalized, library.normalized
    n, dim = library.points.shape[1], library.points.shape[2]
    out = []
    for j in range(len(library)):
        if partial and not qn.closed[0] and ln.closed[j]:
            row = _partial_row(query, library, j, mirror)
        else:
            matrix = qn.frame[0] @ al.rotation[j] @ ln.frame[j].T
            scale = float(qn.scale[0] / ln.scale[j])
            row = {"scale": scale, "matrix": matrix.tolist(),
                   "translation": (qn.centroid[0] - scale * matrix @ ln.centroid[j]).tolist(),
                   "phase": float(((-al.shift[j] if al.reversed[j] else al.shift[j]) / n) % 1.0),
                   "reversed": bool(al.reversed[j]), "mirrored": bool(al.mirrored[j])}
        if dim == 2:
            matrix = np.array(row["matrix"])
            proper = matrix @ np.diag([1.0, -1.0]) if row["mirrored"] else matrix
            row["rotation_deg"] = float(np.degrees(np.arctan2(proper[1, 0], proper[0, 0])))
        out.append(row)
    return out


def _partial_row(query: Descriptors, library: Descriptors, j: int, mirror: bool) -> dict:
    """:func:`placements`' row for the open query on closed library curve ``j``: the partial fit q ≈ s·M·w + b in
    the normalized frames (the grid's, its stretch's ends then refined: :func:`_refined_stretch`), carried to input
    units; the phase where the stretch starts, reversed when it runs against the library curve."""
    qn, ln = query.normalized, library.normalized
    q, w = qn.points[0], ln.points[j]
    if q.shape[1] == 2:
        _, alpha, beta, mirrored = partial_placement(q, w, mirror=mirror)
        s, fit = abs(alpha), np.angle(alpha)
        m = np.array([[np.cos(fit), -np.sin(fit)], [np.sin(fit), np.cos(fit)]]) @ np.diag([1.0, -1.0 if mirrored else 1.0])
        b = np.array([beta.real, beta.imag])
    else:
        _, s, m, b = partial_placement3(q, w, mirror=mirror)
        mirrored = bool(np.linalg.det(m) < 0)
    s, m, b, start, end = _refined_stretch(q, w, s, m, b, -1.0 if mirrored else 1.0)
    matrix = qn.frame[0] @ m @ ln.frame[j].T
    scale = float(qn.scale[0] * s / ln.scale[j])
    return {"scale": scale, "matrix": matrix.tolist(),
            "translation": (qn.centroid[0] + qn.scale[0] * qn.frame[0] @ b - scale * matrix @ ln.centroid[j]).tolist(),
            "phase": start % 1.0, "reversed": bool(end < start), "mirrored": bool(mirrored)}


def _refined_stretch(q: np.ndarray, w: np.ndarray, s: float, m: np.ndarray, b: np.ndarray, sign: float
                     ) -> tuple[float, np.ndarray, np.ndarray, float, float]:
    """The grid's fit q ≈ s·m·w + b of the open curve q (N, D) on closed curve w (M, D) refined past the grid (its
    stretches' lengths step by ~10 %, so does its scale): the stretch's ends (fractions of w's length from w[0];
    the end below the start: travelled backwards), first where the placed w passes nearest q's ends, moved by
    Nelder–Mead on the RMS of the best similarity (det ``sign``) between q and the stretch sampled as q is (evenly
    along its length). Returns (s, m, b, start, end)."""
    from scipy.optimize import minimize

    ring = np.concatenate([w, w[:1]])
    length = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ring, axis=0), axis=1))])
    length /= length[-1]
    fine = np.linspace(0.0, 1.0, 4 * len(ring))
    dense = np.stack([np.interp(fine, length, ring[:, d]) for d in range(w.shape[1])], axis=1)
    placed = b + s * dense @ m.T
    ends = [fine[int(np.argmin(np.sum((placed - p) ** 2, axis=1)))] for p in (q[0], q[-1])]

    def stretch(x: np.ndarray) -> np.ndarray:
        at = (x[0] + (x[1] - x[0]) * np.linspace(0.0, 1.0, len(q))) % 1.0
        return np.stack([np.interp(at, length, ring[:, d]) for d in range(w.shape[1])], axis=1)

    def rms(x: np.ndarray) -> float:
        f, g, c = _similarity(q, stretch(x), sign)
        return float(np.sqrt(np.mean(np.sum((q - c - f * stretch(x) @ g.T) ** 2, axis=1))))

    starts = [np.array([ends[0], ends[1] + k]) for k in (-1.0, 0.0, 1.0)]
    x0 = min(starts, key=rms)
    x = minimize(rms, x0, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-14, "maxiter": 2000}).x
    s, m, b = _similarity(q, stretch(x), sign)
    return s, m, b, float(x[0]), float(x[1])


def _similarity(q: np.ndarray, p: np.ndarray, sign: float) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity q ≈ s·M·p + b of matched points (N, D) each in the least-squares sense (Umeyama), M
    orthogonal with det M = ``sign``: (s, M (D, D), b (D,))."""
    qm, pm = q.mean(axis=0), p.mean(axis=0)
    u, sigma, vt = np.linalg.svd((q - qm).T @ (p - pm))
    flip = np.ones(len(sigma))
    flip[-1] = sign * np.sign(np.linalg.det(u @ vt))
    m = u @ np.diag(flip) @ vt
    s = float((sigma * flip).sum() / max(np.sum((p - pm) ** 2), 1e-300))
    return s, m, qm - s * m @ pm


def learn(desc: Descriptors, names: list[str], similar: list[tuple[str, str]], dissimilar: list[tuple[str, str]], *,
          regularization: float, terms: list[str] | None, file: str) -> LearnedWeights:
    """Fit weights from pairs of curve names (errors name the pair's field in ``file``)."""
    available = term_names(desc)
    chosen = list(terms) if terms is not None else list(available)
    for i, name in enumerate(chosen):
        if name not in available:
            raise InputError(f"term {name!r} does not apply to these curves", file=file, field=("terms", i))
    index = {n: i for i, n in enumerate(names)}

    def pairs(items: list[tuple[str, str]], label: str) -> np.ndarray:
        out = np.empty((len(items), 2), dtype=int)
        for k, pair in enumerate(items):
            for j, name in enumerate(pair):
                if name not in index:
                    raise InputError(f"unknown curve {name!r} (curves: {', '.join(names)})", file=file,
                                     field=(label, k, j))
                out[k, j] = index[name]
            if out[k, 0] == out[k, 1]:
                raise InputError("a pair of a curve with itself", file=file, field=(label, k))
        return out

    sim, dis = pairs(similar, "similar"), pairs(dissimilar, "dissimilar")
    used = np.unique(np.concatenate([sim.ravel(), dis.ravel()]))
    local = np.full(len(names), -1)
    local[used] = np.arange(len(used))
    mats = term_distances(desc.take(used))
    table = np.stack([mats[t] for t in chosen], axis=-1)  # (U, U, T)
    try:
        return learn_weights(chosen, table[local[sim[:, 0]], local[sim[:, 1]]],
                             table[local[dis[:, 0]], local[dis[:, 1]]], regularization)
    except Inseparable as exc:
        a, b = dissimilar[exc.index]
        raise InputError(f"{a} and {b} do not differ in any term: no weights can separate them", file=file,
                         field=("dissimilar", exc.index)) from None
