"""pylinkage 0.x files (``Linkage.save_to_json``) → a linkage document given by link lengths (the
0.x form of :mod:`linkedit.interop.pylinkage`, whose docstring describes the joints it reads)."""

from __future__ import annotations

import math
from typing import Any

from linkedit.errors import InputError
from linkedit.interop.document import JsonFile
from linkedit.spec.lengths import assemble


def legacy(file: JsonFile, reach: float) -> dict[str, Any]:
    data = file.data
    inline: dict[str, dict[str, Any]] = {}
    entries: list[dict[str, Any]] = []
    for n, j in enumerate(file.objects(data, "joints")):
        at = ("joints", n)
        kind = file.name(j, "type", at)
        jid = file.name(j, "name", at, f"joint_{n}") if j.get("name") else f"joint_{n}"
        entries.append({"obj": j, "at": at, "type": kind, "name": jid,
                        "xy": [file.number(j, "x", at, 0.0) if j.get("x") is not None else 0.0,
                               file.number(j, "y", at, 0.0) if j.get("y") is not None else 0.0],
                        **{key: _ref(file, j, key, at, inline) for key in ("joint0", "joint1", "joint2")}})
    entries = list(inline.values()) + entries
    names = {e["name"] for e in entries}
    joints: dict[str, Any] = {}
    links: dict[str, Any] = {}
    ground: list[str] = []
    motor: dict[str, Any] | None = None
    tracks: dict[str, Any] = {}
    for e in entries:
        kind, jn, j, at = e["type"], e["name"], e["obj"], e["at"]
        if jn in joints:
            raise file.error(j, f"joint {jn!r} given twice", (*at, "name"))
        needs = {"Crank": ["joint0"], "Revolute": ["joint0", "joint1"], "Fixed": ["joint0", "joint1"],
                 "Prismatic": ["joint0", "joint1", "joint2"], "Linear": ["joint0", "joint1", "joint2"]}.get(kind, [])
        for key in needs:
            if e[key] is None or e[key] not in names:
                raise file.error(j, f"joint {jn!r} ({kind}) needs {key}, the name of another joint"
                                    + (f", not {e[key]!r}" if e[key] is not None else ""), (*at, key))
        if kind == "Static":
            joints[jn] = e["xy"]
            ground.append(jn)
        elif kind == "Crank":
            if motor is not None:
                raise file.error(j, f"joint {jn}: a second crank; linkedit drives one motor", at)
            pivot = e["joint0"]
            p = next(x["xy"] for x in entries if x["name"] == pivot)
            joints[jn] = {"from": [pivot], "angle_deg": math.degrees(math.atan2(e["xy"][1] - p[1], e["xy"][0] - p[0]))}
            links[f"{pivot}-{jn}"] = {"joints": [pivot, jn], "length": file.number(j, "distance", at)}
            motor = {"joint": jn, "pivot": pivot, "direction": "cw" if file.number(j, "angle", at, 0.0) < 0 else "ccw"}
        elif kind == "Revolute":
            joints[jn] = {"near": e["xy"]}
            links[f"{e['joint0']}-{jn}"] = {"joints": [e["joint0"], jn], "length": file.number(j, "distance0", at)}
            links[f"{e['joint1']}-{jn}"] = {"joints": [e["joint1"], jn], "length": file.number(j, "distance1", at)}
            tracks[jn] = {"joint": jn}
        elif kind == "Fixed":
            joints[jn] = None  # placed below, once every link length is known
            tracks[jn] = {"joint": jn}
        elif kind in ("Prismatic", "Linear"):  # at revolute_radius from joint0, on the line joint1-joint2
            if jn in (e["joint1"], e["joint2"]) or e["joint1"] == e["joint2"]:
                raise file.error(j, f"joint {jn!r} ({kind}): joint1 and joint2 must be two other joints", at)
            joints[jn] = {"line": [e["joint1"], e["joint2"]], "near": e["xy"]}
            links[f"{e['joint0']}-{jn}"] = {"joints": [e["joint0"], jn], "length": file.number(j, "revolute_radius", at)}
            tracks[jn] = {"joint": jn}
        else:
            raise file.error(j, f"joint {jn}: {kind} joints are not supported (Static, Crank, Revolute, Fixed, "
                                "Prismatic)", (*at, "type"))
    if motor is None:
        raise file.error(data, "no Crank joint: nothing drives the linkage", ("joints",))
    for e in entries:
        if e["type"] == "Fixed":
            joints[e["name"]], links[f"{e['joint0']}-{e['joint1']}-{e['name']}"] = _fixed(file, e, links, ground, entries)
    for e in entries:
        for key in ("x", "y", "distance", "distance0", "distance1", "revolute_radius"):
            if isinstance(e["obj"].get(key), (int, float)) and abs(e["obj"][key]) > reach:
                raise file.error(e["obj"], f"beyond {reach:g}: too large to assemble from lengths", (*e["at"], key))
    doc = {"joints": joints, "ground": ground, "links": links, "motor": motor, "tracks": tracks}
    slides = [e for e in entries if e["type"] in ("Prismatic", "Linear")]
    if slides:
        doc["sliders"] = _slots(file, slides, doc)
    return doc


def _slots(file: JsonFile, slides: list[dict[str, Any]], doc: dict[str, Any]) -> dict[str, Any]:
    """The sliders of 0.x ``Prismatic`` joints: each on the line through its joint1 and joint2, on the frame
    when both are, else on the link that carries both (at its direction in the assembled rest pose)."""
    try:
        rest = assemble(doc)["joints"]
    except InputError as exc:  # lengths that cannot close, as validating the document would say it
        raise InputError(exc.message, file=file.source, field=exc.field) from None
    sliders: dict[str, Any] = {}
    for e in slides:
        jn, p, q = e["name"], e["joint1"], e["joint2"]
        guide = "ground" if p in doc["ground"] and q in doc["ground"] else next(
            (name for name, lk in doc["links"].items() if {p, q} <= set(lk["joints"]) and jn not in lk["joints"]), None)
        if guide is None:
            raise file.error(e["obj"], f"joint {jn!r} ({e['type']}): its line through {p!r} and {q!r} is fixed neither "
                                       "to the frame nor to one link, so it is no slot linkedit can slide in", e["at"])
        (x1, y1), (x2, y2) = rest[p], rest[q]
        sliders[jn] = {"joint": jn, "guide": guide, "angle_deg": math.degrees(math.atan2(y2 - y1, x2 - x1))}
    return sliders


def _fixed(file: JsonFile, e: dict[str, Any], links: dict[str, Any], ground: list[str],
           entries: list[dict[str, Any]]) -> tuple[dict[str, Any], dict[str, Any]]:
    """A ``Fixed`` joint and its plate, as pylinkage places it: at ``distance`` from joint0, ``angle`` radians
    from the direction joint0 → joint1 (its own x, y are a cache: null before a first run, or another pose's)."""
    p, q, jn = e["joint0"], e["joint1"], e["name"]
    pq = next((size for lk in links.values() for size in [_length(lk, p, q)] if size is not None), None)
    if pq is None and p in ground and q in ground:
        pq = math.dist(*(x["xy"] for x in entries if x["name"] in (p, q)))
    if pq is None:
        raise file.error(e["obj"], f"joint {jn!r} (Fixed): {p!r} and {q!r} are not the two ends of one link, so it is "
                                   "not rigid with them; linkedit takes a Fixed joint on a link", e["at"])
    r, angle = file.number(e["obj"], "distance", e["at"]), file.number(e["obj"], "angle", e["at"])
    qe = math.sqrt(max(pq * pq + r * r - 2 * pq * r * math.cos(angle), 0.0))
    return {"from": [p, q], "branch": "ccw" if math.sin(angle) > 0 else "cw"}, {"joints": [p, q, jn], "lengths": [pq, r, qe]}


def _length(link: dict[str, Any], p: str, q: str) -> float | None:
    """The length between joints ``p`` and ``q`` that a bar or plate given by lengths fixes, if it holds both."""
    members = link["joints"]
    if p not in members or q not in members:
        return None
    if "length" in link:
        return float(link["length"])
    pairs = [{a, b} for i, a in enumerate(members) for b in members[i + 1:]]
    return float(link["lengths"][pairs.index({p, q})])


def _ref(file: JsonFile, obj: dict[str, Any], key: str, at: tuple[str | int, ...],
         inline: dict[str, dict[str, Any]]) -> str | None:
    """The joint a ``joint0``/``joint1`` entry names (a name, ``{ref: name}``, or an inline Static joint, collected)."""
    value = obj.get(key)
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, dict) and value.get("inline"):
        name = file.name(value, "name", (*at, key), f"static_{len(inline)}") if value.get("name") else f"static_{len(inline)}"
        xy = [file.number(value, c, (*at, key), 0.0) if value.get(c) is not None else 0.0 for c in "xy"]
        inline[name] = {"obj": value, "at": (*at, key), "type": "Static", "name": name, "xy": xy,
                        "joint0": None, "joint1": None}
        return name
    if isinstance(value, dict) and "ref" in value:
        return file.name(value, "ref", (*at, key))
    raise file.error(obj, f"cannot read the joint reference {str(value)[:40]}", (*at, key))
