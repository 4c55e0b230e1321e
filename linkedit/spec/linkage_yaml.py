"""Write a linkage spec back as YAML that loads and simulates unchanged."""

from __future__ import annotations

from linkedit.spec.linkage import JointTrack, LinkageSpec


def _num(v: float) -> str:
    return repr(float(v)) if v != int(v) or abs(v) >= 1e15 else str(int(v))


def dump_linkage(spec: LinkageSpec) -> str:
    """YAML text of ``spec``: name, units, description, joints, ground, links, motor, tracks.

    Coordinates are written with full double precision (``repr``), so reloading gives the same
    floats and the same link lengths.
    """
    out = [f"name: {spec.name}", f"units: {spec.units}"]
    if spec.description:
        out.append("description: |")
        out += [f"  {line}" for line in spec.description.strip().splitlines()]
    out.append("joints:")
    out += [f"  {n}: [{_num(x)}, {_num(y)}]" for n, (x, y) in spec.joints.items()]
    out.append(f"ground: [{', '.join(spec.ground)}]")
    out.append("links:")
    out += [f"  {n}: [{', '.join(m)}]" for n, m in spec.links.items()]
    motor = f"joint: {spec.motor.joint}, pivot: {spec.motor.pivot}"
    if spec.motor.direction != "ccw":
        motor += f", direction: {spec.motor.direction}"
    if spec.motor.range_deg is not None:
        motor += f", range_deg: [{_num(spec.motor.range_deg[0])}, {_num(spec.motor.range_deg[1])}]"
    out.append(f"motor: {{{motor}}}")
    if spec.tracks:
        out.append("tracks:")
        for n, t in spec.tracks.items():
            if isinstance(t, JointTrack):
                out.append(f"  {n}: {{joint: {t.joint}}}")
            else:
                out.append(f"  {n}: {{link: {t.link}, at: [{_num(t.at[0])}, {_num(t.at[1])}]}}")
    if spec.samples is not None:
        out.append(f"samples: {spec.samples}")
    return "\n".join(out) + "\n"
