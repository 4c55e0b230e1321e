"""The example catalog: exact geometry from the designers' lengths, and the YAML files it writes."""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest
import yaml

from linkedit.planar import catalog
from linkedit.planar.catalog.four_bars import CRANK_ROCKER
from linkedit.planar.catalog.legs import HOLY, KLANN
from linkedit.planar.graph import LinkageGraph, mobility
from linkedit.planar.ordering import order_joints
from linkedit.spec.linkage import JointTrack, LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage
from linkedit.spec.yamlload import load_model
from tests.conftest import EXAMPLES

ISSUE_JANSEN_REST = {"A": (15, 0), "C": (-24.0135, 31.2721), "D": (-26.9521, -45.5152), "E": (-74.7944, 8.1432),
                     "F": (-59.2315, -28.0529), "G": (-43.1601, -91.7569)}


def z(spec: LinkageSpec, joint: str) -> complex:
    return complex(*spec.joints[joint])


def dist(spec: LinkageSpec, a: str, b: str) -> float:
    return abs(z(spec, a) - z(spec, b))


def cross(spec: LinkageSpec, i: str, j: str, k: str) -> float:
    """Orientation of triangle (i, j, k): > 0 counter-clockwise."""
    return ((z(spec, j) - z(spec, i)).conjugate() * (z(spec, k) - z(spec, i))).imag


# ---------------------------------------------------------------- exact geometry

JANSEN_PAIRS = {("O", "A"): "m", ("A", "C"): "j", ("A", "D"): "k", ("B", "C"): "b", ("B", "D"): "c",
                ("B", "E"): "d", ("C", "E"): "e", ("E", "F"): "f", ("D", "F"): "g", ("F", "G"): "h",
                ("D", "G"): "i"}


def test_jansen_lengths_are_the_holy_numbers():
    spec = catalog.jansen_leg()
    for (a, b), letter in JANSEN_PAIRS.items():
        assert dist(spec, a, b) == pytest.approx(HOLY[letter], abs=1e-12), (a, b)
    assert spec.joints["O"] == (0.0, 0.0)
    assert spec.joints["B"] == (-HOLY["a"], -HOLY["l"])


def test_jansen_rest_pose_is_the_issues():
    spec = catalog.jansen_leg()
    for name, xy in ISSUE_JANSEN_REST.items():
        assert np.allclose(spec.joints[name], xy, atol=1e-3), name
    assert list(spec.joints) == ["O", "A", "B", "C", "D", "E", "F", "G"]
    assert spec.ground == ["O", "B"]
    assert sorted(map(sorted, spec.links.values())) == sorted(
        [["A", "O"], ["A", "C"], ["A", "D"], ["B", "C", "E"], ["B", "D"], ["E", "F"], ["D", "F", "G"]])
    assert spec.tracks["foot"] == JointTrack(joint="G")


@pytest.mark.parametrize("pairs", [1, 3, 10])
def test_strandbeest_structure_and_pin_phases(pairs):
    spec = catalog.strandbeest(pairs)
    assert len(spec.joints) == 3 + pairs + 10 * pairs
    assert spec.ground == ["O", "B_L", "B_R"]
    assert spec.joints["B_L"] == (-38.0, -7.8) and spec.joints["B_R"] == (38.0, -7.8)
    assert spec.links["crank"] == ["O", *(f"A_{p}" for p in range(pairs))]
    assert set(spec.tracks) == {f"foot_{p}_{s}" for p in range(pairs) for s in "LR"}
    for p in range(pairs):
        pin = z(spec, f"A_{p}")
        assert abs(pin) == pytest.approx(15.0, abs=1e-12)
        assert cmath.phase(pin / cmath.exp(2j * math.pi * p / pairs)) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("pairs", [3, 10])
def test_strandbeest_legs_are_jansen_legs_and_their_mirror_images(pairs):
    spec = catalog.strandbeest(pairs)
    jansen = catalog.jansen_leg()
    for p in range(pairs):
        for side, mirror in (("L", 1), ("R", -1)):
            def name(j: str) -> str:
                return {"O": "O", "A": f"A_{p}", "B": f"B_{side}"}.get(j, f"{j}_{p}_{side}")

            for (a, b), letter in JANSEN_PAIRS.items():
                assert dist(spec, name(a), name(b)) == pytest.approx(HOLY[letter], abs=1e-12)
            for tri in (("A", "B", "C"), ("A", "B", "D"), ("B", "C", "E"), ("E", "D", "F"), ("D", "F", "G")):
                assert np.sign(cross(spec, *map(name, tri))) == mirror * np.sign(cross(jansen, *tri)), (p, side, tri)
            members = {tuple(m) for n, m in spec.links.items() if n.endswith(f"_{p}_{side}")}
            assert members == {tuple(map(name, m)) for n, m in jansen.links.items() if n != "crank"}


def test_strandbeest_needs_a_pair():
    with pytest.raises(ValueError):
        catalog.strandbeest(0)


def test_klann_lengths():
    spec, k = catalog.klann_leg(), KLANN
    assert dist(spec, "A", "C") == pytest.approx(k["crank"], abs=1e-12)
    for pair in ("BH", "CF", "CH", "DE", "EF", "EG", "FG", "FH"):
        assert dist(spec, pair[0], pair[1]) == pytest.approx(k[pair], abs=1e-12), pair
    assert z(spec, "B") == k["B"] and z(spec, "D") == k["D"]


def test_hoekens_proportions_and_collinear_tracer():
    spec = catalog.hoekens()
    expected = {("O", "A"): 1.0, ("O", "D"): 2.0, ("A", "B"): 2.5, ("D", "B"): 2.5, ("A", "P"): 5.0, ("B", "P"): 2.5}
    for (a, b), length in expected.items():
        assert dist(spec, a, b) == pytest.approx(length, abs=1e-14), (a, b)
    assert abs(cross(spec, "A", "B", "P")) < 1e-14
    assert spec.links["coupler"] == ["A", "B", "P"]


def grashof(lengths: dict[str, float]) -> tuple[bool, bool]:
    """(crank is the shortest link, s + l < p + q)."""
    values = sorted(lengths.values())
    return lengths["crank"] == values[0], values[0] + values[-1] < values[1] + values[2]


def test_crank_rocker_is_grashof_with_the_crank_shortest():
    spec = catalog.crank_rocker()
    lengths = {"crank": dist(spec, "O", "A"), "coupler": dist(spec, "A", "B"), "rocker": dist(spec, "D", "B"),
               "ground": dist(spec, "O", "D")}
    assert lengths == pytest.approx(CRANK_ROCKER, abs=1e-12)
    assert grashof(lengths) == (True, True)


def ternary_links(spec: LinkageSpec) -> list[set[str]]:
    """The ternary bodies, the frame (its ground joints) included."""
    bodies = [set(m) for m in spec.links.values() if len(m) == 3] + [set(spec.ground)]
    assert all(len(b) == 3 for b in bodies)
    return bodies


def test_six_bar_chains():
    watt, stephenson = catalog.watt_six_bar(), catalog.stephenson_six_bar()
    for spec in (watt, stephenson):
        assert len(spec.links) + 1 == 6 and len(spec.joints) == 7
        assert mobility(LinkageGraph.from_spec(spec)).rank == 1
    a, b = ternary_links(watt)
    assert a & b  # Watt's chain: the ternary links share a joint
    a, b = ternary_links(stephenson)
    assert not a & b  # Stephenson's chain: they do not


def test_complex_loop_has_mobility_one_and_is_ordered_as_one_numeric_group():
    graph = LinkageGraph.from_spec(catalog.complex_loop())
    assert mobility(graph).rank == 1
    ordering = order_joints(graph)
    assert not ordering.undetermined and not ordering.rules  # no joint has two known neighbours
    assert [(st.kind, [graph.joint_names[k] for k in st.joints]) for st in ordering.steps] == \
        [("group", ["T1", "T2", "T3"])]


# ---------------------------------------------------------------- YAML


def builds() -> list[catalog.Example]:
    return list(catalog.EXAMPLES)


@pytest.mark.parametrize("example", builds(), ids=lambda e: e.file)
def test_dump_linkage_reads_back_the_same_spec(example):
    spec = example.build()
    for text in (dump_linkage(spec), example.text()):
        assert load_model(LinkageSpec, example.file, text) == spec


@pytest.mark.parametrize("example", builds(), ids=lambda e: e.file)
def test_example_file_agrees_with_the_catalog(example):
    """The files in examples/ never drift from the catalog: same topology, coordinates to 1e-9."""
    path = EXAMPLES / example.file
    spec, built = load_model(LinkageSpec, path), example.build()
    assert spec.model_dump(exclude={"joints", "tracks"}) == built.model_dump(exclude={"joints", "tracks"})
    assert list(spec.joints) == list(built.joints)
    scale = np.ptp(np.array(list(built.joints.values())), axis=0).max()
    assert np.abs(np.array(list(spec.joints.values())) - np.array(list(built.joints.values()))).max() <= 1e-9 * scale
    assert list(spec.tracks) == list(built.tracks)
    for name, track in built.tracks.items():
        other = spec.tracks[name]
        assert type(other) is type(track)
        if isinstance(track, JointTrack):
            assert other == track
        else:
            assert other.link == track.link and np.allclose(other.at, track.at, rtol=0, atol=1e-9 * scale)


def test_every_planar_example_file_is_in_the_catalog():
    files = {p.relative_to(EXAMPLES).as_posix() for p in [*EXAMPLES.glob("*.yaml"), *EXAMPLES.glob("invalid/*.yaml")]}
    assert files == {e.file for e in catalog.EXAMPLES}


def test_dump_linkage_key_order_comments_and_units():
    example = catalog.EXAMPLES[0]
    text = example.text()
    assert list(yaml.safe_load(text)) == ["name", "units", "description", "joints", "ground", "links", "motor", "tracks"]
    assert text.startswith("# Theo Jansen's Strandbeest leg")
    assert "  G: [-43.160110524104724, -91.75693292612323]" in text and "# foot" in text
    assert {e.build().units for e in catalog.EXAMPLES if e.file.startswith(("jansen", "strandbeest", "klann"))} == {"mm"}


def test_dump_linkage_writes_enough_digits():
    spec = catalog.jansen_leg()
    for line in dump_linkage(spec).splitlines():
        if line.startswith("  C:"):
            digits = [len(v.strip(" []-").replace(".", "").lstrip("0")) for v in line.split(":")[1].split(",")]
            assert min(digits) >= 12


def test_dump_linkage_rejects_notes_for_missing_fields():
    with pytest.raises(ValueError, match="joints.Z"):
        dump_linkage(catalog.jansen_leg(), notes={"joints.Z": "no such joint"})


def test_write_examples_writes_the_catalog(tmp_path):
    paths = catalog.write_examples(tmp_path)
    assert [p.relative_to(tmp_path).as_posix() for p in paths] == [e.file for e in catalog.EXAMPLES]
    for example, path in zip(catalog.EXAMPLES, paths):
        assert path.read_text(encoding="utf-8") == example.text()


def test_dump_linkage_quotes_names_and_text_that_yaml_would_change():
    spec = LinkageSpec.model_validate({
        "name": "yes", "units": "1e3", "description": "two  spaces\nand a line: # not a comment",
        "joints": {"on": (0, 0), "a b": (1.5, 0), "x: y": (2.2, 2.1), "null": (3, 0), "[D]": (1.0, 1.0)},
        "ground": ["on", "null"],
        "links": {"crank #1": ["on", "a b"], "coupler": ["a b", "x: y", "[D]"], "'r'": ["null", "x: y"]},
        "motor": {"joint": "a b", "pivot": "on", "direction": "cw", "range_deg": [-10, 20.5]},
        "tracks": {"true": {"joint": "x: y"}, "p,q": {"link": "coupler", "at": (0.1, 1e-20)}},
        "samples": 90,
    })
    assert load_model(LinkageSpec, "quoted.yaml", dump_linkage(spec)) == spec
