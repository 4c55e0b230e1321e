"""Pictures of a simulated planar motion: adapts a :class:`~linkedit.planar.Motion` to the SVG drawings."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io.svg import animated_motion, motion_plot
from linkedit.planar.simulate import Motion


def drawing(motion: Motion) -> dict[str, Any]:
    """The keyword arguments of :func:`linkedit.io.svg.motion_plot` for the assembled samples."""
    plan = motion.plan
    ok = motion.assembled
    return dict(
        joint_names=plan.joint_names, positions=motion.positions[ok],
        links={n: list(m) for n, m in zip(plan.graph.link_names, plan.graph.links)},
        ground=list(plan.graph.ground), motor=None if plan.linear else (plan.graph.motor, plan.graph.pivot),
        tracks={n: tr.position[ok] for n, tr in motion.tracks.items()},
        units=plan.spec.units, title=f"{plan.spec.name} ({int(np.sum(ok))} samples)",
    )


def draw_motion(path: str | Path | None, motion: Motion, *, animate: bool = False) -> str:
    """The motion plot (or, with ``animate``, the SMIL animation) of ``motion``; written to ``path`` if given.

    Curves are closed only for a full revolution that assembles at every sample.
    """
    cyclic = motion.cyclic and bool(motion.assembled.all())
    draw = animated_motion if animate else motion_plot
    return draw(path, cyclic=cyclic, **drawing(motion))
