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
class StepRule:
    """A rule of a new kind (sliders, the linear input, a numeric group) writing ``joints``.

    * ``slider``: joint k of a pin-in-slot slider from the known joint ``i`` at a fixed
      distance and the known slot line (circle–line intersection, closed form);
    * ``drive``: the linearly driven joint from its known slot line and the input (closed form);
    * ``lines``: a joint in two slots (sliders ``slider`` and ``i``) whose lines are known: their
      crossing (closed form);
    * ``rotate`` / ``yoke``: a slotted link from the known pin of slider ``slider`` in its slot,
      turning about its known joint ``i`` / translating along the frame (slider ``i``) (closed form);
    * ``group``: a complex loop, solved numerically as one group.
    """

    kind: str
    joints: tuple[int, ...]
    level: int
    slider: int = -1  # index into graph.sliders
    i: int = -1


@dataclass(frozen=True)
class Ordering:
    """Result of Algorithm 1: the rules in evaluation order and the joints left undetermined."""

    rules: tuple[Rule, ...]
    undetermined: tuple[int, ...]
    steps: tuple[StepRule, ...] = ()


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


def _revolute_round(graph: LinkageGraph, known: set[int], neighbours: list[set[int]], level: int) -> list[Rule]:
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
    return found


def order_joints(graph: LinkageGraph) -> Ordering:
    """Run Algorithm 1 on ``graph``; see the module docstring.

    Linkages with sliders, a linear input or a complex loop take :func:`order_with_steps`.
    """
    if graph.sliders or graph.pivot < 0:
        return order_with_steps(graph)
    neighbours = graph.neighbours()
    known = set(graph.ground) | {graph.motor}
    rules: list[Rule] = []
    level = 0
    while True:
        level += 1
        found = _revolute_round(graph, known, neighbours, level)
        if not found:
            break
        rules.extend(found)
        known.update(r.k for r in found)
    undetermined = tuple(k for k in range(graph.n_joints) if k not in known)
    if undetermined:
        return order_with_steps(graph)
    return Ordering(rules=merge_levels(rules), undetermined=undetermined)


def _frame_known(graph: LinkageGraph, link: int, known: set[int]) -> bool:
    return graph.fixed(link) or set(graph.frame_pair(link)) <= known


def _slider_round(graph: LinkageGraph, known: set[int], taken: set[int], neighbours: list[set[int]],
                  level: int) -> list[StepRule]:
    """Closed-form slider rules whose inputs are known (see :class:`StepRule`)."""
    x = graph.rest[:, 0] + 1j * graph.rest[:, 1]
    out: list[StepRule] = []
    for n, s in enumerate(graph.sliders):
        k = s.joint
        if k < 0 or k in known or k in taken or not _frame_known(graph, s.guide, known):
            continue
        if n == graph.drive:
            out.append(StepRule("drive", (k,), level, n))
            taken.add(k)
            continue
        other = next((m for m, o in enumerate(graph.sliders) if m != n and o.joint == k and m != graph.drive
                      and _frame_known(graph, o.guide, known)), -1)
        if other >= 0:  # a joint in two known slots: where their lines cross
            out.append(StepRule("lines", (k,), level, n, other))
            taken.add(k)
            continue
        have = [i for i in sorted(neighbours[k]) if i in known]
        if not have:
            continue
        # the best conditioned rod: the one closest to the slot direction at rest
        u = np.exp(1j * s.angle)
        if not graph.fixed(s.guide):
            a, b = graph.frame_pair(s.guide)
            u = u * (x[b] - x[a]) / abs(x[b] - x[a])
        i = max(have, key=lambda i: abs((np.conj(u) * (x[k] - x[i])).real) / abs(x[k] - x[i]))
        out.append(StepRule("slider", (k,), level, n, i))
        taken.add(k)
    out.extend(_guide_round(graph, known, taken, level))
    return out


def _guide_round(graph: LinkageGraph, known: set[int], taken: set[int], level: int) -> list[StepRule]:
    """Closed-form rules that place a slotted link from a known pin in its slot: ``rotate`` (the
    link has a known joint ``i``: it turns about it until the slot meets the pin) and ``yoke``
    (the link translates along the frame, slider ``i``: it slides until the slot meets the pin)."""
    out: list[StepRule] = []
    for m, s in enumerate(graph.sliders):
        if s.joint < 0 or s.joint not in known or graph.fixed(s.guide) or m == graph.drive:
            continue
        members = graph.links[s.guide]
        todo = tuple(j for j in members if j not in known and j not in taken)
        have = [j for j in members if j in known]
        block = _yoke(graph, s.guide)
        if not todo or (not have and block < 0):
            continue
        out.append(StepRule("rotate", todo, level, m, have[0]) if have else StepRule("yoke", todo, level, m, block))
        taken.update(todo)
    return out


def _yoke(graph: LinkageGraph, link: int) -> int:
    """The slider that makes ``link`` translate along the frame (−1: none)."""
    return next((n for n, s in enumerate(graph.sliders) if s.link == link and graph.fixed(s.guide)), -1)


#: largest complex-loop group tried subset by subset; beyond it the whole remainder is one group
MAX_GROUP_SEARCH = 4


def _group(graph: LinkageGraph, rows, known: set[int]) -> tuple[int, ...] | None:
    """The smallest set of unknown joints that the constraint rows fix, given the known joints."""
    from itertools import combinations

    unknown = [k for k in range(graph.n_joints) if k not in known]
    z = graph.rest[:, 0] + 1j * graph.rest[:, 1]

    def fixes(group: tuple[int, ...]) -> bool:
        inside = known | set(group)
        use = [r for r, js in enumerate(rows.joints) if js <= inside and js & set(group)]
        if len(use) < 2 * len(group):
            return False
        jac = rows.take(np.array(use)).jacobian(z[:, None], np.array(group))[0]
        jac = jac / np.maximum(np.abs(jac).max(axis=1, keepdims=True), 1e-300)
        return int(np.linalg.matrix_rank(jac, tol=1e-9 * max(jac.shape))) == 2 * len(group)

    for size in range(1, min(len(unknown), MAX_GROUP_SEARCH) + 1):
        for group in combinations(unknown, size):
            if fixes(group):
                return group
    if len(unknown) > MAX_GROUP_SEARCH and fixes(tuple(unknown)):
        return tuple(unknown)
    return None


def order_with_steps(graph: LinkageGraph) -> Ordering:
    """Algorithm 1 extended: revolute rules, closed-form slider rules, and, where neither can
    place a joint, the smallest numeric group (a complex loop) — level by level."""
    from linkedit.planar.constraints import linkage_rows

    neighbours = graph.neighbours()
    known = set(graph.ground) | ({graph.motor} if graph.pivot >= 0 else set())
    rows = linkage_rows(graph)
    rules: list[Rule] = []
    steps: list[StepRule] = []
    level = 0
    while len(known) < graph.n_joints:
        level += 1
        found = _revolute_round(graph, known, neighbours, level)
        taken = {r.k for r in found}
        more = _slider_round(graph, known, taken, neighbours, level)
        if not found and not more:
            group = _group(graph, rows, known)
            if group is None:
                break
            more = [StepRule("group", group, level)]
        rules.extend(found)
        steps.extend(more)
        known.update(taken)
        for st in more:
            known.update(st.joints)
    undetermined = tuple(k for k in range(graph.n_joints) if k not in known)
    return Ordering(rules=tuple(rules), undetermined=undetermined, steps=tuple(steps))


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
