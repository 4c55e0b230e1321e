"""Joint ordering (LinkEdit Algorithm 1): which joint is rebuilt from which two, level by level.

Start from the ground joints and the motor joint. In every round, each joint that is not yet
known but can be rebuilt from two known joints becomes a rule (i, j) → k:

* a **rigid** rule when k shares one link with two known joints i, j (k is then fixed in the
  link's frame: exact, even for collinear joints);
* a **dyad** rule when k has two known neighbours on different links (law of cosines).

All rules of a round form one **level**: their inputs are known, so the whole level is
evaluated as one batched array operation (one batch per kind). Rules that are not on a critical
path may move to a later level, within their slack, to join a batch of their kind there
(:func:`merge_levels`): fewer, larger batches evaluate faster. The pair (i, j) is chosen to be the best conditioned
one at the rest pose (rigid: the farthest apart; dyad: the angle at k closest to 90°).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.planar.graph import LinkageGraph


@dataclass(frozen=True)
class Rule:
    """Rebuild joint ``k`` from known joints ``i`` and ``j``; ``link`` is set for rigid rules."""

    i: int
    j: int
    k: int
    level: int
    link: int | None  # index of the link carrying i, j, k (rigid rule), or None (dyad)

    @property
    def rigid(self) -> bool:
        return self.link is not None


@dataclass(frozen=True)
class Ordering:
    """Result of Algorithm 1: the rules in evaluation order and the joints left undetermined."""

    rules: tuple[Rule, ...]
    undetermined: tuple[int, ...]


def _best_rigid(graph: LinkageGraph, k: int, known: set[int]) -> Rule | None:
    x = graph.rest
    best, best_d = None, -1.0
    for li, link in enumerate(graph.links):
        if k not in link:
            continue
        have = [j for j in link if j in known]
        for a in range(len(have)):
            for b in range(a + 1, len(have)):
                d = float(np.hypot(*(x[have[a]] - x[have[b]])))
                if d > best_d:
                    best, best_d = Rule(have[a], have[b], k, -1, li), d
    return best


def _best_dyad(graph: LinkageGraph, k: int, candidates: list[int]) -> Rule | None:
    x = graph.rest
    best, best_s = None, -1.0
    for a in range(len(candidates)):
        for b in range(a + 1, len(candidates)):
            i, j = candidates[a], candidates[b]
            u, v = x[i] - x[k], x[j] - x[k]
            s = abs(u[0] * v[1] - u[1] * v[0]) / (np.hypot(*u) * np.hypot(*v))  # |sin| of the angle at k
            if s > best_s:
                best, best_s = Rule(i, j, k, -1, None), s
    return best


def order_joints(graph: LinkageGraph) -> Ordering:
    """Run Algorithm 1 on ``graph``; see the module docstring."""
    neighbours = graph.neighbours()
    known = set(graph.ground) | {graph.motor}
    rules: list[Rule] = []
    level = 0
    while True:
        level += 1
        found: list[Rule] = []
        for k in range(graph.n_joints):
            if k in known:
                continue
            rule = _best_rigid(graph, k, known)
            if rule is None:
                have = [n for n in sorted(neighbours[k]) if n in known]
                if len(have) >= 2:
                    rule = _best_dyad(graph, k, have)
            if rule is not None:
                found.append(Rule(rule.i, rule.j, rule.k, level, rule.link))
        if not found:
            break
        rules.extend(found)
        known.update(r.k for r in found)
    undetermined = tuple(k for k in range(graph.n_joints) if k not in known)
    return Ordering(rules=merge_levels(rules), undetermined=undetermined)


def merge_levels(rules: list[Rule]) -> tuple[Rule, ...]:
    """Re-level rules so that same-kind rules share levels where their dependencies allow.

    Each rule may sit anywhere between its earliest level (one after its latest input) and its
    latest level (one before its earliest consumer). Rules with no slack fix the batches;
    every other rule, in dependency order, takes the first level of its window that already has
    a batch of its kind (else the earliest level). Returns the rules sorted by level.
    """
    producer = {r.k: n for n, r in enumerate(rules)}
    consumers: list[list[int]] = [[] for _ in rules]
    for n, r in enumerate(rules):
        for inp in (r.i, r.j):
            if inp in producer:
                consumers[producer[inp]].append(n)
    depth = max((r.level for r in rules), default=0)
    latest = [depth] * len(rules)
    for n in sorted(range(len(rules)), key=lambda n: -rules[n].level):
        if consumers[n]:
            latest[n] = min(latest[c] for c in consumers[n]) - 1
    fixed = {(r.level, r.rigid) for n, r in enumerate(rules) if r.level == latest[n]}
    chosen: list[int] = [0] * len(rules)
    for n in sorted(range(len(rules)), key=lambda n: rules[n].level):
        r = rules[n]
        earliest = 1 + max((chosen[producer[x]] for x in (r.i, r.j) if x in producer), default=0)
        window = range(earliest, latest[n] + 1)
        chosen[n] = next((lv for lv in window if (lv, r.rigid) in fixed), earliest)
        fixed.add((chosen[n], r.rigid))
    out = [Rule(r.i, r.j, r.k, chosen[n], r.link) for n, r in enumerate(rules)]
    return tuple(sorted(out, key=lambda r: r.level))
