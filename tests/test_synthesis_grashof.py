"""The four-bar atlas holds every Grashof type a full-turn crank can drive: crank-rockers (the crank the shortest
link) and drag links (the ground the shortest: crank and rocker both turn fully), in the shares documented in
`linkedit.synthesis.fourbar.sample`; a held-out drag link's coupler curve is synthesized within 1 %."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from linkedit.synthesis import atlas, fourbar

#: A drag link the atlas does not hold (family parameters a, b, c, u, v, branch; ground 1, the shortest link).
DRAG_LINK = np.array([2.39163231681066, 3.8726447328752416, 3.618580069999852, 0.9885942094459517,
                      -0.9765409285956692, 1.0])


def grashof_type(rows: np.ndarray) -> np.ndarray:
    """'crank-rocker', 'drag-link' or 'other' per row (K, 6), from the four link lengths (ground 1, crank a,
    coupler b, rocker c): Grashof (shortest + longest ≤ the other two) with the crank or the ground the shortest."""
    lengths = np.column_stack([np.ones(len(rows)), rows[:, :3]])  # ground, crank, coupler, rocker
    ordered = np.sort(lengths, axis=1)
    grashof = ordered[:, 0] + ordered[:, 3] <= ordered[:, 1] + ordered[:, 2]
    shortest = np.argmin(lengths, axis=1)
    return np.where(grashof & (shortest == 1), "crank-rocker",
                    np.where(grashof & (shortest == 0), "drag-link", "other"))


@pytest.fixture(scope="module")
def four_bars(tmp_path_factory):
    path = tmp_path_factory.mktemp("atlas") / "four-bar.h5"
    atlas.build(path, ["four-bar"], 3 * atlas.CHUNK, seed=1)
    return path


def test_the_atlas_holds_crank_rockers_and_drag_links(four_bars):
    """About 16 % drag links (documented), crank-rockers for the rest, every one a full-turn crank
    inside the 20° band (the closed form, independently: the transmission angle at both extremes of |A − D|)."""
    with h5py.File(four_bars) as f:
        rows = f["families/four-bar/params"][()]
    kinds = grashof_type(rows)
    assert set(kinds) == {"crank-rocker", "drag-link"}
    assert 0.12 <= np.mean(kinds == "drag-link") <= 0.20
    assert rows[kinds == "drag-link", 0].max() > 3.0  # not a sliver near a = 1
    a, b, c = rows[:, 0], rows[:, 1], rows[:, 2]
    for d in (np.abs(1 - a), 1 + a):
        assert (np.abs((b * b + c * c - d * d) / (2 * b * c)) <= np.cos(np.radians(20.0)) + 1e-12).all()


def test_a_held_out_drag_link_is_synthesized(run_cli, four_bars, tmp_path):
    """A drag link's coupler curve, moved, 200 points: `synthesize` within 1 % RMS of its size, measured here on
    `linkedit simulate result.yaml` (dense, both ways, against the true curve)."""
    assert grashof_type(DRAG_LINK[None])[0] == "drag-link"
    truth = 12 - 5j + 30 * np.exp(2.2j) * fourbar.curves(DRAG_LINK[None], 20000, 0.35)[0]
    target = truth[(np.arange(200) * len(truth)) // 200]
    (tmp_path / "t.csv").write_text("x,y\n" + "\n".join(f"{float(p.real)!r},{float(p.imag)!r}" for p in target) + "\n")
    out = tmp_path / "out"
    result = run_cli("synthesize", tmp_path / "t.csv", "--atlas", four_bars, "-o", out, "--top", "3")
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["family"] == "four-bar" and report["error"]["after"]["rms"] <= 0.01
    sim = run_cli("simulate", out / "result.yaml", "-o", tmp_path / "fine.h5", "-n", "4000")
    assert sim.exit_code == 0, sim.output
    with h5py.File(tmp_path / "fine.h5") as f:
        p = f["tracks/target/position"][()]
    drawn = p[:, 0] + 1j * p[:, 1]
    gap = np.concatenate([np.abs(target[:, None] - drawn[None]).min(axis=1),
                          np.abs(drawn[::10, None] - truth[None]).min(axis=1)]) / report["target"]["size"]
    assert np.sqrt(np.mean(gap ** 2)) <= 0.01
