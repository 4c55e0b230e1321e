"""The linkage as a graph: joints, rigid links, ground, motor — and its mobility.

Joints are indexed in spec order (0..J-1). Every pair of joints on one link is held at a
constant distance; ``pairs`` lists them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from itertools import combinations

import numpy as np

from linkedit.spec.linkage import FRAME, LinkageSpec


@dataclass(frozen=True)
class SliderPair:
    """A prismatic pair (indices are spec order; −1: none / the frame)."""

    name: str
    joint: int  #: the joint in the slot, or −1 for a translating link
    link: int  #: the translating link, or −1 for a joint slider
    guide: int  #: the guide link, −1 for the frame
    angle: float  #: direction of the line at rest, radians


@dataclass(frozen=True)
class LinkageGraph:
    """Topology and rest pose of a planar linkage (indices are spec order)."""

    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    links: tuple[tuple[int, ...], ...]
    ground: tuple[int, ...]
    motor: int  #: the driven joint (for a linear input: the joint of the driven slider)
    pivot: int  #: the motor's pivot joint, −1 for a linear input
    rest: np.ndarray  # (J, 2) rest-pose positions
    sliders: tuple[SliderPair, ...] = ()
    drive: int = -1  #: index into ``sliders`` of the linearly driven slider, −1 for a rotary motor

    @classmethod
    def from_spec(cls, spec: LinkageSpec) -> "LinkageGraph":
        names = tuple(spec.joints)
        index = {n: i for i, n in enumerate(names)}
        link_names = tuple(spec.links)
        sliders = tuple(SliderPair(
            name=n, joint=index[s.joint] if s.joint is not None else -1,
            link=link_names.index(s.link) if s.link is not None else -1,
            guide=-1 if s.guide == FRAME else link_names.index(s.guide), angle=float(np.radians(s.angle_deg)))
            for n, s in spec.sliders.items())
        m = spec.motor
        if m.slider is not None:  # a linear input
            drive = list(spec.sliders).index(m.slider)
            motor, pivot = sliders[drive].joint, -1
        else:
            assert m.joint is not None and m.pivot is not None  # checked by the spec
            drive, motor, pivot = -1, index[m.joint], index[m.pivot]
        return cls(
            joint_names=names,
            link_names=link_names,
            links=tuple(tuple(index[j] for j in members) for members in spec.links.values()),
            ground=tuple(index[g] for g in spec.ground),
            motor=motor,
            pivot=pivot,
            rest=np.array([spec.joints[n] for n in names], dtype=float),
            sliders=sliders, drive=drive,
        )

    def with_rest(self, rest: np.ndarray) -> "LinkageGraph":
        """The same topology with another rest pose (J, 2)."""
        return replace(self, rest=np.asarray(rest, dtype=float))

    def frame_pair(self, link: int) -> tuple[int, int]:
        """The two joints that define ``link``'s frame: its farthest pair at rest (−1, −1: the frame)."""
        if link < 0:
            return -1, -1
        members = self.links[link]
        return max(((a, b) for a in members for b in members if a < b),
                   key=lambda p: float(np.hypot(*(self.rest[p[0]] - self.rest[p[1]]))))

    def fixed(self, link: int) -> bool:
        """Whether ``link`` is the frame (−1) or a link of ground joints only."""
        return link < 0 or set(self.links[link]) <= set(self.ground)

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
    """Mobility of ``graph`` from Grübler's formula and from the constraint Jacobian rank.

    A pin in a slot removes one degree of freedom, a translating link (prismatic pair) two.
    The rank is taken at the rest pose over every rigid-link and slider constraint (not the
    input: a motor drives the one degree of freedom), relative to the linkage's size.
    """
    from linkedit.planar.constraints import linkage_rows

    ground = set(graph.ground)
    bodies = [set(link) for link in graph.links if not set(link) <= ground]
    count = np.zeros(graph.n_joints, dtype=int)
    for body in bodies:
        for j in body:
            count[j] += 1
    for g in ground:
        count[g] += 1  # the frame
    slots = sum(1 for s in graph.sliders if s.joint >= 0)
    blocks = sum(1 for s in graph.sliders if s.link >= 0)
    grubler = 3 * len(bodies) - 2 * int(np.sum(np.maximum(count - 1, 0))) - slots - 2 * blocks

    free = [j for j in range(graph.n_joints) if j not in ground]
    rows = linkage_rows(graph, with_drive=False)
    z = graph.rest[:, 0] + 1j * graph.rest[:, 1]
    jac = rows.jacobian(z[:, None], np.array(free, dtype=int))[0] if free else np.zeros((rows.m, 0))
    jac = jac / np.maximum(np.abs(jac).max(axis=1, keepdims=True), 1e-300)  # each row to unit scale
    rank = int(np.linalg.matrix_rank(jac, tol=1e-9 * max(jac.shape, default=1))) if jac.size else 0
    return Mobility(grubler=grubler, rank=2 * len(free) - rank, redundant=max(rows.m - rank, 0))
