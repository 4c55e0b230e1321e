"""What the revolute kinds share: a level's batch of rules (i, j) → k, written as one block.

A :class:`Triangles` object is every rule of one kind (:mod:`.dyad`, :mod:`.rigid`) in one
level: it writes the internal rows ``start:stop`` from the rows ``i``, ``j`` with one array
operation per quantity. Its members are entries of the plan's triangle table (``rule``; −1 for
a tracked point on a link, which a rigid rule places but no table lists).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property, partial
from typing import Any

import numpy as np

from linkedit.planar.rules.base import Failure, Rule
from linkedit.planar.rules.pool import Pool


@dataclass(frozen=True, eq=False)
class Triangles(Rule):
    """Rules (i, j) → k of one kind in one level (see module docstring)."""

    level: int
    start: int
    stop: int
    i: np.ndarray  # (R,) input rows
    j: np.ndarray  # (R,) input rows
    k_point: np.ndarray  # (R,) point ids written (joint index, or J + track-point number)
    i_point: np.ndarray  # (R,) point ids of the inputs
    j_point: np.ndarray
    rule: np.ndarray  # (R,) index into the plan's triangle table, or -1 for a tracked point
    sign: np.ndarray  # (R, 1) orientation of triangle (i, j, k) at rest (dyads), ±1
    #: every input i is a ground point: its derivatives are 0, so :meth:`inputs` reads its
    #: positions alone and the rule adds z_i to its positions alone
    grounded: bool = False

    @property
    def listed(self) -> np.ndarray:
        """(R,) bool: members the triangle table lists (each owns one d_s row)."""
        return self.rule >= 0

    def ds_count(self) -> int:
        return int(self.listed.sum())

    def batch_rows(self) -> int:
        return self.stop - self.start

    def table_entries(self) -> np.ndarray:
        return self.rule[self.listed]

    def scratch(self, pool: Pool, Z: np.ndarray) -> Any:
        """z_i and z_j − z_i with their derivatives, (orders, R, *L, T) complex each."""
        one = (Z.shape[0], self.stop - self.start, *Z.shape[2:])
        return pool(one, complex), pool(one, complex)

    @cached_property
    def runs(self) -> tuple[slice | None, slice | None]:
        """The rows ``i`` and ``j`` as slices where they are consecutive (a batch of one always), else None."""
        return _run(self.i), _run(self.j)

    def inputs(self, Z: np.ndarray, zi: np.ndarray, e: np.ndarray) -> np.ndarray:
        """The rows ``i`` of ``Z`` (orders, P, *S), and ``e`` filled with rows ``j`` − rows ``i``: consecutive
        rows are read in place (a view of ``Z``: the rule writes other rows), others copied into ``zi``.
        :attr:`grounded`: only the positions of z_i are read (``zi[0]``; its derivatives are 0)."""
        i, j = self.runs
        if self.grounded:
            return self._from_ground(Z, zi, e)
        if i is None:
            Z.take(self.i, 1, zi, "clip")  # indices are valid: clip skips take's buffering
        else:
            zi = Z[:, i]
        if j is None:
            Z.take(self.j, 1, e, "clip")
            e -= zi
        else:
            np.subtract(Z[:, j], zi, out=e)
        return zi

    def _from_ground(self, Z: np.ndarray, zi: np.ndarray, e: np.ndarray) -> np.ndarray:
        """:meth:`inputs` of a :attr:`grounded` batch: z_i's positions alone, e's derivatives are rows ``j``'s."""
        i, j = self.runs
        if i is None:
            Z[0].take(self.i, 0, zi[0], "clip")
        else:
            zi = Z[:, i]
        if j is None:
            Z.take(self.j, 1, e, "clip")
            e[0] -= zi[0]
        else:
            np.subtract(Z[0, j], zi[0], out=e[0])
            np.copyto(e[1:], Z[1:, j])
        return zi

    def operands(self, work: Any) -> tuple[np.ndarray, np.ndarray, Callable[[], Any] | None]:
        """:meth:`positions`' inputs: the rows ``i`` and ``j`` of ``work.z`` (P, T), read in place
        where consecutive, else gathered into ``work.pair`` by the returned call (one ``take``
        for both when neither is consecutive; None when both are)."""
        r, z, pair = self.stop - self.start, work.z, work.pair
        i, j = self.runs
        if i is not None and j is not None:
            return z[i], z[j], None
        if i is None and j is None:
            return pair[:r], pair[r:2 * r], partial(z.take, np.concatenate([self.i, self.j]), 0, pair[:2 * r], "clip")
        gather = partial(z.take, self.i if i is None else self.j, 0, pair[:r], "clip")
        return (pair[:r], z[j], gather) if i is None else (z[i], pair[:r], gather)

    def written(self) -> np.ndarray:
        return self.k_point

    def placed(self) -> np.ndarray:
        return self.k_point[self.listed]

    def depend(self, row_of: np.ndarray, dep: np.ndarray, uses: np.ndarray) -> None:
        J = uses.shape[0]
        own = uses[self.i_point] | uses[self.j_point] | np.where(
            (self.k_point < J)[:, None], uses[np.minimum(self.k_point, J - 1)], False)
        dep[self.start:self.stop] = dep[self.i] | dep[self.j] | own

    def lines(self, names: list[str]) -> list[tuple[tuple[int, int, int], str]]:
        m = self.listed
        return [((self.level, 0, int(r)), f"{names[k]} ← ({names[i]}, {names[j]}) {self.kind}")
                for r, i, j, k in zip(self.rule[m], self.i_point[m], self.j_point[m], self.k_point[m])]

    def inputs_placed(self, finite: np.ndarray) -> np.ndarray:
        m = self.listed
        return finite[:, self.i_point[m]] & finite[:, self.j_point[m]]

    def explain(self, names: list[str], n: int, f: Failure, t: int) -> tuple[str, tuple[str, str], bool, str]:
        """Joint k, its inputs, whether they are too far apart for its links, and a toggle's
        explanation when its d_s is 0 within rounding."""
        m = self.listed
        i, j, k = self.i_point[m][n], self.j_point[m][n], self.k_point[m][n]
        d = np.linalg.norm(f.p[:, [j]] - f.p[:, [i]], axis=-1)[t, 0]
        lik = np.linalg.norm(f.rest[[k]] - f.rest[[i]], axis=-1)[0]
        ljk = np.linalg.norm(f.rest[[k]] - f.rest[[j]], axis=-1)[0]
        far = bool(d > lik + ljk) if np.isfinite(d) else False
        what = ""
        if abs(f.ds[t, n]) <= f.toggle:  # within rounding of a toggle: name it, never "too close"
            how = "stretched" if abs(d - lik - ljk) <= abs(d - abs(lik - ljk)) else "folded"
            what = (f"joint {names[k]} reaches a toggle position: its links are fully {how} between "
                    f"{names[i]} and {names[j]} (d_s = 0, its velocity is undefined there)")
        return names[k], (names[i], names[j]), far, what

    def culprit(self, names: list[str], n: int) -> str:
        return f"joint {names[self.placed()[n]]}"


class Spread:
    """A rule's constants (R, 1) spread over the samples, (n, R, T) of ``dtype``, copied again
    only when the rule is called with another constants tuple: numpy's loop over an (R, 1)
    operand broadcast against (R, T) costs a few times a same-shape one. The one-linkage
    constants are read-only (:meth:`Triangles.constants`), so the same tuple holds the same values.
    ``derive``, given, fills the tiles after the parts' from them (a product of constants, formed
    once per constants tuple)."""

    def __init__(self, n: int, rows: int, samples: int, dtype: type = float,
                 derive: Callable[[np.ndarray], object] | None = None) -> None:
        self.tiles: np.ndarray = np.empty((n, rows, samples), dtype=dtype)
        self.held: tuple[Any, ...] | None = None
        self.derive = derive

    def of(self, const: tuple[Any, ...], *parts: np.ndarray) -> np.ndarray:
        """The tiles of ``parts`` (R, 1) each, taken from the constants tuple ``const``, then ``derive``'s."""
        if const is not self.held:
            for tile, part in zip(self.tiles, parts):
                np.copyto(tile, part)
            if self.derive is not None:
                self.derive(self.tiles)
            self.held = const
        return self.tiles


def frozen(*parts: np.ndarray) -> tuple[np.ndarray, ...]:
    """``parts`` made read-only (one linkage's constants, see :class:`Spread`)."""
    for p in parts:
        p.flags.writeable = False
    return parts


def _run(rows: np.ndarray) -> slice | None:
    """``rows`` (R,) as a slice when they are consecutive, else None."""
    first = int(rows[0])
    return slice(first, first + rows.size) if np.array_equal(rows, np.arange(first, first + rows.size)) else None
