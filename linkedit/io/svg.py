"""SVG pictures of planar linkages: a motion plot, an animation (SMIL) and an edit overlay.

All coordinates are world coordinates in the linkage's units (x right, y up). Every function
returns the SVG text and, when given a path, also writes it atomically. Inputs that are not
finite (NaN, inf) raise ValueError: nothing non-finite is ever written into a picture.

The drawn elements carry classes and names so programs (and tests) can find them:
``class="link"`` / ``"track"`` / ``"joint"`` / ``"joint-path"`` / ``"ground"`` / ``"motor"`` /
``"target"`` / ``"envelope"``, with ``data-name`` = the link, track or joint name; sliders:
``"rail"`` (a guide on the frame), ``"slot"`` (a slot in a moving link, ``"slot-arm"`` joining it
to its link's body) and ``"block"`` (the sliding joint), with ``data-name`` = the slider's name;
the edit overlay adds ``before`` or ``after`` to the class list.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.io import slides
from linkedit.io.atomic import write_text
from linkedit.io.figure_layout import finite
from linkedit.io.figure_style import ENVELOPE_GREEN, INK, PALETTE, PATH_GREY, Stroke
from linkedit.io.slides import Slide
from linkedit.io.svg_figure import Figure

MAX_FRAMES = 120          # animation frames per cycle at most (file size)
MAX_NAMED_JOINTS = 24     # joint names are written beside the joints up to this many joints


@dataclass(frozen=True)
class Drawing:
    """One linkage's motion, checked: ``positions`` (T, J, 2), ``tracks`` name → (T, 2)."""

    joint_names: list[str]
    positions: np.ndarray
    links: dict[str, list[int]]
    ground: list[int]
    motor: tuple[int, int] | None
    tracks: dict[str, np.ndarray]
    breaks: tuple[int, ...] = ()  #: sample indices that start a new piece of every curve
    sliders: tuple[Slide, ...] = ()
    #: the last sample is followed by the first (a full cycle with breaks inside): the last piece
    #: of a curve goes on into its first
    wrap: bool = False

    @classmethod
    def check(cls, joint_names: Sequence[str], positions: np.ndarray, links: Mapping[str, Sequence[int]],
              ground: Sequence[int], motor: tuple[int, int] | None,
              tracks: Mapping[str, np.ndarray], breaks: Sequence[int] = (), sliders: Sequence[Slide] = (),
              wrap: bool = False) -> Drawing:
        """Validate shapes, indices and finiteness (ValueError naming the offending input)."""
        names = [str(n) for n in joint_names]
        pos = finite("positions", positions, (None, len(names), 2))
        if pos.shape[0] == 0:
            raise ValueError("positions: no time samples")

        def index(what: str, i: object) -> int:
            k = int(i)  # type: ignore[call-overload]
            if k != i or not 0 <= k < len(names):
                raise ValueError(f"{what}: joint index {i!r} out of range 0..{len(names) - 1}")
            return k

        body = {}
        for name, members in links.items():
            body[str(name)] = [index(f"link {name}", i) for i in members]
            if len(body[str(name)]) < 2:
                raise ValueError(f"link {name}: needs at least 2 joints")
        paths = {str(n): finite(f"track {n}", c, (pos.shape[0], 2)) for n, c in tracks.items()}
        pair = None if motor is None else (index("motor joint", motor[0]), index("motor pivot", motor[1]))
        cuts = tuple(sorted({int(b) for b in breaks}))
        if any(not 0 < b < pos.shape[0] for b in cuts):
            raise ValueError(f"breaks: sample indices must be in 1..{pos.shape[0] - 1}, got {list(cuts)}")
        for s in sliders:
            for i in (s.joint, *(s.guide or ()), *s.link):
                index(f"slider {s.name}", i)
            if not np.isfinite(s.angle):
                raise ValueError(f"slider {s.name}: angle is not finite")
        return cls(names, pos, body, [index("ground", i) for i in ground], pair, paths, cuts, tuple(sliders),
                   bool(wrap) and bool(cuts))

    def pieces(self, curve: np.ndarray) -> list[np.ndarray]:
        """``curve`` (T, ...) cut at the breaks (with :attr:`wrap`, its last piece joined to its first)."""
        if not self.breaks:
            return [curve]
        parts = np.split(curve, self.breaks)
        return [np.concatenate([parts[-1], parts[0]])] + parts[1:-1] if self.wrap else parts

    def motor_turns_ccw(self) -> bool:
        """Whether the motor joint turns counter-clockwise about its pivot over the samples."""
        if self.motor is None:
            return True
        r = self.positions[:, self.motor[0]] - self.positions[:, self.motor[1]]
        angle = np.unwrap(np.arctan2(r[:, 1], r[:, 0]))
        return bool(angle[-1] >= angle[0])


def motion_plot(path: str | Path | None, *, joint_names: Sequence[str], positions: np.ndarray,
                links: Mapping[str, Sequence[int]], ground: Sequence[int], motor: tuple[int, int] | None,
                tracks: Mapping[str, np.ndarray], units: str = "", title: str = "", cyclic: bool = True,
                breaks: Sequence[int] = (), notes: Sequence[tuple[int, str]] = (),
                sliders: Sequence[Slide] = (), wrap: bool = False) -> str:
    """A static motion plot; returns the SVG text and writes it to ``path`` (atomically) if given.

    ``positions`` (T, J, 2): joint positions over the cycle in ``units``, sample 0 = rest pose;
    ``joint_names`` (J names); ``links``: link name → joint indices (2 or more); ``ground``:
    joint indices fixed to the frame; ``motor``: (driven joint, pivot joint) indices or None;
    ``tracks``: track name → (T, 2) positions. Draws the links at the rest pose, ground and
    motor symbols, every track's curve (one colour each, in the legend), the other joints'
    paths faint, axes in ``units``. ``cyclic``: the samples are one full cycle (curves closed).
    ``breaks``: sample indices where a curve is broken (samples before and after are not
    neighbours: the linkage was locked in between; ``wrap``: the last sample is followed by the
    first, a full cycle); ``notes``: (sample, text) marked on the
    first track's curve (or the motor joint's path), e.g. the lock-up angles. ``sliders``: the
    prismatic pairs (:class:`~linkedit.io.slides.Slide`), drawn as a rail on the frame or a slot in
    their guide link over the stretch their joint travels, and a block at the joint.
    """
    d = Drawing.check(joint_names, positions, links, ground, motor, tracks, breaks, sliders, wrap)
    fig = Figure(title=title, units=units, cyclic=cyclic)
    colors = _colors(d.tracks)
    _joint_paths(fig, d)
    _tracks(fig, d, colors, closed=cyclic)
    _mechanism(fig, d)
    marked = next(iter(d.tracks.values()), None)
    if marked is None and d.motor is not None:
        marked = d.positions[:, d.motor[0]]
    for sample, words in notes:
        if marked is not None:
            fig.joints(marked[sample][None], radius=4.0, fill="#ffffff", stroke=Stroke(PALETTE[1], 1.6), cls="lockup")
            fig.annotate(marked[sample], words, color=PALETTE[1], cls="lockup-label")
    for name, curve in d.tracks.items():
        fig.joints(curve[0][None], names=[name], fill=colors[name], stroke=Stroke(colors[name], 1.0),
                   cls="track-point")
    if len(d.joint_names) <= MAX_NAMED_JOINTS:
        for name, p in zip(d.joint_names, d.positions[0]):
            fig.annotate(p, name, cls="joint-label")
    return _finish(path, fig)


def animated_motion(path: str | Path | None, *, duration_s: float = 4.0, **drawing: Any) -> str:
    """An animated motion plot (SMIL, plays in a browser); returns the SVG text, writes ``path`` if given.

    Same inputs as :func:`motion_plot` (``notes`` are not drawn); see :func:`animation`.
    """
    return _finish(path, animation(duration_s=duration_s, **drawing))


def animation(*, joint_names: Sequence[str], positions: np.ndarray, links: Mapping[str, Sequence[int]],
              ground: Sequence[int], motor: tuple[int, int] | None, tracks: Mapping[str, np.ndarray],
              units: str = "", title: str = "", duration_s: float = 4.0, cyclic: bool = True,
              breaks: Sequence[int] = (), notes: Sequence[tuple[int, str]] = (),
              sliders: Sequence[Slide] = (), wrap: bool = False, captions: Sequence[str] | None = None) -> Figure:
    """The figure of an animated motion plot (written as SVG by :func:`animated_motion`, as GIF by
    :func:`linkedit.io.gif.write_gif`).

    ``captions``: one per sample, shown as its frame plays (a cylinder's stroke); by default the crank's
    turn from the first frame, where there is a motor.

    The cycle plays in ``duration_s`` seconds, forever; the T samples are thinned evenly to at
    most ``MAX_FRAMES`` frames (every element's ``<animate values=...>`` has one value per frame,
    plus frame 0 again at the end when ``cyclic``). Links, joints, sliders and track points move;
    track curves, joint paths, ground and motor symbols and rails are drawn still underneath.
    """
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be a positive number of seconds, got {duration_s}")
    d = Drawing.check(joint_names, positions, links, ground, motor, tracks, breaks, sliders, wrap)
    samples = d.positions.shape[0]
    frames = np.arange(samples) if samples <= MAX_FRAMES else (
        np.round(np.linspace(0, samples, MAX_FRAMES, endpoint=False)).astype(int))
    fig = Figure(title=title, units=units, duration_s=float(duration_s), cyclic=cyclic)
    colors = _colors(d.tracks)
    _joint_paths(fig, d)
    _tracks(fig, d, colors, closed=cyclic)
    _mechanism(fig, d, frames)
    for name, curve in d.tracks.items():
        fig.joints(curve[frames][:, None], names=[name], fill=colors[name], stroke=Stroke(colors[name], 1.0),
                   cls="track-point")
    if len(d.joint_names) <= MAX_NAMED_JOINTS:
        fig.labels(d.positions[frames], d.joint_names)
    if captions is not None:
        if len(captions) != samples:
            raise ValueError(f"captions: one per sample ({samples}), got {len(captions)}")
        fig.frame_caption([captions[k] for k in frames])
    elif d.motor is not None:
        r = d.positions[frames, d.motor[0]] - d.positions[frames, d.motor[1]]
        turn = np.degrees(np.unwrap(np.arctan2(r[:, 1], r[:, 0])))
        fig.frame_caption([f"crank {abs(a - turn[0]):.0f}°" for a in turn])
    return fig


def edit_overlay(path: str | Path | None, *, before: Mapping[str, object], after: Mapping[str, object],
                 targets: Mapping[str, np.ndarray],
                 envelope: tuple[float | None, float | None, float | None, float | None] | None,
                 units: str = "", title: str = "",
                 displacements: Sequence[tuple[str, Sequence[float] | None, Sequence[float]]] = (),
                 cyclic: bool = True, open_targets: Collection[str] = ()) -> str:
    """The edit picture: before faint, after solid, targets dashed, envelope box; returns the SVG text.

    ``before`` / ``after``: the keyword arguments of :func:`motion_plot` for the linkage before
    and after the edit (``joint_names``, ``positions`` (T, J, 2), ``links``, ``ground``,
    ``motor``, ``tracks``; ``units`` and ``title`` keys, if present, are ignored — this
    function's own are used). ``targets``: label → (T', 2) target curve in ``units``, coloured
    like the track whose name is a word of the label (``"retarget foot"`` → ``foot``).
    ``envelope``: (xmin, xmax, ymin, ymax) with None for an open side (drawn to the plot edge),
    or None for no box. ``displacements``: (label, old position or None, target) of each
    displaced point: a marker at the target and an arrow from the old position. ``cyclic``: the
    samples are one full cycle (curves closed; else open, as a partial sweep's); ``open_targets``:
    labels of targets drawn open all the same (a curve given open). Writes ``path`` atomically if given.
    """
    old, new = _drawing("before", before), _drawing("after", after)
    fig = Figure(title=title, units=units, cyclic=cyclic)
    colors = _colors({**new.tracks, **old.tracks})
    if envelope is not None:
        if len(envelope) != 4:
            raise ValueError(f"envelope: expected (xmin, xmax, ymin, ymax), got {envelope!r}")
        fig.box(*envelope)
    for name, curve in old.tracks.items():
        fig.polyline(curve, Stroke(colors[name], 1.6, "faint"), closed=cyclic, cls="track before", name=name)
    for link, members in old.links.items():
        fig.link(old.positions[0][members], name=link, style="faint", cls="link before")
    _joint_paths(fig, new, cls="joint-path after")
    spare = iter(PALETTE[len(colors) % len(PALETTE):] + PALETTE[:len(colors) % len(PALETTE)])
    for label, curve in targets.items():
        words = str(label).split()
        color = next((colors[w] for w in words if w in colors), None) or next(spare)
        fig.polyline(finite(f"target {label}", curve, (None, 2)), Stroke(color, 1.6, "dashed"),
                     closed=cyclic and label not in open_targets,
                     cls="target", name=str(label))
    _tracks(fig, new, colors, closed=cyclic, cls="track after")
    _mechanism(fig, new, cls="after")
    for label, old_at, target in displacements:
        if old_at is not None:
            fig.arrow(old_at, target, Stroke(PALETTE[1], 1.6, "dashed"), cls="displace", name=label)
        fig.joints(np.asarray(target, dtype=float)[None], radius=5.0, fill="#ffffff", stroke=Stroke(PALETTE[1], 2.0),
                   cls="displace-target")
        fig.annotate(target, label, color=PALETTE[1], cls="displace-label")
    fig.legend("before", Stroke(PATH_GREY, 2.0, "faint"))
    fig.legend("after", Stroke(INK, 2.0))
    if targets:
        fig.legend("target", Stroke(INK, 1.6, "dashed"))
    if envelope is not None:
        fig.legend("envelope", Stroke(ENVELOPE_GREEN, 1.8, "dashed"), "box")
    if displacements:
        fig.legend("displace target", Stroke(PALETTE[1], 2.0), "dot")
    return _finish(path, fig)


def _drawing(which: str, kw: Mapping[str, object]) -> Drawing:
    fields = ("joint_names", "positions", "links", "ground", "motor", "tracks")
    unknown = set(kw) - set(fields) - {"units", "title", "breaks", "notes", "sliders", "wrap"}
    missing = set(fields) - set(kw)
    if unknown or missing:
        raise ValueError(f"{which}: unknown keys {sorted(unknown)}, missing keys {sorted(missing)}")
    try:
        return Drawing.check(**{k: kw[k] for k in fields}, breaks=kw.get("breaks", ()),  # type: ignore[arg-type]
                             sliders=kw.get("sliders", ()), wrap=bool(kw.get("wrap", False)))  # type: ignore[arg-type]
    except ValueError as exc:
        raise ValueError(f"{which}: {exc}") from None


def _colors(tracks: Mapping[str, np.ndarray]) -> dict[str, str]:
    return {name: PALETTE[n % len(PALETTE)] for n, name in enumerate(tracks)}


def _joint_paths(fig: Figure, d: Drawing, cls: str = "joint-path") -> None:
    """Faint paths of the joints that move and are not already drawn as a track."""
    p = d.positions
    moves = np.ptp(p, axis=0).max(axis=1) > 1e-12 * max(1.0, float(np.abs(p).max()))
    curves = list(d.tracks.values())
    drawn = False
    for j in np.flatnonzero(moves):
        if any(np.allclose(p[:, j], c, rtol=0, atol=1e-9 * max(1.0, float(np.abs(c).max()))) for c in curves):
            continue
        for piece in d.pieces(p[:, j]):
            fig.polyline(piece, Stroke(PATH_GREY, 0.9, "faint"), closed=fig.cyclic and not d.breaks, cls=cls,
                         name=d.joint_names[j], label=None if drawn else "joint paths")
            drawn = True


def _tracks(fig: Figure, d: Drawing, colors: Mapping[str, str], *, closed: bool, cls: str = "track") -> None:
    """Each track's curve in its colour; past the palette's colours, dashed (so the 11th differs from the 1st)."""
    for n, (name, curve) in enumerate(d.tracks.items()):
        style = "dashed" if n >= len(PALETTE) else "solid"
        for k, piece in enumerate(d.pieces(curve)):
            fig.polyline(piece, Stroke(colors[name], 2.2, style), closed=closed and not d.breaks, cls=cls, name=name,
                         label=name if k == 0 else None)


def _mechanism(fig: Figure, d: Drawing, frames: np.ndarray | None = None, cls: str = "") -> None:
    """Ground and motor symbols, slider guides, links, blocks and joints at sample 0, or moving over
    the sample indices ``frames``."""
    pose = d.positions[0] if frames is None else d.positions[frames]
    rest = d.positions[0]
    for g in d.ground:
        fig.ground(rest[g], name=d.joint_names[g])
    if d.motor is not None:
        fig.motor(rest[d.motor[1]], ccw=d.motor_turns_ccw(), name=d.joint_names[d.motor[0]])
    extra = f" {cls}" if cls else ""
    at = [0] if frames is None else frames
    for s in d.sliders:
        if s.guide is None:
            fig.rail(slides.slot(s, d.positions), _rail_side(s, rest), name=s.name, cls="rail" + extra)
    for name, members in d.links.items():
        fig.link(pose[..., members, :], name=name, cls="link" + extra)
    for s in d.sliders:
        if s.guide is None:
            continue
        reach = slides.arm(s, d.positions)
        if reach is not None:
            fig.link(_frames(slides.carry(s, d.positions, reach)[at]), name=s.name, cls="slot-arm" + extra)
        fig.slot(_frames(slides.carry(s, d.positions, slides.slot(s, d.positions))[at]), name=s.name,
                 cls="slot" + extra)
    for s in d.sliders:
        p0 = d.positions[0, s.joint]
        unit = slides.carry(s, d.positions, np.array([p0, p0 + [np.cos(s.angle), np.sin(s.angle)]]))[at]
        fig.block(_frames(d.positions[at, s.joint]), _frames(unit[:, 1] - unit[:, 0]), name=s.name,
                  cls="block" + extra)
    fig.joints(pose, names=d.joint_names, cls="joint" + extra)


def _frames(a: np.ndarray) -> np.ndarray:
    """One frame ``(1, ...)`` as the still ``(...)``; more frames kept."""
    return a[0] if a.shape[0] == 1 else a


def _rail_side(s: Slide, rest: np.ndarray) -> np.ndarray:
    """The side of a frame rail its hatching goes: below it, or for a steep rail away from the mechanism."""
    n = np.array([np.sin(s.angle), -np.cos(s.angle)])
    if abs(np.cos(s.angle)) < 0.3:
        return n if float(n @ (rest[s.joint] - rest.mean(axis=0))) >= 0 else -n
    return n if n[1] < 0 else -n


def _finish(path: str | Path | None, fig: Figure) -> str:
    svg = fig.render()
    if path is not None:
        write_text(path, svg)
    return svg
