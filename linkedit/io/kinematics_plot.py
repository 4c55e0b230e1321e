"""``linkedit plot``: a point's kinematics and the linkage's transmission quality against crank angle.

Panels: position (x, y), velocity, acceleration and jerk (x, y and magnitude) of one track or
joint; the transmission angle of every dyad with the 40°–140° band and its worst (near-toggle)
sample marked where it leaves the band; d_s = sin²(transmission angle). Derivatives are per
radian of motor angle, or per second for a motor at constant ``rpm``. Velocity and
acceleration are the result's (analytic for the symbolic engine); jerk is the central
difference of the acceleration over the inputs (periodic for a full turn; left out where a swing turns back).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from linkedit.errors import InputError
from linkedit.io.h5read import open_result
from linkedit.io.svg_chart import Panel, chart

#: the transmission angle a designer wants to stay in, degrees
GOOD_TRANSMISSION = (40.0, 140.0)


@dataclass(frozen=True)
class Kinematics:
    """What the plot shows, read from a planar result: (T,) input from rest, (T, 2) arrays, (T, D) dyads."""

    name: str
    units: str
    point: str
    crank_deg: np.ndarray  #: (T,) crank angle from rest, degrees; a linear input's stroke, ``units``
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray
    dyad_joints: list[str]
    transmission_deg: np.ndarray
    singularity: np.ndarray
    linear: bool = False  #: a linear input (a cylinder): derivatives per unit of stroke
    #: the sign of d(input)/d(sample order): −1 for a clockwise motor (its angle falls as it turns)
    #: or a stroke that retracts, 0 for a swing (``oscillate_deg``: both); d/dt = sign · ω · d/dθ
    sign: float = 1.0

    @property
    def input_label(self) -> str:
        return f"stroke from rest ({self.units})" if self.linear else "crank angle from rest (°)"


def read_kinematics(path: str | Path, *, track: str | None = None, joint: str | None = None) -> Kinematics:
    """Read a planar result (``specs/planar-hdf5.md``); the point is ``track`` or ``joint``
    (default: the first track, else the motor joint). Every dataset is checked against the
    layout before it is read (:mod:`linkedit.io.h5read`)."""
    with open_result(path, kind="planar") as f:
        t = f.array("t", shape=(None,))
        T = t.size
        if T == 0:
            raise f.error("t", "no samples")
        names = f.strings("joint") if f.has("joint") else f.strings("joints/names")
        J = len(names)
        tracks = f.names("tracks") if f.has("tracks") else []
        if track is not None and track not in tracks:
            raise InputError(f"no track {track!r} (tracks: {', '.join(tracks) or 'none'})", file=str(path), field="--track")
        if joint is not None and joint not in names:
            raise InputError(f"no joint {joint!r} (joints: {', '.join(names)})", file=str(path), field="--joint")
        linear = f.attr("input", default="rotary") == "linear"
        if joint is None and track is None:
            track = tracks[0] if tracks else None
            if track is None:
                motor = f.attr("motor", "joints", kind=int)
                if not 0 <= motor < J:
                    raise f.error("joints", f"attribute 'motor': joint {motor} of {J}")
                joint = names[motor]
        if track is not None:
            pos, vel, acc = (f.array(f"tracks/{track}/{q}", shape=(T, 2)) for q in ("position", "velocity", "acceleration"))
        else:
            k = names.index(str(joint))
            pos, vel, acc = (f.array(f"joints/{q}", shape=(T, J, 2))[:, k] for q in ("position", "velocity", "acceleration"))
        angle = f.array("stroke" if linear else "motor_angle", shape=(T,))
        rigid = f.array("rules/rigid", shape=(None,), kinds="b")
        R = rigid.size
        ijk = f.array("rules/joints", shape=(R, 3), kinds="iu").astype(np.int64)
        if R and not ((ijk >= 0) & (ijk < J)).all():
            raise f.error("rules/joints", f"joint indices outside 0…{J - 1}")
        dyads = ~rigid
        rebuilt = [names[k] for k in ijk[:, 2]]
        alpha = f.array("diagnostics/transmission_angle", shape=(T, R))[:, dyads]
        ds = f.array("diagnostics/singularity", shape=(T, R))[:, dyads]
        ok = f.array("diagnostics/assembled", shape=(T,), kinds="biu").astype(bool)
        cyclic = bool(t[-1] < 1.0) and T > 2  # a full turn samples t = n/T; a sweep ends at 1
        units, name = f.attr("units"), f.attr("name", default=Path(path).stem)
    turned = angle if linear else np.unwrap(angle)
    crank = np.abs(turned - turned[0]) if linear else np.degrees(np.abs(turned - turned[0]))
    steps = np.diff(turned)
    swings = bool((steps > 0).any() and (steps < 0).any())
    jerk = _jerk(acc, turned, bool(cyclic and ok.all()), 0.0 if swings or linear else 2.0 * np.pi)
    alpha = np.where(ok[:, None], np.degrees(alpha), np.nan)
    return Kinematics(name=name, units=units, point=str(track or joint), crank_deg=crank, position=pos,
                      velocity=vel, acceleration=acc, jerk=jerk,
                      dyad_joints=[n for n, d in zip(rebuilt, dyads) if d], transmission_deg=alpha,
                      singularity=np.where(ok[:, None], ds, np.nan), linear=linear,
                      sign=0.0 if swings else float(np.sign(steps.sum())) or 1.0)


def _jerk(acc: np.ndarray, x: np.ndarray, cyclic: bool, turn: float) -> np.ndarray:
    """d acc / d input, (T, 2), by central differences over the inputs ``x`` (T,) (radians or
    stroke, in sample order; one-sided at a sweep's ends). ``cyclic``: the last sample is followed
    by the first, ``turn`` (2π for a full revolution, 0 for a swing) further on. NaN at a sample
    where the input turns back (a swing's ends): the difference there does not measure it."""
    if x.size < 2:
        return np.zeros_like(acc)
    if cyclic:
        ahead, behind = np.roll(acc, -1, axis=0), np.roll(acc, 1, axis=0)
        way = np.sign(x[-1] - x[0]) if turn else 0.0
        xa, xb = np.r_[x[1:], x[0] + way * turn], np.r_[x[-1] - way * turn, x[:-1]]
    else:
        ahead, behind = np.r_[acc[1:], acc[-1:]], np.r_[acc[:1], acc[:-1]]
        xa, xb = np.r_[x[1:], x[-1]], np.r_[x[0], x[:-1]]
    with np.errstate(divide="ignore", invalid="ignore"):
        jerk = (ahead - behind) / (xa - xb)[:, None]
    inner = slice(None) if cyclic else slice(1, -1)
    back = np.zeros(x.size, dtype=bool)
    back[inner] = ((xa - x) * (x - xb))[inner] <= 0.0
    return np.where(back[:, None], np.nan, jerk)


def worst_transmission(k: Kinematics) -> list[tuple[str, float, float]]:
    """Per dyad that leaves the 40°–140° band: (joint, worst angle in degrees, crank angle in degrees)."""
    out = []
    lo, hi = GOOD_TRANSMISSION
    for d, joint in enumerate(k.dyad_joints):
        a = k.transmission_deg[:, d]
        if not np.isfinite(a).any():
            continue
        dev = np.abs(np.nan_to_num(a, nan=90.0) - 90.0)
        t = int(np.argmax(dev))
        if a[t] < lo or a[t] > hi:
            out.append((joint, float(a[t]), float(k.crank_deg[t])))
    return out


def kinematics_svg(k: Kinematics, *, rpm: float | None = None) -> str:
    """The plot (see module docstring); with ``rpm`` the derivatives are per second."""
    u = k.units
    if rpm is not None and k.linear:
        raise InputError("a linear input has no rpm: its derivatives are per unit of stroke", field="--rpm")
    if rpm is not None and not k.sign:
        raise InputError("an oscillate_deg input swings at a varying speed, not at a constant rpm: plot it per "
                         "radian (drop --per-second)", field="--rpm")
    if rpm is not None:
        w = rpm * 2.0 * math.pi / 60.0
        scales, per = (k.sign * w, w ** 2, k.sign * w ** 3), ("/s", "/s²", "/s³")
    else:
        scales, per = (1.0, 1.0, 1.0), (f"/{u}", f"/{u}²", f"/{u}³") if k.linear else ("/rad", "/rad²", "/rad³")
    panels = [Panel(f"position ({u})", name="position")]
    panels[0].line(f"{k.point} x", k.position[:, 0])
    panels[0].line(f"{k.point} y", k.position[:, 1])
    for what, arr, s, p in zip(("velocity", "acceleration", "jerk"), (k.velocity, k.acceleration, k.jerk), scales, per):
        panel = Panel(f"{what} ({u}{p})", name=what)
        panel.line("x", arr[:, 0] * s)
        panel.line("y", arr[:, 1] * s)
        panel.line("magnitude", np.hypot(arr[:, 0], arr[:, 1]) * s, dashed=True)
        panels.append(panel)
    if k.dyad_joints:
        tp = Panel("transmission angle (°)", band=GOOD_TRANSMISSION, name="transmission-angle")
        ds = Panel("d_s = sin² (transmission)", name="singularity")
        for d, joint in enumerate(k.dyad_joints):
            tp.line(f"at {joint}", k.transmission_deg[:, d])
            ds.line(f"at {joint}", k.singularity[:, d])
        tp.marks = [(x, a, f"{j} {a:.1f}°") for j, a, x in worst_transmission(k)]
        panels += [tp, ds]
    speed = f", {rpm:g} rpm" if rpm is not None else ""
    return chart(k.crank_deg, panels, xlabel=k.input_label, title=f"{k.name}: {k.point}{speed}")
