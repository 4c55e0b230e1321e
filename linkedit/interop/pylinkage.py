"""pylinkage's JSON serialization (``Linkage`` saved with ``save_to_json``) → a linkage document.

pylinkage describes joints, not links: ``Static`` (a frame point), ``Crank`` (turns about
``joint0`` at ``distance``; the sign of ``angle``, its step per iteration, gives the direction),
``Revolute`` (at ``distance0`` from ``joint0`` and ``distance1`` from ``joint1``; its x, y pick
the branch), ``Fixed`` (rigid with ``joint0`` and ``joint1``: a plate). Each becomes links given
by length (``specs/linkage.md``), so lengths are pylinkage's to the last bit and the rest pose
is assembled on the branch nearest the saved positions. ``Prismatic``/``Linear`` joints
(sliders) are not supported yet.
"""

from __future__ import annotations

import json
import math
from typing import Any

from linkedit.errors import InputError


def _ref(value: Any, inline: dict[str, dict[str, Any]]) -> str | None:
    """The joint a ``joint0``/``joint1`` entry names; inline Static joints are collected."""
    if value is None:
        return None
    if isinstance(value, str):
        return value
    if isinstance(value, dict) and value.get("inline"):
        name = value.get("name") or f"static_{len(inline)}"
        inline[name] = {"type": "Static", "name": name, "x": value.get("x", 0.0), "y": value.get("y", 0.0)}
        return name
    if isinstance(value, dict) and "ref" in value:
        return str(value["ref"])
    raise InputError(f"cannot read the joint reference {value!r}")


def to_document(text: str, *, source: str, units: str, name: str | None = None) -> dict[str, Any]:
    """A linkage document from pylinkage JSON text."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"malformed JSON: {exc.msg}", file=source, line=exc.lineno) from None
    if not isinstance(data, dict) or not isinstance(data.get("joints"), list):
        raise InputError("not a pylinkage linkage (no 'joints' list)", file=source)
    inline: dict[str, dict[str, Any]] = {}
    entries = []
    for n, j in enumerate(data["joints"]):
        if not isinstance(j, dict) or "type" not in j:
            raise InputError(f"joints[{n}]: a joint needs a type", file=source)
        entries.append({**j, "name": str(j.get("name") or f"joint_{n}"),
                        "joint0": _ref(j.get("joint0"), inline), "joint1": _ref(j.get("joint1"), inline)})
    entries = list(inline.values()) + entries
    joints: dict[str, Any] = {}
    links: dict[str, Any] = {}
    ground, motor, tracks = [], None, {}
    for j in entries:
        kind, jn = j["type"], j["name"]
        xy = [float(j.get("x") or 0.0), float(j.get("y") or 0.0)]
        if kind == "Static":
            joints[jn] = xy
            ground.append(jn)
        elif kind == "Crank":
            if motor is not None:
                raise InputError(f"joint {jn}: a second crank; linkedit drives one motor", file=source)
            pivot = j["joint0"]
            joints[jn] = {"from": [pivot], "angle_deg": _angle_deg(xy, entries, pivot)}
            links[f"{pivot}-{jn}"] = {"joints": [pivot, jn], "length": float(j["distance"])}
            motor = {"joint": jn, "pivot": pivot, "direction": "cw" if float(j.get("angle") or 0) < 0 else "ccw"}
        elif kind == "Revolute":
            joints[jn] = {"near": xy}
            links[f"{j['joint0']}-{jn}"] = {"joints": [j["joint0"], jn], "length": float(j["distance0"])}
            links[f"{j['joint1']}-{jn}"] = {"joints": [j["joint1"], jn], "length": float(j["distance1"])}
            tracks[jn] = {"joint": jn}
        elif kind == "Fixed":
            joints[jn] = xy
            links[f"{j['joint0']}-{j['joint1']}-{jn}"] = [j["joint0"], j["joint1"], jn]
            tracks[jn] = {"joint": jn}
        else:
            raise InputError(f"joint {jn}: {kind} joints are not supported yet (Static, Crank, Revolute, Fixed)",
                             file=source)
    if motor is None:
        raise InputError("no Crank joint: nothing drives the linkage", file=source)
    return {"name": name or str(data.get("name") or "pylinkage"), "units": units,
            "description": f"imported from pylinkage ({source})", "joints": joints, "ground": ground,
            "links": links, "motor": motor, "tracks": tracks}


def _angle_deg(xy: list[float], entries: list[dict[str, Any]], pivot: str) -> float:
    """Direction from the crank's pivot to its saved position, degrees."""
    p = next((e for e in entries if e["name"] == pivot), None)
    if p is None:
        raise InputError(f"crank pivot {pivot!r} is not a joint")
    return math.degrees(math.atan2(xy[1] - float(p.get("y") or 0.0), xy[0] - float(p.get("x") or 0.0)))
