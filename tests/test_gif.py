"""The animated GIF is the animated SVG's figure, frame by frame: same size, same frames, same cycle
time, the moving parts where the SVG has them, with title, axes and legend, antialiased
(issue 25, item 2)."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from linkedit.io.gif import frame_ms
from tests.conftest import EXAMPLES
from tests.test_svg import NS, find

FRAME_FILL = (0xE2, 0xE8, 0xF0)  # a slider block's fill


def _rgb(im, k):
    im.seek(k)
    return np.asarray(im.convert("RGB"), dtype=int)


def test_gif_frames_are_the_svg_figure(run_cli, tmp_path):
    Image = pytest.importorskip("PIL.Image")
    for suffix in ("svg", "gif"):
        r = run_cli("simulate", EXAMPLES / "scotch-yoke.yaml", "-o", tmp_path / f"{suffix}.h5", "-n", "72", "--animate",
                    "--svg", tmp_path / f"a.{suffix}")
        assert r.exit_code == 0, r.output
    root = ET.parse(tmp_path / "a.svg").getroot()
    im = Image.open(tmp_path / "a.gif")
    assert im.size == (int(root.get("width")), int(root.get("height")))
    assert im.n_frames == 72 and im.info["loop"] == 0
    durations = []
    for k in range(im.n_frames):
        im.seek(k)
        durations.append(im.info["duration"])
    assert sum(durations) == 4000  # the SVG's cycle: dur="4s"
    assert {a.get("dur") for a in root.iter(NS + "animate")} == {"4s"}
    # the block in the yoke's slot is where the SVG's animation puts it, frame by frame
    (block,) = [b for b in find(root, "block") if b.get("data-name") == "slot"]
    (anim,) = block.iter(NS + "animate")
    frames = [np.array([[float(c) for c in p.split(",")] for p in v.split()]) for v in anim.get("values").split(";")]
    for k in (0, 9, 18, 45):
        corners = frames[k]
        inside = corners.mean(axis=0) + 0.35 * (corners[1] - corners[0])  # on the block, clear of the pin
        x, y = np.round(inside).astype(int)
        assert np.abs(_rgb(im, k)[y, x] - FRAME_FILL).max() <= 12, k
        assert np.abs(_rgb(im, (k + 36) % 72)[y, x] - FRAME_FILL).max() > 12, k  # half a turn later it is elsewhere
    first = _rgb(im, 0)
    title = next(t for t in root.iter(NS + "text") if t.get("class") == "title")
    ty, tx = int(float(title.get("y"))), int(float(title.get("x")))
    assert (first[ty - 12:ty + 2, tx - 40:tx + 40].sum(axis=2) < 300).any()  # the title's letters
    legend = next(g for g in root.iter(NS + "g") if g.get("class") == "legend")
    lx = int(float(next(legend.iter(NS + "text")).get("x")))
    assert (first[:, lx:].sum(axis=2) < 400).any()  # the legend's words
    assert len(np.unique(first.reshape(-1, 3), axis=0)) > 30  # antialiased edges, not two-tone


@pytest.mark.parametrize("frames, seconds", [(120, 4.0), (72, 4.0), (50, 3.0), (7, 1.0)])
def test_frame_times_add_up_to_the_cycle(frames, seconds):
    ms = frame_ms(frames, seconds)
    assert len(ms) == frames and sum(ms) == round(seconds * 1000) and all(m % 10 == 0 and m >= 20 for m in ms)
    assert max(ms) - min(ms) <= 10
