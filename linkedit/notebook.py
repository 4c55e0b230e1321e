"""The notebook API: ``import linkedit as le; m = le.simulate("examples/jansen.yaml")``.

Functions take paths or already-loaded specs and return objects that show themselves in
Jupyter: a :class:`Motion` draws its motion plot (``_repr_svg_``) and converts to pandas
(``to_dataframe``) or xarray (``to_xarray``; both optional: ``pip install linkedit[notebook]``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from linkedit.edit.runner import EditResult
from linkedit.gcs.result import GcsResult
from linkedit.planar.simulate import Motion as _Motion
from linkedit.spec.edit_script import EditScript
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.mechanism3d import MechanismSpec

SpecLike = str | Path | LinkageSpec


class Motion(_Motion):
    """A simulated planar cycle (:class:`linkedit.planar.Motion`) that shows itself in a notebook.

    Arrays: ``t`` (T,), ``motor_angle`` (T,) rad (a linear input's stroke, spec units),
    ``positions``/``velocity``/``acceleration`` (T, J, 2) in the spec's units (derivatives per
    radian of motor angle, or per unit of stroke), ``tracks[name]``
    with (T, 2) arrays, diagnostics (T, R).
    """

    def _repr_svg_(self) -> str:
        from linkedit.io.planar_svg import draw_motion

        return draw_motion(None, self)

    def to_dataframe(self) -> Any:
        """A pandas DataFrame, one row per sample: the columns of the CSV result (``specs/planar-hdf5.md``)."""
        import pandas as pd

        from linkedit.io.planar_csv import columns

        names, table = columns(self)
        return pd.DataFrame(table, columns=names).set_index("t")

    def to_xarray(self) -> Any:
        """An xarray Dataset with dimensions ``t``, ``joint``, ``xy`` (and ``rule`` for diagnostics);
        the input is ``motor_angle`` (rad) or, for a linear input, ``stroke`` (the spec's units)."""
        import xarray as xr

        plan, u = self.plan, self.plan.spec.units
        per = u if plan.linear else "rad"  # a linear input's stroke, as the HDF5 result names it
        txy = ("t", "joint", "xy")
        data = {
            "stroke" if plan.linear else "motor_angle": (("t",), self.motor_angle, {"units": per}),
            "position": (txy, self.positions, {"units": u}),
            "velocity": (txy, self.velocity, {"units": f"{u}/{per}"}),
            "acceleration": (txy, self.acceleration, {"units": f"{u}/{per}**2"}),
            "singularity": (("t", "rule"), self.singularity, {"units": "1"}),
            "transmission_angle": (("t", "rule"), self.transmission, {"units": "rad"}),
            "assembled": (("t",), self.assembled, {}),
        }
        for name, tr in self.tracks.items():
            data[f"track_{name}"] = (("t", "xy"), tr.position, {"units": u})
        coords = {"t": self.t, "joint": plan.joint_names, "xy": ["x", "y"],
                  "rule": [plan.joint_names[k] for k in plan.table.joints[:, 2]]}
        return xr.Dataset({k: xr.Variable(*v) for k, v in data.items()}, coords=coords,
                          attrs={"name": plan.spec.name, "units": u})


class Edit(EditResult):
    """An edit's result (:class:`linkedit.edit.runner.EditResult`) that shows its overlay in a
    notebook: before faint, after solid, targets dashed (the picture ``linkedit edit`` writes)."""

    script: EditScript | None = None

    def _repr_svg_(self) -> str:
        from linkedit.io.edit_picture import edit_picture

        return edit_picture(None, self, self.script)


class Solution(GcsResult):
    """A solved 3D run (:class:`linkedit.gcs.result.GcsResult`) that shows its picture in a notebook."""

    def _repr_svg_(self) -> str:
        from linkedit.io.gcs_svg import draw

        return draw(None, self)


def _notebook(m: _Motion) -> Motion:
    return Motion(**{f.name: getattr(m, f.name) for f in dataclasses.fields(m)})


def load_spec(spec: SpecLike) -> LinkageSpec:
    """A linkage spec from a YAML path (links may be given by length), or the spec itself."""
    if isinstance(spec, LinkageSpec):
        return spec
    from linkedit.spec.yamlload import load_model

    return load_model(LinkageSpec, spec)


def simulate(spec: SpecLike, samples: int | None = None, *, partial: bool = False) -> Motion:
    """Simulate one motor cycle of a planar linkage (a YAML path or a :class:`LinkageSpec`).

    ``samples``: time samples per cycle (default: the spec's, else 360). Raises
    :class:`~linkedit.errors.MechanismError` where it locks up, unless ``partial``.
    """
    from linkedit.planar import simulate as run

    return _notebook(run(load_spec(spec), samples, partial=partial))


def load(path: str | Path) -> Motion:
    """Read a planar result (.h5 from ``linkedit simulate``) back into a :class:`Motion`.

    The spec stored in the file is compiled again; the arrays are the file's, sample for sample.
    """
    from linkedit.io.h5read import open_result
    from linkedit.planar.plan import compile_plan
    from linkedit.planar.simulate import Track
    from linkedit.spec.yamlload import validate

    with open_result(path, kind="planar") as f:
        import yaml

        spec = validate(LinkageSpec, yaml.safe_load(f.attr("spec")), file=f"{path}:/spec")
        plan = compile_plan(spec)
        t = f.array("t", shape=(None,))
        T, J, R = t.size, plan.n_joints, len(plan.table.joints)
        tracks = {n: Track(*(f.array(f"tracks/{n}/{q}", shape=(T, 2)) for q in ("position", "velocity", "acceleration")))
                  for n in f.names("tracks")}
        joints = [f.array(f"joints/{q}", shape=(T, J, 2)) for q in ("position", "velocity", "acceleration")]
        d = "diagnostics"
        steps = f"{d}/step_singularity"  # sliders' and numeric groups' d_s (T, X), written where the plan has steps
        step_ds = f.array(steps, shape=(T, len(plan.steps))) if plan.steps and f.has(steps) else None
        lockups = _lockups(f, d)
        return Motion(plan=plan, t=t, motor_angle=f.array("stroke" if plan.linear else "motor_angle", shape=(T,)),
                      positions=joints[0], velocity=joints[1], acceleration=joints[2], tracks=tracks,
                      singularity=f.array(f"{d}/singularity", shape=(T, R)),
                      orientation=f.array(f"{d}/orientation", shape=(T, R), kinds="iu"),
                      transmission=f.array(f"{d}/transmission_angle", shape=(T, R)),
                      assembled=f.array(f"{d}/assembled", shape=(T,), kinds="biu").astype(bool),
                      step_singularity=step_ds, lockups=lockups)


def _lockups(f: Any, where: str) -> list[Any]:
    """The lock-ups of a planar result's ``lockup_intervals`` attribute (format 3; none in a format 2 file)."""
    import json

    from linkedit.planar.diagnostics import LockUp

    text = f.attr("lockup_intervals", where, default="[]")
    try:
        return [LockUp.from_record(r) for r in json.loads(text)]
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        raise f.error(where, f"attribute 'lockup_intervals' is not the list of lock-ups it should be ({exc})") from None


def edit(spec: SpecLike, script: str | Path | Mapping[str, Any] | EditScript) -> Edit:
    """Apply an edit script (YAML path, dict or :class:`~linkedit.spec.edit_script.EditScript`) to a linkage.

    Returns the :class:`~linkedit.edit.runner.EditResult` (``edited`` spec, ``before``/``after``
    motions, ``goals_met``, ``warnings``: every goal not met is one, as ``linkedit edit
    --best-effort`` gives them). A name the linkage lacks is the CLI's
    :class:`~linkedit.errors.InputError`; a result that does not work raises ``EditFailed``.
    """
    from linkedit.edit.runner import run_script
    from linkedit.edit.script import read_script

    linkage = load_spec(spec)
    read = read_script(script)
    read.check(linkage)
    result = run_script(linkage, read.script)
    out = Edit(**{f.name: getattr(result, f.name) for f in dataclasses.fields(result)})
    out.script = read.script
    return out


def solve3d(spec: str | Path | MechanismSpec, *, steps: int | None = None, solver: str = "lm",
            partial: bool = False) -> Solution:
    """Solve a 3D mechanism (YAML path or :class:`~linkedit.spec.mechanism3d.MechanismSpec`) at every step.

    Returns a :class:`Solution` (a :class:`~linkedit.gcs.result.GcsResult` that draws itself).
    Raises :class:`~linkedit.errors.MechanismError` at the first step that does not converge, naming
    its constraints (as ``linkedit solve3d``), unless ``partial``: then every step is solved and
    ``diagnostics.status`` says which converged.
    """
    import yaml

    from linkedit.errors import InputError
    from linkedit.gcs import check_solved, solve_spec
    from linkedit.spec.yamlload import load_yaml, located, read_text, validate

    if isinstance(spec, MechanismSpec):  # the result records its spec: this one, as YAML
        model, file, lines = spec, "", None
        text = yaml.safe_dump(spec.model_dump(mode="json", exclude_defaults=True), sort_keys=False)
    else:
        file, text = str(spec), read_text(spec)
        data, lines = load_yaml(spec, text)
        model = validate(MechanismSpec, data, file=file, lines=lines)
    try:
        res = solve_spec(model, steps=steps, solver=solver, spec_text=text, stop_at_failure=not partial)
    except InputError as exc:  # found compiling the spec (half-turn keyframes): its field's line
        raise (exc if lines is None else located(exc, file, lines)) from None
    if not partial:
        check_solved(res)
    return Solution(**{f.name: getattr(res, f.name) for f in dataclasses.fields(res)})


def features(*curves: str, samples: int | None = None, harmonics: int | None = None) -> Any:
    """Features of motion curves (inputs as for ``linkedit features``: ``result.h5:track``, .csv, curve sets).

    ``samples`` in [8, 4096], ``harmonics`` in [1, 64] (else InputError). Returns a pandas DataFrame
    (one row per curve) if pandas is installed, else a list of dicts.
    """
    from linkedit.curves.compare import describe_curves
    from linkedit.curves.descriptors import DEFAULT_HARMONICS, DEFAULT_SAMPLES
    from linkedit.curves.sources import load_inputs

    loaded = load_inputs([str(c) for c in curves])
    desc = describe_curves(loaded, samples=DEFAULT_SAMPLES if samples is None else samples,
                           harmonics=DEFAULT_HARMONICS if harmonics is None else harmonics)
    rows = [{"name": c.name, "closed": bool(c.closed)} | {n: float(v) for n, v in zip(desc.names, desc.features[i])}
            for i, c in enumerate(loaded)]
    try:
        import pandas as pd
    except ModuleNotFoundError:
        return rows
    return pd.DataFrame(rows).set_index("name")
