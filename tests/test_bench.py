"""`linkedit bench --quick` runs every section and prints figures (a smoke test, not a timing)."""

from __future__ import annotations

import re

import pytest

from linkedit.commands.bench import SECTIONS


#: the synthesis section builds its atlases and refines every family's targets (about a minute here): `make test-all`
SLOW = {"synthesis"}


@pytest.mark.parametrize("section", [pytest.param(s, marks=pytest.mark.slow) if s in SLOW else s
                                     for s in sorted(SECTIONS)])
def test_bench_section_prints_figures(run_cli, section):
    r = run_cli("bench", "--quick", "--section", section)
    assert r.exit_code == 0, r.output
    assert f"== {section}" in r.output
    assert re.search(r"\d+\.\d+", r.output)
    if section == "synthesis":  # issue 23 §4: the spatial held-out rows, each family's, solved by solve3d
        rows = re.findall(r"^  (spherical-four-bar|rssr) #1 .* % \(.*\) +\d+\.\d+$", r.output, re.MULTILINE)
        assert rows == ["spherical-four-bar", "rssr"], r.output
        arcs = re.findall(r"^  half arc of (spherical-four-bar|rssr) #1 .* % \(.*\) +\d+\.\d+$", r.output, re.MULTILINE)
        assert arcs == ["spherical-four-bar", "rssr"], r.output
        # quick mode refines one candidate per target, and every section's header says so
        tops = re.findall(r"^(quality|synthesize end to end|precision points|published precision-point problems|"
                          r"spatial targets),(?: --points)? --top (\d+)", r.output, re.MULTILINE)
        assert sorted(tops) == [("precision points", "1"), ("published precision-point problems", "1"),
                                ("quality", "1"), ("spatial targets", "1"), ("synthesize end to end", "1")], tops
        # issue 23 §1 and §3: the published precision-point problems and function generation
        assert re.search(r"^  Morgan & Wampler 1990, problem 7 .* 0 +\d+\.\d+  15 exact", r.output, re.MULTILINE)
        assert re.search(r"^  log10 x +band 20°: sense free \d\.\d+° .* same sense \d\.\d+° .* six-bar same sense "
                         r"0\.[0-4]\d*° ", r.output, re.MULTILINE)
        # issue 23 §2: motion generation from poses of held-out linkages, each family's exact case exact to rounding
        # (position over the poses' size ≤ 1e-12; angle and timing ≤ 1e-10°, 1.7e-12 rad: met to ~1e-15 and
        # ~1e-13°, the six-bar's too); least squares only without --quick
        exact = re.findall(r"^  (four-bar|slider-crank|six-bar) +exact, (\d) poses +(\S+) +(\S+) +(\S+) +\d+\.\d+$",
                           r.output, re.MULTILINE)
        assert [(f, n) for f, n, *_ in exact] == [("four-bar", "5"), ("slider-crank", "4"), ("six-bar", "5")], r.output
        for family, _, position, angle, timing in exact:
            assert float(position) <= 1e-12 and float(angle) <= 1e-10, (family, position, angle)
            assert (timing == "—") == (family != "six-bar") and (timing == "—" or float(timing) <= 1e-10), timing
        assert "lsq, 8 poses" not in r.output


def test_unknown_section_exit_2(run_cli):
    r = run_cli("bench", "--section", "nope")
    assert r.exit_code == 2 and "unknown section" in r.output
