"""The linkage as a graph: joints, rigid links, ground, motor — and its mobility.

Joints are indexed in spec order (0..J-1). Every pair of joints on one link is held at a
constant distance; ``pairs`` lists them.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from linkedit.spec.linkage import LinkageSpec


@dataclass(frozen=True)
class LinkageGraph:
    """Topology and rest pose of a planar linkage (indices are spec order)."""

    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    links: tuple[tuple[int, ...], ...]
    ground: tuple[int, ...]
    motor: int
    pivot: int
    rest: np.ndarray  # (J, 2) rest-pose positions

    @classmethod
    def from_spec(cls, spec: LinkageSpec) -> "LinkageGraph":
        names = tuple(spec.joints)
        index = {n: i for i, n in enumerate(names)}
        return cls(
            joint_names=names,
            link_names=tuple(spec.links),
            links=tuple(tuple(index[j] for j in members) for members in spec.links.values()),
            ground=tuple(index[g] for g in spec.ground),
            motor=index[spec.motor.joint],
            pivot=index[spec.motor.pivot],
            rest=np.array([spec.joints[n] for n in names], dtype=float),
        )

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    @property
    def pairs(self) -> np.ndarray:
        """(P, 2) int: every joint pair that shares a link, each pair once, sorted."""
        out = sorted({tuple(sorted(p)) for link in self.links for p in combinations(link, 2)})
        return np.array(out, dtype=int).reshape(-1, 2)

    def neighbours(self) -> list[set[int]]:
        """For each joint, the joints it shares a link with."""
        out: list[set[int]] = [set() for _ in self.joint_names]
        for link in self.links:
            for a in link:
                out[a].update(b for b in link if b != a)
        return out


@dataclass(frozen=True)
class Mobility:
    """Degrees of freedom of the linkage: Grübler's count and the rank-based value."""

    grubler: int  #: 3(n−1) − 2·Σ(bodies at a joint − 1), n bodies including the frame
    rank: int  #: 2·(free joints) − rank of the distance-constraint Jacobian at the rest pose
    redundant: int  #: distance constraints that are implied by the others (at the rest pose)

    def describe(self) -> str:
        return f"mobility {self.rank} (Grübler count {self.grubler}, {self.redundant} redundant constraint(s))"


def mobility(graph: LinkageGraph) -> Mobility:
    """Mobility of ``graph`` from Grübler's formula and from the constraint Jacobian rank."""
    ground = set(graph.ground)
    bodies = [set(link) for link in graph.links if not set(link) <= ground]
    count = np.zeros(graph.n_joints, dtype=int)
    for body in bodies:
        for j in body:
            count[j] += 1
    for g in ground:
        count[g] += 1  # the frame
    grubler = 3 * len(bodies) - 2 * int(np.sum(np.maximum(count - 1, 0)))

    free = [j for j in range(graph.n_joints) if j not in ground]
    column = {j: c for c, j in enumerate(free)}
    pairs = graph.pairs
    x = graph.rest
    jac = np.zeros((len(pairs), 2 * len(free)))
    for row, (a, b) in enumerate(pairs):
        d = x[a] - x[b]
        if a in column:
            jac[row, 2 * column[a]: 2 * column[a] + 2] = d
        if b in column:
            jac[row, 2 * column[b]: 2 * column[b] + 2] = -d
    scale = np.abs(jac).max(initial=1.0)
    # independent rows: per link only 2n−3 of its n(n−1)/2 pairs count
    needed = sum(2 * len(link) - 3 for link in graph.links if not set(link) <= ground)
    rank = int(np.linalg.matrix_rank(jac, tol=1e-9 * scale * max(jac.shape, default=1))) if jac.size else 0
    return Mobility(grubler=grubler, rank=2 * len(free) - rank, redundant=max(needed - rank, 0))
