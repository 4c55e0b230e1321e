"""Write a linkage spec back as YAML that loads and simulates unchanged."""

from __future__ import annotations

import json
from collections.abc import Mapping

import yaml

from linkedit.spec.linkage import JointTrack, LinkageSpec
from linkedit.spec.yamlload import SpecLoader


def _num(v: float) -> str:
    """Shortest text that reads back as the same double (integers without a decimal point)."""
    v = float(v)
    return str(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)


def _text(v: str) -> str:
    """A name or text as a YAML scalar: plain when it reads back unchanged, else double-quoted."""
    plain = v and v == v.strip() and not any(ch in v for ch in ",[]{}#:&*!|>'\"%@`") and "  " not in v
    if plain:
        try:
            plain = yaml.load(v, Loader=SpecLoader) == v
        except yaml.YAMLError:
            plain = False
    return v if plain else json.dumps(v, ensure_ascii=False)


def dump_linkage(spec: LinkageSpec, header: str = "", notes: Mapping[str, str] | None = None) -> str:
    """YAML text of ``spec`` in key order name, units, description, joints, ground, links, sliders, motor, tracks.

    Numbers are written with ``repr`` (17 significant digits where needed), so the file loads
    back to the same doubles. ``header`` becomes a comment block at the top; ``notes`` adds
    end-of-line comments, keyed ``"joints.<name>"``, ``"links.<name>"``, ``"tracks.<name>"``
    or a top-level key (``"joints"``, ``"ground"``, ``"motor"``…).
    """
    notes = notes or {}
    lines: list[tuple[str, str]] = []  # (text, note key)

    def add(text: str, key: str = "") -> None:
        lines.append((text, key))

    for text in header.strip().splitlines() if header.strip() else ():
        add(f"# {text}".rstrip())
    add(f"name: {_text(spec.name)}", "name")
    add(f"units: {_text(spec.units)}", "units")
    if spec.description and spec.description == " ".join(spec.description.split()):
        add("description: >-", "description")
        for text in _wrap(spec.description, 96):
            add(f"  {text}")
    elif spec.description:
        add(f"description: {_text(spec.description)}", "description")
    add("joints:", "joints")
    for n, (x, y) in spec.joints.items():
        add(f"  {_text(n)}: [{_num(x)}, {_num(y)}]", f"joints.{n}")
    add(f"ground: [{', '.join(map(_text, spec.ground))}]", "ground")
    add("links:", "links")
    for n, members in spec.links.items():
        add(f"  {_text(n)}: [{', '.join(map(_text, members))}]", f"links.{n}")
    if spec.sliders:
        add("sliders:", "sliders")
        for n, sl in spec.sliders.items():
            what = f"joint: {_text(sl.joint)}" if sl.joint is not None else f"link: {_text(str(sl.link))}"
            add(f"  {_text(n)}: {{{what}, guide: {_text(sl.guide)}, angle_deg: {_num(sl.angle_deg)}}}",
                f"sliders.{n}")
    m = spec.motor
    if m.slider is not None and m.stroke is not None:  # a linear input
        motor = f"slider: {_text(m.slider)}, stroke: [{_num(m.stroke[0])}, {_num(m.stroke[1])}]"
    else:
        motor = f"joint: {_text(str(m.joint))}, pivot: {_text(str(m.pivot))}"
        if m.direction != "ccw":
            motor += f", direction: {m.direction}"
    for key in ("range_deg", "oscillate_deg"):
        value = getattr(m, key)
        if value is not None:
            motor += f", {key}: [{_num(value[0])}, {_num(value[1])}]"
    add(f"motor: {{{motor}}}", "motor")
    if spec.tracks:
        add("tracks:", "tracks")
        for n, t in spec.tracks.items():
            if isinstance(t, JointTrack):
                body = f"joint: {_text(t.joint)}"
            else:
                body = f"link: {_text(t.link)}, at: [{_num(t.at[0])}, {_num(t.at[1])}]"
            add(f"  {_text(n)}: {{{body}}}", f"tracks.{n}")
    if spec.samples is not None:
        add(f"samples: {spec.samples}", "samples")
    unknown = set(notes) - {key for _, key in lines}
    if unknown:
        raise ValueError(f"notes for fields that are not in the spec: {sorted(unknown)}")
    width = max((len(text) for text, key in lines if key in notes), default=0) + 2
    return "".join(f"{text:<{width}}# {notes[key]}\n" if key in notes else f"{text}\n" for text, key in lines)


def _wrap(text: str, width: int) -> list[str]:
    """Greedy word wrap (a folded YAML scalar reads back as the original single-spaced text)."""
    out: list[str] = []
    for word in text.split():
        if out and len(out[-1]) + 1 + len(word) <= width:
            out[-1] += " " + word
        else:
            out.append(word)
    return out
