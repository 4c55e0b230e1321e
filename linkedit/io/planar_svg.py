"""Pictures of a simulated planar motion: adapts a :class:`~linkedit.planar.Motion` to the SVG drawings."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io import slides
from linkedit.io.svg import animated_motion, motion_plot
from linkedit.planar.simulate import Motion
from linkedit.spec.linkage import LinkTrack


def drawing(motion: Motion) -> dict[str, Any]:
    """The keyword arguments of :func:`linkedit.io.svg.motion_plot` for the assembled samples.

    A point tracked on a link is drawn as part of its link (an extra corner of the link's
    plate); sliders are drawn as rails, slots and blocks; where the linkage is locked (``--partial``) the curves break and the lock-up
    angles are marked: where it locks and frees (a numeric group's: the assembled samples either side, "locks after", "free
    again by"); a sweep's run from its start or to its end has no such mark there (a full cycle's curves run on from its last
    sample into its first).
    """
    plan = motion.plan
    ok = motion.assembled
    names = list(plan.joint_names)
    positions = motion.positions[ok]
    links = {n: list(m) for n, m in zip(plan.graph.link_names, plan.graph.links)}
    extra: list[np.ndarray] = []
    for name, track in plan.spec.tracks.items():
        if isinstance(track, LinkTrack):
            links[track.link].append(len(names) + len(extra))
            extra.append(motion.tracks[name].position[ok])
    if extra:
        positions = np.concatenate([positions, np.stack(extra, axis=1)], axis=1)
        names += [n for n, t in plan.spec.tracks.items() if isinstance(t, LinkTrack)]
    kept = np.flatnonzero(ok)
    breaks = [int(i) for i in np.flatnonzero(np.diff(kept) > 1) + 1]
    notes = []

    def near(value: float) -> int:  # the sample nearest to an input (a lock-up between the samples)
        if plan.linear:
            return int(np.argmin(np.abs(motion.motor_angle - value)))
        return int(np.argmin(np.abs((np.degrees(motion.motor_angle) - value + 180.0) % 360.0 - 180.0)))

    for lk in motion.lockups:  # mark the assembled samples either side of each locked run
        at, free = ("at", "after") if lk.exact else ("after", "by")
        if lk.run is None:  # between the samples, which all assemble: at the samples nearest to it
            notes += [(int(np.searchsorted(kept, near(lk.start_deg))), f"locks {at} {lk.show(lk.start_deg)} ({lk.joint})"),
                      (int(np.searchsorted(kept, near(lk.end_deg))), f"free again {free} {lk.show(lk.end_deg)}")]
            continue
        first, last = lk.run
        if motion.cyclic or first > 0:  # (a sweep that starts locked does not lock: it starts so)
            notes.append((int(np.searchsorted(kept, first)) - 1 if first > kept[0] else len(kept) - 1,
                          f"locks {at} {lk.show(lk.start_deg)} ({lk.joint})"))
        if motion.cyclic or last < ok.size - 1:  # (nor is one locked to its end ever free again)
            notes.append((int(np.searchsorted(kept, last)) % len(kept), f"free again {free} {lk.show(lk.end_deg)}"))
    return dict(
        joint_names=names, positions=positions, links=links,
        ground=list(plan.graph.ground), motor=None if plan.linear else (plan.graph.motor, plan.graph.pivot),
        tracks={n: tr.position[ok] for n, tr in motion.tracks.items()},
        units=plan.spec.units, title=f"{plan.spec.name} ({_count(ok)})", breaks=breaks, notes=notes,
        sliders=slides.from_graph(plan.graph, positions[0]), wrap=motion.cyclic and bool(ok[0] and ok[-1]),
    )


def _count(ok: np.ndarray) -> str:
    """The samples drawn, in words: ``360 samples``, or ``5 of 8 samples assembled`` (``--partial``)."""
    kept = int(np.sum(ok))
    return f"{kept} of {ok.size} samples assembled" if kept < ok.size else f"{ok.size} sample" + "s" * (ok.size != 1)


def captions(motion: Motion) -> list[str] | None:
    """An animation's frame captions: a linear input's stroke from rest at each assembled sample (a crank's
    turn is the animation's own default, None)."""
    if not motion.plan.linear:
        return None
    return [f"stroke {s:.4g} {motion.plan.spec.units}" for s in motion.motor_angle[motion.assembled]]


def draw_gif(path: str | Path, motion: Motion) -> None:
    """Write the animation of ``motion`` as a GIF (Pillow)."""
    from linkedit.io.gif import write_gif

    kw = drawing(motion)
    kw.pop("notes")
    write_gif(path, cyclic=motion.cyclic and bool(motion.assembled.all()), captions=captions(motion), **kw)


def draw_motion(path: str | Path | None, motion: Motion, *, animate: bool = False) -> str:
    """The motion plot (or, with ``animate``, the SMIL animation) of ``motion``; written to ``path`` if given.

    Curves are closed only for a full revolution that assembles at every sample.
    """
    cyclic = motion.cyclic and bool(motion.assembled.all())
    if animate:
        return animated_motion(path, cyclic=cyclic, captions=captions(motion), **drawing(motion))
    return motion_plot(path, cyclic=cyclic, **drawing(motion))
