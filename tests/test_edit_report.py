"""What an edit's report says about the edited linkage: the transmission angle as ``validate``
checks it, the smallest d_s as the final check (4× the samples) measures it, and a stall blamed
on the barrier only where the barrier acts."""

from __future__ import annotations

import json

import numpy as np

from linkedit.planar import catalog
from linkedit.spec.linkage import LinkageSpec
from tests.test_edit_trust import EDITS, Edited, linkage_file, term, write


def test_an_edit_that_pushes_a_transmission_angle_out_of_band_warns_as_validate_does(run_cli, tmp_path):
    cr = catalog.crank_rocker()  # transmission 44°…100° at B
    p = linkage_file(tmp_path, cr)
    e = Edited(run_cli, tmp_path, p, write(tmp_path, "s.yaml", {"samples": 60, "lock": ["O", "D"], "operations": [
        {"displace": {"joint": "B", "to": [110, 20]}}]}))
    assert e.result.exit_code == 0, e.output
    # the worst angle at B of the edited linkage, from its re-simulated joints (angle A-B-D)
    joints = e.resimulated(run_cli, 360)["joints"]
    names = list(cr.joints)
    a, b, d = (joints[:, names.index(n)] for n in "ABD")
    u, w = a - b, d - b
    angle = np.degrees(np.arccos(np.sum(u * w, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)))
    assert angle.min() < 20.0
    validate = json.loads(run_cli("validate", e.yaml, "--json").stdout)["result"][0]["warnings"]
    (mine,) = [w for w in json.loads(e.output)["warnings"] if "transmission" in w]
    assert mine.startswith(validate[0]) and "44.4° before the edit" in mine
    assert f"{angle.min():.1f}°" in mine


def test_the_reported_min_ds_is_the_final_checks(run_cli, tmp_path):
    jansen = catalog.jansen_leg()
    p = linkage_file(tmp_path, jansen)
    e = Edited(run_cli, tmp_path, p, write(tmp_path, "s.yaml", {"samples": 24, "lock": ["O"], "operations": [
        {"preserve": ["foot"], "displace": {"joint": "C", "to": [-20, 36]}}]}))
    assert e.result.exit_code == 0, e.output
    sim = run_cli("simulate", e.yaml, "-o", tmp_path / "fine.h5", "--samples", "96", "--json")
    fine = json.loads(sim.stdout)["result"][0]["min_singularity"]["value"]
    reported = term(e.report["operations"][0], "min d_s")
    assert abs(reported["after"] - fine) <= 1e-9
    before = json.loads(run_cli("simulate", p, "-o", tmp_path / "b.h5", "--samples", "96", "--json").stdout)
    assert abs(reported["before"] - before["result"][0]["min_singularity"]["value"]) <= 1e-9


def test_a_stall_names_the_barrier_only_where_it_acts(run_cli, tmp_path):
    # Hoekens retargeted with its pivots locked: the goal cannot be reached, the solver creeps
    # on with the barrier far away (every d_s above ε)
    p = linkage_file(tmp_path, catalog.hoekens())
    s = write(tmp_path, "s.yaml", {"samples": 120, "lock": ["O"], "weights": {"regularization": 0}, "operations": [
        {"retarget": {"track": "tracer", "scale": [1.3, 1.3]}}]})
    e = Edited(run_cli, tmp_path, p, s, "--best-effort")
    op = e.report["operations"][0]
    assert op["stalled"], e.output
    assert term(op, "energy singularity")["after"] == 0.0
    status = run_cli("edit", p, s, "-o", tmp_path / "o2", "--best-effort").output.splitlines()[0]
    assert "stalled" in status and "barrier" not in status



def test_a_stall_at_the_barrier_names_it(run_cli, tmp_path):
    e = Edited(run_cli, tmp_path, None, EDITS / "jansen-toggle.yaml", "--best-effort")
    op = e.report["operations"][0]
    assert op["stalled"] and term(op, "energy singularity")["after"] > 0.0
    human = run_cli("edit", EDITS / "jansen-toggle.yaml", "-o", tmp_path / "o2", "--best-effort").output
    assert "stalled: slow progress, along the barrier's edge" in human
    assert "warning: pull D towards the toggle: goal not met: displace D" in human


def test_a_near_toggle_warning_of_a_linear_input_says_the_stroke(run_cli, tmp_path):
    """A cylinder-driven crank ending 0.2 mm short of its stretched toggle (|OB| ≤ r + l = 90 mm:
    the stroke's end is nearest, d_s grows as B comes back): the warning names the stroke there,
    in mm; it said "motor angle 0.2°"."""
    data = catalog.slider_crank().model_dump()
    data["motor"] = {"slider": "piston", "stroke": [-25.0, 0.2]}
    p = linkage_file(tmp_path, LinkageSpec.model_validate(data))
    e = Edited(run_cli, tmp_path, p, write(tmp_path, "s.yaml", {"samples": 40, "lock": ["O"], "operations": [
        {"displace": {"joint": "C", "to": [51.0, 26.7]}}]}))
    assert e.result.exit_code == 0, e.output
    (near,) = [w for w in json.loads(e.output)["warnings"] if "toggle" in w]
    assert "of its toggle position at stroke 0.2 mm (below" in near, near


def test_a_follow_polyline_is_written_as_its_own_points_beside_the_sampled_targets(run_cli, tmp_path):
    # a retarget's target has one point per script sample (16), a follow curve (timing: false)
    # the 3 points given: written on the retarget's 16-sample axis it read back as 16 rows, 13 of
    # them (0, 0) that nobody gave
    import xarray as xr

    path = EDITS.parent / "crank-rocker.yaml"
    given = [[60.0, 55.0], [66.0, 58.0], [70.0, 56.0]]
    e = Edited(run_cli, tmp_path, path, write(tmp_path, "s.yaml", {"samples": 16, "lock": ["O", "D"], "operations": [
        {"retarget": {"track": "coupler_point", "scale": [1.02, 1.0]},
         "follow": {"track": "rocker_tip", "curve": given, "closed": False}}]}), "--best-effort")
    assert e.result.exit_code == 0, e.output
    with xr.open_datatree(e.h5, engine="h5netcdf") as tree:
        targets = tree["operations/000/targets"]
        assert targets["follow rocker_tip"].values.tolist() == given
        assert targets["retarget coupler_point"].shape == (64, 2)  # at the final check's 4 × 16 samples


def _drawn(svg_path, cls: str) -> dict[str, str]:
    """data-name → SVG element tag (``polygon``: drawn closed, ``polyline``: open) of the picture's
    ``cls`` marks."""
    from tests.test_svg import NS, find, parse

    return {e.get("data-name"): e.tag.removeprefix(NS) for e in find(parse(svg_path.read_text()), cls)}


def test_the_edit_picture_of_a_partial_sweep_draws_its_curves_open(run_cli, tmp_path):
    # a 0…120° sweep traces arcs: closed, every curve of the picture got a chord from its end
    # back to its start that the linkage never travels (simulate draws the same linkage open)
    cr = catalog.crank_rocker()
    spec = cr.model_copy(update={"motor": cr.motor.model_copy(update={"range_deg": (0.0, 120.0)})})
    e = Edited(run_cli, tmp_path, linkage_file(tmp_path, spec), write(tmp_path, "s.yaml", {
        "samples": 60, "lock": ["O", "D"], "operations": [{"retarget": {"track": "coupler_point", "scale": [1.05, 1.0]}}]}),
        "--best-effort")
    svg = e.out / f"{e.stem}-edit.svg"
    assert e.result.exit_code == 0, e.output
    assert set(_drawn(svg, "track").values()) == {"polyline"}
    assert _drawn(svg, "target") == {"retarget coupler_point": "polyline"}
    assert set(_drawn(svg, "joint-path").values()) == {"polyline"}


def test_the_edit_picture_draws_an_open_follow_curve_open(run_cli, tmp_path):
    path = EDITS.parent / "crank-rocker.yaml"
    e = Edited(run_cli, tmp_path, path, write(tmp_path, "s.yaml", {"samples": 16, "lock": ["O", "D"], "operations": [
        {"retarget": {"track": "coupler_point", "scale": [1.02, 1.0]},
         "follow": {"track": "rocker_tip", "curve": [[60, 55], [66, 58], [70, 56]], "closed": False}}]}),
        "--best-effort")
    assert _drawn(e.out / "crank-rocker-edit.svg", "target") == {"retarget coupler_point": "polygon",
                                                                 "follow rocker_tip": "polyline"}
