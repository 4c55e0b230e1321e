"""Names that reach the file system or a CAD file: layer names DXF would take as one, file names
as long as the file system allows (issue 26 §7)."""

from __future__ import annotations

import csv
import os
import subprocess
import sys

import pytest

from tests.conftest import EXAMPLES

#: a crank-rocker whose link and track names collide in DXF (case, forbidden characters)
COLLIDING = """\
name: colliding
units: mm
joints:
  O: [0, 0]
  D: [75, 0]
  A: [25, 0]
  B: [63, 58.787753826796276]
  "'=B": [0, 40]
ground: [O, D, "'=B"]
links:
  crank: [O, A]
  coupler: [A, B]
  COUPLER: [D, B]
motor: {joint: A, pivot: O}
tracks:
  c_x: {joint: B}
  "c;x": {joint: A}
  "=B": {joint: B}
"""


def test_links_and_tracks_whose_layer_names_collide_get_numbered_layers(run_cli, tmp_path):
    ezdxf = pytest.importorskip("ezdxf")
    spec, out = tmp_path / "c.yaml", tmp_path / "c.dxf"
    spec.write_text(COLLIDING)
    r = run_cli("simulate", spec, "-o", out, "-n", "12", "--json")
    assert r.exit_code == 0, r.output
    doc = ezdxf.readfile(out)
    layers = [layer.dxf.name for layer in doc.layers]
    assert {"LINK-crank", "LINK-coupler", "LINK-COUPLER#2", "TRACK-c_x", "TRACK-c_x#2", "TRACK-_B"} <= set(layers)
    assert len({n.lower() for n in layers}) == len(layers)
    msp = doc.modelspace()
    # each link keeps its own layer: the rocker D–B on the numbered one, the coupler A–B on the first
    rocker = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer == "LINK-COUPLER#2"]
    assert [tuple(p[:2]) for p in rocker[0].get_points()] == [(75.0, 0.0), (63.0, 58.787753826796276)]
    tracks = {e.dxf.layer: len(list(e.get_points())) for e in msp.query("LWPOLYLINE") if e.dxf.layer.startswith("TRACK")}
    assert tracks == {"TRACK-c_x": 12, "TRACK-c_x#2": 12, "TRACK-_B": 12}
    # the CSV of the same spec: a column per name, none repeated ('=B the joint, =B the track)
    table = tmp_path / "c.csv"
    assert run_cli("simulate", spec, "-o", table, "-n", "3").exit_code == 0
    header = next(r for r in csv.reader(table.read_text().splitlines()) if not r[0].startswith("#"))
    assert len(header) == len(set(header)) == 2 + 4 * 8  # t, angle; 5 joints and 3 tracks


def test_an_output_name_of_255_bytes_is_written(run_cli, tmp_path):
    name = "é" * 125 + "rr.h5"  # 250 + 5 bytes in UTF-8: the longest name the file system takes
    assert len(name.encode()) == 255
    r = run_cli("simulate", EXAMPLES / "crank-rocker.yaml", "-n", "12", "-o", tmp_path / name)
    assert r.exit_code == 0, r.output
    assert os.listdir(tmp_path) == [name]
    assert run_cli("plot", tmp_path / name, "-o", tmp_path / "p.svg").exit_code == 0  # it reopens


def test_a_stale_part_file_of_a_long_name_is_removed(tmp_path):
    from linkedit.io.atomic import _tag, write_text

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True).stdout.strip()
    name = "b" * 240 + ".h5"
    stale = tmp_path / f".{_tag(name)}.{dead}.abc123.part"
    other = tmp_path / f".{_tag(name)}.{dead}.x.{dead}.abc123.part"  # a temporary file of another target
    stale.write_text("half")
    other.write_text("half")
    write_text(tmp_path / name, "x")
    assert sorted(os.listdir(tmp_path)) == sorted([name, other.name])
