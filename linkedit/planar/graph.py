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
    rank: int  #: 2·(free joints) − rank of the rigid-link constraint Jacobian at the rest pose
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
    x = graph.rest[:, 0] + 1j * graph.rest[:, 1]
    # Each link as a rigid body (velocity constraints at the rest pose): one distance row for
    # its farthest pair (i, j), and two rows per other joint k: δz_k = δz_i + c·(δz_j − δz_i),
    # c = (z_k − z_i)/(z_j − z_i). Unlike pairwise distances this keeps full rank when joints
    # of one link are collinear (Hoekens' coupler).
    rows: list[dict[int, np.ndarray]] = []
    for link in graph.links:
        if set(link) <= ground:
            continue
        i, j = max(((a, b) for a in link for b in link if a < b), key=lambda p: abs(x[p[0]] - x[p[1]]))
        d = x[i] - x[j]
        rows.append({i: np.array([[d.real, d.imag]]), j: -np.array([[d.real, d.imag]])})
        for k in link:
            if k in (i, j):
                continue
            c = (x[k] - x[i]) / (x[j] - x[i])
            rot = np.array([[c.real, -c.imag], [c.imag, c.real]])
            rows.append({k: np.eye(2), i: rot - np.eye(2), j: -rot})
    n_rows = sum(next(iter(r.values())).shape[0] for r in rows)
    jac = np.zeros((n_rows, 2 * len(free)))
    at = 0
    for r in rows:
        height = next(iter(r.values())).shape[0]
        for joint, block in r.items():
            if joint in column:
                jac[at:at + height, 2 * column[joint]: 2 * column[joint] + 2] += block
        at += height
    needed = n_rows
    scale = np.abs(jac).max(initial=1.0)
    rank = int(np.linalg.matrix_rank(jac, tol=1e-9 * scale * max(jac.shape, default=1))) if jac.size else 0
    return Mobility(grubler=grubler, rank=2 * len(free) - rank, redundant=max(needed - rank, 0))
