"""The finders behind :mod:`linkedit.gcs.closed_form`: which rule
(:mod:`linkedit.gcs.closed_form_rules`) places each member of a system, matched on its
constraints, in placing order (each member from members placed before it, the world first)."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from linkedit.gcs.closed_form_place import Placement
from linkedit.gcs.closed_form_rules import (PARALLEL, SIDED, Arm, Cone, Driven, Dyad, End, Hinged, Reach, Rule,
                                            Slider, Spun, Swing)
from linkedit.gcs.system import System


def find_rules(system: System) -> list[Rule] | None:
    """The rules in placing order, or None where some member has none (or the system has
    custom constraints)."""
    if system.customs:
        return None
    M = system.n_members
    driven = set(system.driven_vectors.tolist())
    ends: dict[str, dict[int, list[End]]] = {}
    for blk in system.blocks:
        per = ends.setdefault(blk.kind, {m: [] for m in range(M)})
        own_b = len(blk.vectors) > 1  # b's vector, which an input may drive: not a member's own then
        for i, (a, b) in enumerate(zip(blk.a, blk.b)):
            if a != b:
                if a < M:
                    per[int(a)].append(End(i, True, int(b)))
                if b < M and not (own_b and blk.vectors[1].start + i in driven):
                    per[int(b)].append(End(i, False, int(a)))
    none: dict[int, list[End]] = {m: [] for m in range(M)}
    pins, axes, turns, lines, planes = (ends.get(k, none)
                                        for k in ("location", "axis", "orientation", "line", "plane"))
    # the constraints each member takes part in (a link's are its two ball joints only)
    touching = np.bincount(np.concatenate([np.r_[blk.a, blk.b] for blk in system.blocks] or [np.zeros(0, int)]),
                           minlength=M + 1)
    place = Placement(system)
    placed = {M}
    order: list[Rule] = []

    def arm_of(axis: End, start: End, end: End | None = None) -> Arm:
        """A member's arm from its point of the location constraint ``start`` to that of
        ``end`` across its axis of the axis constraint ``axis`` (all seen from it); with no
        ``end``, from its origin to its unit axis of the axis constraint ``start``."""
        if end is None:
            return Arm.of(place.mine("axis", axis), np.zeros(3), place.mine("axis", start))
        return Arm.of(place.mine("axis", axis), place.mine("location", start), place.mine("location", end))

    def differ(a: End, b: End) -> bool:
        """Whether a member's points of the location constraints a and b (seen from it) differ."""
        return place.mine("location", a).tolist() != place.mine("location", b).tolist()

    def first(found: list[End]) -> End | None:
        return next((e for e in found if e.other in placed), None)

    def direct(u: int) -> Rule | None:
        """A driven or hinged rule for member u."""
        pin, turn = first(pins[u]), first(turns[u])
        if pin is not None and turn is not None:
            return Driven(u, turn, pin)
        axis = first(axes[u])
        if pin is None or axis is None:
            return None
        other = next((e for e in pins[u] if e.other in placed and differ(pin, e)), None)
        return None if other is None else Hinged(u, (pin, other), axis, arm_of(axis, pin, other))

    def partners(u: int, apart: bool) -> Iterator[tuple[End, End, End, int, End]]:
        """Member u's first placed pin and axis, with each unplaced member w pinned to u (by
        ``joint`` seen from u, ``back`` seen from w) at another point of u than that pin
        (``apart``) or at the same one."""
        pin, axis = first(pins[u]), first(axes[u])
        if pin is None or axis is None:
            return
        for joint in pins[u]:
            w = joint.other
            if w not in placed and differ(pin, joint) == apart:
                yield pin, axis, joint, w, End(joint.index, not joint.side_a, u)

    def dyad_of(u: int) -> Rule | None:
        """A dyad of member u and an unplaced member."""
        for pin, axis, joint, w, back in partners(u, True):
            pin_w, axis_w = first(pins[w]), first(axes[w])
            if back in pins[w] and pin_w is not None and axis_w is not None and differ(pin_w, back):
                return Dyad((u, w), (pin, pin_w), (axis, axis_w), joint,
                            (arm_of(axis, pin, joint), arm_of(axis_w, pin_w, back)))
        return None

    def cone_of(u: int) -> Rule | None:
        """A spherical dyad of member u and an unplaced member."""
        for pin, axis, joint, w, back in partners(u, False):
            pin_w, axis_w = first(pins[w]), first(axes[w])
            if back not in pins[w] or pin_w is None or axis_w is None or differ(pin_w, back):
                continue
            for hinge in (e for e in axes[u] if e.other == w):
                other = End(hinge.index, not hinge.side_a, u)
                arms = (arm_of(axis, hinge), arm_of(axis_w, other))
                if other in axes[w] and min(a.length for a in arms) > PARALLEL:
                    return Cone((u, w), (pin, pin_w), (axis, axis_w), joint, hinge, arms)
        return None

    def slider_of(u: int) -> Rule | None:
        """A rod u pinned to a placed member and a slider on a placed member's line."""
        for pin, axis, joint, w, back in partners(u, True):
            turn = first(turns[w])
            line = next((e for e in lines[w] if e.side_a and e.other in placed), None)
            if turn is None or line is None or back not in pins[w]:
                continue
            arm = Arm.of(place.mine("axis", axis), place.mine("location", pin), place.mine("location", joint))
            return Slider((u, w), pin, axis, turn, line, joint, arm,
                          place.mine("location", back) - place.mine("line", line))
        return None

    def link(u: int, joint: End) -> tuple[End, float] | None:
        """The link that u's location constraint ``joint`` pins it to (unplaced, held by
        that and one more location constraint alone, to a placed member at another of its
        points): that one (seen from the link) and the length between the two points."""
        w, back = joint.other, End(joint.index, not joint.side_a, u)
        if w in placed or touching[w] != 2 or back not in pins[w]:
            return None
        far = next((e for e in pins[w] if e != back and e.other in placed), None)
        if far is None or not differ(back, far):
            return None
        return far, float(np.linalg.norm(place.mine("location", far) - place.mine("location", back)))

    def swing_of(u: int) -> Rule | None:
        """A rocker u whose joint is a link's ball joint."""
        pin, axis = first(pins[u]), first(axes[u])
        if pin is None or axis is None:
            return None
        for joint in pins[u]:
            found = link(u, joint) if differ(pin, joint) else None
            if found is not None:
                return Swing(u, pin, axis, arm_of(axis, pin, joint), joint, *found)
        return None

    def reach_of(u: int) -> Rule | None:
        """A slider u whose joint is a link's ball joint."""
        turn = first(turns[u])
        line = next((e for e in lines[u] if e.side_a and e.other in placed), None)
        flat = [e for e in planes[u] if e.side_a and e.other in placed]
        two = next(((p, q) for i, p in enumerate(flat) for q in flat[i + 1:]
                    if place.mine("plane", p).tolist() == place.mine("plane", q).tolist()), None)
        guide, kind = ((line,), "line") if line is not None else (two, "plane")
        if turn is None or guide is None:
            return None
        for joint in pins[u]:
            found = link(u, joint)
            if found is not None:
                offset = place.mine("location", joint) - place.mine(kind, guide[0])
                return Reach(u, turn, guide, kind, joint, *found, offset)
        return None

    def spun_of(u: int) -> Rule | None:
        """A link u between two placed ball joints."""
        held = [e for e in pins[u] if e.other in placed]
        if touching[u] != 2 or len(held) != 2 or not differ(*held):
            return None
        return Spun(u, (held[0], held[1]))

    while len(placed) <= M:
        # the members placed directly first, then dyads, spherical dyads, sliders, rockers
        # and sliders reaching a link, links between ball joints
        rule = None
        for find in (direct, dyad_of, cone_of, slider_of, swing_of, reach_of, spun_of):
            rule = next((r for u in range(M) if u not in placed for r in (find(u),) if r is not None), None)
            if rule is not None:
                break
        if rule is None:
            return None
        order.append(rule)
        placed |= set(rule.members) if isinstance(rule, SIDED) else {rule.member}
    return order
