"""Every picture rendered by a real browser (headless Chromium): it draws, it is not blank.

Chromium comes from Debian's packages (``apt-get install chromium``); without it these tests
skip with that reason. The PNGs are kept in the test's folder for looking at."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from tests.conftest import EXAMPLES

pytestmark = pytest.mark.skipif(shutil.which("chromium") is None,
                                reason="headless chromium not installed (apt-get install chromium)")


def _size(svg):
    head = svg.read_text()[:2000]
    return tuple(int(float(re.search(f'{k}="([0-9.]+)"', head).group(1))) for k in ("width", "height"))


def _shots(folder, names):
    """Render every picture in one browser run (one page, pictures stacked); returns name → image."""
    Image = pytest.importorskip("PIL.Image")
    sizes = {n: _size(folder / f"{n}.svg") for n in names}
    tops, y = {}, 0
    for n in names:
        tops[n], y = y, y + sizes[n][1]
    width = max(w for w, _ in sizes.values())
    page = folder / "all.html"
    page.write_text("<html><body style='margin:0;background:#fff'>" + "".join(
        f"<img src='{n}.svg' style='position:absolute;left:0;top:{tops[n]}px;width:{sizes[n][0]}px;"
        f"height:{sizes[n][1]}px'>" for n in names) + "</body></html>")
    png = folder / "all.png"
    subprocess.run(["chromium", "--headless", "--disable-gpu", "--no-sandbox", f"--screenshot={png}",
                    f"--window-size={width},{y}", "--hide-scrollbars", page.as_uri()],
                   check=True, capture_output=True, timeout=120)
    sheet = Image.open(png).convert("L")
    out = {}
    for n in names:
        w, h = sizes[n]
        out[n] = sheet.crop((0, tops[n], w, tops[n] + h))
        out[n].save(folder / f"{n}.png")
    return out


def test_every_picture_renders(run_cli, tmp_path):
    j = tmp_path / "j.h5"
    steps = [
        ("simulate", EXAMPLES / "jansen.yaml", "-o", j, "--svg", tmp_path / "motion.svg", "-n", "120"),
        ("simulate", EXAMPLES / "klann.yaml", "-o", tmp_path / "k.h5", "--svg", tmp_path / "animated.svg", "--animate",
         "-n", "120"),
        ("edit", EXAMPLES / "edits" / "jansen-move-knee.yaml", "-o", tmp_path / "edit"),
        ("solve3d", EXAMPLES / "3d" / "compound-crank-rocker.yaml", "-o", tmp_path / "c.h5", "--svg", tmp_path / "3d.svg", "--steps", "61"),
        ("solve3d", EXAMPLES / "3d" / "crank-rocker.yaml", "-o", tmp_path / "cr.h5", "--svg", tmp_path / "3d-xy.svg",
         "--steps", "61", "--arrows"),
        ("compare-curves", f"{j}:foot", EXAMPLES / "curves" / "foot-paths.yaml", "--svg", tmp_path / "curves.svg"),
        ("plot", j, "-o", tmp_path / "kinematics.svg"),
    ]
    for args in steps:
        r = run_cli(*args)
        assert r.exit_code == 0, (args, r.output)
    shutil.copy(next((tmp_path / "edit").glob("*.svg")), tmp_path / "edit.svg")
    import numpy as np

    for name, im in _shots(tmp_path, ["motion", "animated", "edit", "3d", "3d-xy", "curves", "kinematics"]).items():
        inked = float((np.asarray(im) < 200).mean())
        assert min(im.size) > 300 and 0.01 < inked < 0.6, (name, im.size, inked)
