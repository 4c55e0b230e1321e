"""pylinkage's JSON files → a linkage document (``specs/linkage.md``).

Three forms, told apart by their keys:

* **mechanism** (pylinkage ≥ 1.0, ``mechanism_to_json``): ``joints`` (``id``, ``type`` ground,
  revolute, prismatic or tracker, ``position``) and ``links`` (``id``, ``type`` ground, driver,
  arc_driver or link, ``joints``). As in pylinkage, the positions define every length; the crank
  starts at its ``initial_angle`` and turns by ``angular_velocity`` (radians per step; its sign
  gives the direction, 2π/|ω| steps a turn becomes ``samples``). A file saved at another crank
  angle is re-posed: the crank pin at ``initial_angle``, each other joint on the branch nearest
  where it was saved. A prismatic joint slides on the frame line through ``line_point`` along
  ``axis``; a tracker (a point at ``distance`` and ``angle`` from ``ref_joint1``, measured from
  the direction to ``ref_joint2``) becomes a track on the link carrying both references. An
  ``arc_driver`` sweeps once from ``arc_start`` to ``arc_end`` (``motor.range_deg``; pylinkage's
  forward half-cycle, sample k the pose after its k-th step).
* **graph** (pylinkage ≥ 1.0, ``graph_to_json`` of a hypergraph or an Assur graph): ``nodes``
  (``id``, ``role`` GROUND, DRIVER or DRIVEN, ``joint_type``), ``edges`` (``source``, ``target``,
  optional ``body_id``: edges of one body are one rigid link) and ``hyperedges`` (rigid links of
  several joints). It holds topology only: the dimensions come in a second file, pylinkage's
  ``Dimensions.to_dict()`` saved as JSON (``node_positions``, ``driver_angles``,
  ``edge_distances``). The positions define the lengths, as in pylinkage's ``to_mechanism``; a
  distance that disagrees with them is refused. A prismatic node slides on the line through the
  two ground nodes of its three-node hyperedge (how pylinkage writes a slider). A PRISMATIC DRIVER node
  is a ``LinearActuator``: its edge to the anchor holds the stroke, ``driver_angles`` its speed
  (``angular_velocity``, > 0) and direction (``initial_angle``); it becomes a linear input over the whole
  stroke (``motor: {slider, stroke}``, extension 0 … stroke, one sample per step), the anchor dropped.
* **0.x** (``Linkage`` saved with ``save_to_json``): ``Static`` (a frame point), ``Crank`` (turns
  about ``joint0`` at ``distance``; the sign of ``angle``, its step, gives the direction),
  ``Revolute`` (at ``distance0`` from ``joint0`` and ``distance1`` from ``joint1``; its x, y pick
  the branch), ``Fixed`` (rigid with ``joint0`` and ``joint1``: at ``distance`` from joint0, ``angle`` from
  the direction joint0 → joint1, as pylinkage places it; its own x, y are not read). Links are given by length, so
  lengths are pylinkage's to the last bit and the rest pose is assembled on the branch nearest
  the saved positions. ``Prismatic`` (or ``Linear``, its older name): at ``revolute_radius`` from ``joint0`` on the
  line through ``joint1`` and ``joint2``, the crossing nearest its x, y; a slider on the frame when both are
  ``Static``, else on the link carrying both (a line through two joints on no common link is refused).
"""

from __future__ import annotations

import math
from typing import Any

from linkedit.errors import InputError
from linkedit.interop.document import JsonFile, default_tracks
from linkedit.interop.pylinkage_legacy import legacy

#: How far (radians) a saved crank may sit from its ``initial_angle`` and still count as there.
_SAME_ANGLE = 1e-9
#: Relative disagreement allowed between a graph's distances and its positions (and a slider off its line).
_AGREE = 1e-9
#: Largest coordinate or length given to linkedit's assembly from lengths (squares of larger ones overflow).
_REACH = 1e150


def to_document(text: str, *, source: str, units: str, name: str | None = None,
                dimensions: tuple[str, str] | None = None) -> dict[str, Any]:
    """A linkage document from pylinkage JSON text; ``dimensions``: (text, source) of a graph's Dimensions."""
    file = JsonFile(text, source)
    data = file.data
    if not isinstance(data, dict):
        raise file.error(data, "not a pylinkage file (a JSON object with 'joints', or 'nodes' and 'edges')")
    if "nodes" in data or "edges" in data:
        if dimensions is None:
            raise file.error(data, "a pylinkage graph holds topology only: give its Dimensions (Dimensions.to_dict() "
                                   "saved as JSON) with --dimensions FILE")
        doc = _graph(file, JsonFile(*dimensions))
    elif dimensions is not None:
        raise InputError("--dimensions goes with a pylinkage graph (nodes and edges), not this file", field="--dimensions")
    elif "links" in data:
        doc = _mechanism(file)
    elif "joints" in data:
        doc = legacy(file, reach=_REACH)
    else:
        raise file.error(data, "not a pylinkage file (no 'joints', 'links' or 'nodes')")
    title = data.get("name") if isinstance(data.get("name"), str) and data.get("name") else "pylinkage"
    return {"name": name or title, "units": units, "description": f"imported from pylinkage ({source})", **doc}


# --- pylinkage ≥ 1.0: Mechanism ---------------------------------------------------------------

def _mechanism(file: JsonFile) -> dict[str, Any]:
    data = file.data
    joints: dict[str, dict[str, Any]] = {}
    for n, j in enumerate(file.objects(data, "joints")):
        jid = file.name(j, "id", ("joints", n))
        if jid in joints:
            raise file.error(j, f"joint {jid!r} given twice", ("joints", n, "id"))
        kind = file.name(j, "type", ("joints", n), "revolute")
        if kind not in ("ground", "revolute", "prismatic", "tracker"):
            raise file.error(j, f"joint type {kind!r}: ground, revolute, prismatic or tracker", ("joints", n, "type"))
        joints[jid] = {"type": kind, "xy": file.point(j, "position", ("joints", n)), "obj": j, "at": ("joints", n)}
    links: dict[str, tuple[str, list[str], dict[str, Any]]] = {}
    for n, lk in enumerate(file.objects(data, "links")):
        lid = file.name(lk, "id", ("links", n))
        kind = file.name(lk, "type", ("links", n), "link")
        if kind not in ("ground", "driver", "arc_driver", "link"):
            raise file.error(lk, f"link type {kind!r}: ground, driver, arc_driver or link", ("links", n, "type"))
        members = file.get(lk, "joints", ("links", n), [])
        if not isinstance(members, list) or not all(isinstance(m, str) for m in members):
            raise file.error(lk, "expected a list of joint ids", ("links", n, "joints"))
        for m in members:
            if m not in joints:
                raise file.error(lk, f"unknown joint {m!r}", ("links", n, "joints"))
        if lid in links:
            raise file.error(lk, f"link {lid!r} given twice", ("links", n, "id"))
        links[lid] = (kind, members, lk)
    drivers = [lid for lid, (kind, _, _) in links.items() if kind in ("driver", "arc_driver")]
    if len(drivers) != 1:
        raise file.error(data, f"{len(drivers)} driver links: linkedit drives one motor", ("links",))
    ground = {jid for jid, j in joints.items() if j["type"] == "ground"}
    ground |= {m for kind, members, _ in links.values() if kind == "ground" for m in members}
    crank, motor, initial, samples = _driver(file, list(links).index(drivers[0]), links[drivers[0]], ground)
    ground.add(motor["pivot"])
    for n, (lid, (kind, members, lk)) in enumerate(links.items()):
        if kind == "link" and len(members) < 2:
            raise file.error(lk, f"link {lid!r} carries {len(members)} joint: a link joins 2 or more", ("links", n))
    bodies = {lid: members for lid, (kind, members, _) in links.items() if kind != "ground" and not set(members) <= ground}
    xy = {jid: j["xy"] for jid, j in joints.items()}
    size = _size(xy.values())
    sliders: dict[str, dict[str, Any]] = {}
    tracks: dict[str, dict[str, Any]] = {}
    for jid, j in joints.items():
        if j["type"] == "prismatic":
            if jid in ground:
                raise file.error(j["obj"], f"joint {jid!r} is prismatic and fixed to the frame", j["at"])
            sliders[jid] = _slide_line(file, j["obj"], j["at"], jid, xy[jid], size)
        elif j["type"] == "tracker":
            tracks[jid] = _tracker(file, j["obj"], j["at"], jid, xy, bodies, ground)
            del xy[jid]
    doc: dict[str, Any] = {"ground": [jid for jid in xy if jid in ground], "motor": motor}
    saved = math.atan2(xy[crank][1] - xy[motor["pivot"]][1], xy[crank][0] - xy[motor["pivot"]][0])
    if abs(math.remainder(saved - initial, math.tau)) <= _SAME_ANGLE:
        doc["joints"], doc["links"] = xy, bodies
    else:  # saved at another crank angle: pose it at initial_angle, near where it was saved
        if sliders or tracks:
            raise file.error(data, "saved at a crank angle other than its initial_angle: linkedit re-poses revolute "
                                   "joints only; save it at its initial angle (mechanism.reset())")
        if max(abs(c) for p in xy.values() for c in p) > _REACH:
            raise file.error(data, f"saved away from its initial_angle, with coordinates beyond {_REACH:g}: too large "
                                   "to re-pose from lengths")
        doc["joints"], doc["links"] = _reposed(xy, bodies, ground, crank, motor["pivot"], math.degrees(initial))
    if sliders:
        doc["sliders"] = sliders
    doc["tracks"] = tracks or default_tracks(list(xy), doc["ground"], bodies)
    if samples:
        doc["samples"] = samples
    return doc


def _driver(file: JsonFile, n: int, link: tuple[str, list[str], dict[str, Any]],
            ground: set[str]) -> tuple[str, dict[str, Any], float, int | None]:
    """The crank pin, the motor, the initial angle (radians) and the steps of a turn of a driver link."""
    kind, members, lk = link
    lid, at = lk["id"], ("links", n)
    if len(members) != 2:
        raise file.error(lk, f"driver {lid!r} carries {len(members)} joints: a crank joins its pivot and one pin", at)
    pivot = file.get(lk, "motor_joint", at, None)
    if pivot is None:
        pivot = next((m for m in members if m in ground), members[0])
    if pivot not in members:
        raise file.error(lk, f"motor_joint {pivot!r} is not one of the driver's joints", (*at, "motor_joint"))
    crank = members[1] if members[0] == pivot else members[0]
    if crank in ground:
        raise file.error(lk, f"the driver's pin {crank!r} is fixed to the frame", at)
    omega = file.number(lk, "angular_velocity", at, math.tau / 360)
    if omega == 0:
        raise file.error(lk, "angular_velocity is 0: the crank does not turn", (*at, "angular_velocity"))
    motor: dict[str, Any] = {"joint": crank, "pivot": pivot, "direction": "cw" if omega < 0 else "ccw"}
    if kind == "arc_driver":
        start = file.number(lk, "arc_start", at, 0.0)
        end = file.number(lk, "arc_end", at, 3.14159)  # pylinkage's default
        initial = file.number(lk, "initial_angle", at, start) if lk.get("initial_angle") is not None else start
        if not start < end <= start + math.tau:
            raise file.error(lk, f"arc_start {start} .. arc_end {end}: not a sweep of at most one turn", at)
        motor.update(direction="ccw", range_deg=[math.degrees(start - initial), math.degrees(end - initial)])
        steps = _steps(omega, end - start)
        return crank, motor, initial, steps + 1 if steps else None  # a sweep samples both its ends
    return crank, motor, file.number(lk, "initial_angle", at, 0.0), _steps(omega)


def _steps(omega: float, sweep: float = math.tau) -> int | None:
    """The whole number of steps of ``omega`` radians in ``sweep`` radians, if it is one."""
    count = sweep / abs(omega)
    return round(count) if 1 <= round(count) <= 1_000_000 and abs(count - round(count)) <= 1e-9 * count else None


def _slide_line(file: JsonFile, obj: dict[str, Any], at: tuple[str | int, ...], jid: str, xy: list[float],
                size: float) -> dict[str, Any]:
    """The slider of a prismatic joint: the frame line through ``line_point`` along ``axis``, through the joint."""
    axis = file.point(obj, "axis", at) if "axis" in obj else [1.0, 0.0]
    through = file.point(obj, "line_point", at) if "line_point" in obj else [0.0, 0.0]
    length = math.hypot(*axis)
    if not length > 0:
        raise file.error(obj, "the axis has no direction", (*at, "axis"))
    off = abs((xy[0] - through[0]) * axis[1] - (xy[1] - through[1]) * axis[0]) / length
    if off > _AGREE * size:
        raise file.error(obj, f"joint {jid!r} is {off:.6g} off its slide line", (*at, "position"))
    return {"joint": jid, "guide": "ground", "angle_deg": math.degrees(math.atan2(axis[1], axis[0]))}


def _tracker(file: JsonFile, obj: dict[str, Any], at: tuple[str | int, ...], jid: str, xy: dict[str, list[float]],
             bodies: dict[str, list[str]], ground: set[str]) -> dict[str, Any]:
    """A tracker as a track on the link that carries both its reference joints, at its rest position."""
    refs = [file.name(obj, key, at) for key in ("ref_joint1_id", "ref_joint2_id")]
    for ref in refs:
        if ref not in xy or ref == jid:
            raise file.error(obj, f"tracker {jid!r}: reference {ref!r} is not a joint", at)
    if any(jid in members for members in bodies.values()):
        raise file.error(obj, f"tracker {jid!r} is on a link: a tracker only observes", at)
    body = next((lid for lid, members in bodies.items() if set(refs) <= set(members)), None)
    if body is None:
        raise file.error(obj, f"tracker {jid!r}: no link carries both {refs[0]!r} and {refs[1]!r}", at)
    distance, angle = file.number(obj, "distance", at, 0.0), file.number(obj, "angle", at, 0.0)
    (x1, y1), (x2, y2) = xy[refs[0]], xy[refs[1]]
    direction = math.atan2(y2 - y1, x2 - x1) + angle
    return {"link": body, "at": [x1 + distance * math.cos(direction), y1 + distance * math.sin(direction)]}


def _reposed(xy: dict[str, list[float]], bodies: dict[str, list[str]], ground: set[str], crank: str, pivot: str,
             rest_deg: float) -> tuple[dict[str, Any], dict[str, Any]]:
    """Joints and links given by length: the crank pin at ``rest_deg`` from the pivot, the rest near their positions."""
    joints: dict[str, Any] = {}
    for jid, p in xy.items():
        joints[jid] = p if jid in ground else {"from": [pivot], "angle_deg": rest_deg} if jid == crank else {"near": p}
    links: dict[str, Any] = {}
    for lid, members in bodies.items():
        lengths = [math.dist(xy[a], xy[b]) for i, a in enumerate(members) for b in members[i + 1:]]
        links[lid] = {"joints": members, "length": lengths[0]} if len(members) == 2 else {"joints": members, "lengths": lengths}
    return joints, links


def _size(points: Any) -> float:
    pts = list(points)
    return max((math.dist(p, q) for p in pts[:1] for q in pts), default=0.0) or 1.0


# --- pylinkage ≥ 1.0: graph (hypergraph or Assur graph) + Dimensions ------------------------------

def _graph(file: JsonFile, dims: JsonFile) -> dict[str, Any]:
    data, sizes = file.data, dims.data
    if not isinstance(sizes, dict):
        raise dims.error(sizes, "not pylinkage Dimensions (a JSON object with node_positions)")
    positions = dims.mapping(sizes, "node_positions")
    nodes: dict[str, dict[str, Any]] = {}
    for n, node in enumerate(file.objects(data, "nodes")):
        nid = file.name(node, "id", ("nodes", n))
        role = file.name(node, "role", ("nodes", n), "DRIVEN")
        kind = file.name(node, "joint_type", ("nodes", n), "REVOLUTE")
        if role not in ("GROUND", "DRIVER", "DRIVEN") or kind not in ("REVOLUTE", "PRISMATIC", "GROUND", "TRACKER"):
            raise file.error(node, f"node {nid!r}: role GROUND, DRIVER or DRIVEN and joint_type REVOLUTE, PRISMATIC, "
                                   f"GROUND or TRACKER, got {role!r}, {kind!r}", ("nodes", n))
        if nid in nodes:
            raise file.error(node, f"node {nid!r} given twice", ("nodes", n, "id"))
        if nid not in positions:
            raise dims.error(positions, f"node {nid!r} has no position", ("node_positions",))
        nodes[nid] = {"role": role, "kind": kind, "xy": dims.point(positions, nid, ("node_positions",)), "obj": node}
    ground = {nid for nid, v in nodes.items() if v["role"] == "GROUND" or v["kind"] == "GROUND"}
    xy = {nid: v["xy"] for nid, v in nodes.items()}
    size = _size(xy.values())
    distances = dims.mapping(sizes, "edge_distances", (), {})
    pushed = {nid for nid, v in nodes.items() if v["role"] == "DRIVER" and v["kind"] == "PRISMATIC"}  # linear actuators
    edges: list[tuple[str, str, str, Any]] = []  # id, source, target, body
    actuator: tuple[str, str] | None = None  # (edge, anchor) of a linear actuator: its distance is the stroke
    for n, e in enumerate(file.objects(data, "edges", (), [])):
        ends = [file.name(e, key, ("edges", n)) for key in ("source", "target")]
        eid = file.name(e, "id", ("edges", n))
        for end in ends:
            if end not in nodes:
                raise file.error(e, f"edge {eid!r}: unknown node {end!r}", ("edges", n))
        if set(ends) & pushed and set(ends) - pushed <= ground and actuator is None:
            actuator = (eid, ends[1] if ends[0] in pushed else ends[0])
            continue
        if eid in distances:
            _agree(dims, distances, eid, math.dist(xy[ends[0]], xy[ends[1]]), size, ("edge_distances", eid))
        edges.append((eid, ends[0], ends[1], e.get("body_id")))
    bodies: dict[str, list[str]] = {}
    for eid, a, b, body in edges:
        if not {a, b} <= ground:
            members = bodies.setdefault(str(body) if body is not None else eid, [])
            members.extend(m for m in (a, b) if m not in members)
    sliders: dict[str, dict[str, Any]] = {}
    rails: set[str] = set()
    for n, h in enumerate(file.objects(data, "hyperedges", (), [])):
        hid = file.name(h, "id", ("hyperedges", n))
        members = file.get(h, "nodes", ("hyperedges", n))
        if not isinstance(members, list) or not all(isinstance(m, str) and m in nodes for m in members):
            raise file.error(h, f"hyperedge {hid!r}: expected a list of node ids", ("hyperedges", n, "nodes"))
        moving = [m for m in members if nodes[m]["kind"] == "PRISMATIC" and m not in ground]
        if moving and len(members) == 3 and len(set(members) & ground) == 2:  # a slide line through two frame nodes
            line = [m for m in members if m in ground]
            (x1, y1), (x2, y2) = xy[line[0]], xy[line[1]]
            sliders[moving[0]] = _slide_line(file, {"axis": [x2 - x1, y2 - y1], "line_point": [x1, y1]},
                                             ("hyperedges", n), moving[0], xy[moving[0]], size)
            rails.update(line)
        elif not set(members) <= ground:
            bodies[hid] = list(dict.fromkeys(members))
    for nid, v in nodes.items():
        if v["kind"] == "PRISMATIC" and nid not in sliders and nid not in pushed:
            raise file.error(v["obj"], f"prismatic node {nid!r}: its slide line is not in the file (pylinkage writes it as "
                                       "a hyperedge with two ground nodes; an Assur graph keeps no line)")
    drivers = [nid for nid, v in nodes.items() if v["role"] == "DRIVER"]
    if len(drivers) != 1:
        raise file.error(data, f"{len(drivers)} DRIVER nodes: linkedit drives one motor", ("nodes",))
    driver = drivers[0]
    angles = dims.mapping(sizes, "driver_angles", (), {})
    if driver in pushed:
        if actuator is None:
            raise file.error(nodes[driver]["obj"], f"linear actuator {driver!r} has no edge to a GROUND node (its anchor)")
        sliders[driver], motor, steps = _actuator(dims, distances, angles, driver, actuator, xy, size)
        rails.add(actuator[1])  # the anchor only places the line
    used = {m for members in bodies.values() for m in members}
    xy = {nid: p for nid, p in xy.items() if nid in used or nid not in rails}
    if driver in pushed:
        doc: dict[str, Any] = {"joints": xy, "ground": [nid for nid in xy if nid in ground], "links": bodies,
                               "motor": motor, "sliders": sliders}
        doc["tracks"] = default_tracks(list(xy), doc["ground"], bodies)
        if steps:
            doc["samples"] = steps
        return doc
    pivot = next((a if b == driver else b for _, a, b, _ in edges if driver in (a, b) and ({a, b} - {driver}) <= ground), None)
    if pivot is None:
        raise file.error(nodes[driver]["obj"], f"DRIVER node {driver!r} has no edge to a GROUND node (its crank)")
    omega = math.tau / 360
    if driver in angles:
        omega = dims.number(dims.mapping(angles, driver, ("driver_angles",)), "angular_velocity", ("driver_angles", driver))
    if omega == 0:
        raise dims.error(angles, "angular_velocity is 0: the crank does not turn", ("driver_angles", driver))
    doc = {"joints": xy, "ground": [nid for nid in xy if nid in ground], "links": bodies,
                           "motor": {"joint": driver, "pivot": pivot, "direction": "cw" if omega < 0 else "ccw"}}
    if sliders:
        doc["sliders"] = sliders
    doc["tracks"] = default_tracks(list(xy), doc["ground"], bodies)
    if _steps(omega):
        doc["samples"] = _steps(omega)
    return doc


def _actuator(dims: JsonFile, distances: dict[str, Any], angles: dict[str, Any], driver: str, edge: tuple[str, str],
              xy: dict[str, list[float]], size: float) -> tuple[dict[str, Any], dict[str, Any], int | None]:
    """A pylinkage ``LinearActuator`` (a DRIVER node of joint_type PRISMATIC): its slider on the frame line from
    its anchor at ``initial_angle`` (radians), the linear input over its whole stroke (the edge's distance, from
    extension 0 to the stroke, as displacements from the saved extension) and its steps (stroke / speed, + 1)."""
    eid, anchor = edge
    if eid not in distances:
        raise dims.error(distances, f"the stroke of linear actuator {driver!r} (edge {eid!r}) is missing", ("edge_distances",))
    stroke = dims.number(distances, eid, ("edge_distances",))
    table = dims.mapping(angles, driver, ("driver_angles",)) if driver in angles else {}
    angle = dims.number(table, "initial_angle", ("driver_angles", driver), 0.0) if "initial_angle" in table else 0.0
    speed = dims.number(table, "angular_velocity", ("driver_angles", driver)) if table else 0.1  # pylinkage's default
    if not speed > 0:  # pylinkage's speed is a magnitude: at 0 it stands still, below 0 it jitters at one end
        raise dims.error(table, f"linear actuator {driver!r}: speed {speed:g} " + (
            "never moves" if speed == 0 else "is negative (a speed, units per step; initial_angle gives the direction)"),
            ("driver_angles", driver, "angular_velocity"))
    slider = _slide_line(dims, {"axis": [math.cos(angle), math.sin(angle)], "line_point": xy[anchor]},
                         ("node_positions", driver), driver, xy[driver], size)
    extension = (xy[driver][0] - xy[anchor][0]) * math.cos(angle) + (xy[driver][1] - xy[anchor][1]) * math.sin(angle)
    if not (stroke > 0 and -_AGREE * size <= extension <= stroke + _AGREE * size):
        raise dims.error(distances, f"linear actuator {driver!r}: stroke {stroke!r} must be positive and hold its "
                                    f"extension {extension!r}", ("edge_distances", eid))
    steps = _steps(speed, stroke)
    return slider, {"slider": driver, "stroke": [-extension, stroke - extension]}, steps + 1 if steps else None


def _agree(dims: JsonFile, table: dict[str, Any], key: str, actual: float, size: float,
           field: tuple[str | int, ...]) -> None:
    given = dims.number(table, key, field[:-1])
    if abs(given - actual) > _AGREE * size:
        raise dims.error(table, f"{given!r} but the positions put them {actual!r} apart", field)
