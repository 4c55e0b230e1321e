"""The files of ``examples/``: which mechanism each holds, the comments written with it, and
writing them all."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from linkedit.io.atomic import write_text
from linkedit.planar.catalog.four_bars import crank_rocker, hoekens
from linkedit.planar.catalog.legs import jansen_leg, klann_leg, strandbeest
from linkedit.planar.catalog.six_bars import complex_loop, figure_eight_six_bar, stephenson_six_bar, watt_six_bar
from linkedit.planar.catalog.sliders import (inverted_slider_crank, lifting_arm, locking_slider_crank, quick_return,
                                             scotch_yoke, scotch_yoke_coupler, slider_crank, stephenson_slider,
                                             two_slots)
from linkedit.spec.linkage import LinkageSpec
from linkedit.spec.linkage_yaml import dump_linkage


@dataclass(frozen=True)
class Example:
    """One file of ``examples/``: which mechanism it holds and the comments written with it."""

    file: str
    build: Callable[[], LinkageSpec]
    header: str = ""
    notes: Mapping[str, str] = field(default_factory=dict)
    #: False for a linkage that linkedit must reject (the complex loop)
    simulates: bool = True

    def text(self) -> str:
        return dump_linkage(self.build(), self.header, self.notes)


EXAMPLES: tuple[Example, ...] = (
    Example(
        "jansen.yaml", jansen_leg,
        header="""\
Theo Jansen's Strandbeest leg, the bundled demo:  linkedit simulate examples/jansen.yaml
Holy numbers (mm): a=38 l=7.8 (frame pivot B = (-a, -l)), m=15 (crank), j=50 (AC), k=61.9 (AD),
b=41.5 (BC), c=39.3 (BD), d=40.1 (BE), e=55.8 (CE), f=39.4 (EF), g=36.7 (DF), h=65.7 (FG), i=49 (DG).
The rest pose below is the crank at 0 degrees, computed exactly from these lengths
(written by linkedit.planar.catalog; regenerate with: python -m linkedit.planar.catalog).""",
        notes={
            "joints": "rest pose, mm: name -> [x, y]",
            "joints.O": "crank axle (ground)", "joints.A": "crank pin", "joints.B": "frame pivot (ground)",
            "joints.C": "upper knee", "joints.D": "lower knee", "joints.E": "hip corner",
            "joints.F": "ankle", "joints.G": "foot",
            "ground": "joints fixed to the frame",
            "links": "rigid bodies: name -> the joints they carry",
            "links.crank": "m = 15", "links.upper_rod": "j = 50", "links.lower_rod": "k = 61.9",
            "links.upper": "triangle: BC = b, BE = d, CE = e", "links.rocker": "c = 39.3",
            "links.knee": "f = 39.4", "links.lower": "triangle: DF = g, FG = h, DG = i",
            "motor": "A turns counter-clockwise about O; t = 0 is the rest pose",
            "tracks.foot": "the walking foot",
        },
    ),
    Example("strandbeest-3.yaml", lambda: strandbeest(3),
            header="Strandbeest with 3 leg pairs on one crank (pins 120 degrees apart); "
                   "written by linkedit.planar.catalog."),
    Example("strandbeest-10.yaml", lambda: strandbeest(10),
            header="Strandbeest with 10 leg pairs on one crank (pins 36 degrees apart); "
                   "written by linkedit.planar.catalog."),
    Example("klann.yaml", klann_leg,
            header="Klann's walking leg, lengths after boim.com/Walkin8r/Klann.html (optimized geometry);\n"
                   "written by linkedit.planar.catalog.",
            notes={"joints.A": "crank axle", "joints.C": "crank pin", "joints.G": "foot"}),
    Example("hoekens.yaml", hoekens,
            header="Hoekens' straight-line linkage: crank 1, ground 2, coupler 2.5 extended to 5, rocker 2.5.\n"
                   "P runs along a straight line (within 0.01) while the crank turns from 90 to 270 degrees.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"links.coupler": "P is on the line A-B, AP = 5", "tracks.tracer": "the straight-line point"}),
    Example("crank-rocker.yaml", crank_rocker,
            header="Grashof crank-rocker four-bar; written by linkedit.planar.catalog.",
            notes={"tracks.coupler_point": "a point fixed to the coupler, given at the rest pose"}),
    Example("watt-six-bar.yaml", watt_six_bar,
            header="Watt II six-bar of linkedit's own design; written by linkedit.planar.catalog.",
            notes={"links.bell_crank": "ternary: shares D with the frame (Watt's chain)"}),
    Example("stephenson-six-bar.yaml", stephenson_six_bar,
            header="Stephenson III six-bar of linkedit's own design; written by linkedit.planar.catalog.",
            notes={"links.coupler": "ternary: touches the frame only through crank and rocker"}),
    Example("complex-loop.yaml", complex_loop,
            header="A six-bar with a complex kinematic loop (class-III Assur group): no joint can be placed\n"
                   "from two known ones, so T1, T2, T3 are solved as one numeric group at every sample.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"links.body": "ternary body hung from P1, P2 and the crank pin A"}),
    Example("slider-crank.yaml", slider_crank,
            header="Offset slider-crank: crank r = 20, rod l = 70, slider line y = e = 12;\n"
                   "x_B = r cos(theta) + sqrt(l^2 - (r sin(theta) - e)^2). Written by linkedit.planar.catalog.",
            notes={"sliders.piston": "B stays on the horizontal line through its rest position"}),
    Example("quick-return.yaml", quick_return,
            header="Crank-shaper quick-return: the crank pin A slides in the rocker's slot (through O2);\n"
                   "the rod C-R drives the ram R along y = 75. Written by linkedit.planar.catalog.",
            notes={"sliders.slot": "the slot turns with the rocker", "sliders.ram": "the ram's guide"}),
    Example("scotch-yoke.yaml", scotch_yoke,
            header="Scotch yoke: the yoke moves by r cos(theta). Written by linkedit.planar.catalog.",
            notes={"sliders.slot": "A in the yoke's vertical slot", "sliders.guide": "the yoke translates along x"}),
    Example("figure-eight-six-bar.yaml", figure_eight_six_bar,
            header="A Stephenson III six-bar whose tracer draws Gerono's figure-eight x = 20 cos t, y = 10 sin 2t (mm) to\n"
                   "0.26 % RMS of its width with every transmission angle within [20°, 160°] (no four-bar does better\n"
                   "than 4.15 % in that band: README, synthesis). Found by a global search outside linkedit (random\n"
                   "six-bars, then SLSQP with the band and every link and pivot within 3 widths of the figure as\n"
                   "constraints). `linkedit atlas build --family examples/figure-eight-six-bar.yaml` makes it a\n"
                   "synthesis family. Written by linkedit.planar.catalog."),
    Example("scotch-yoke-coupler.yaml", scotch_yoke_coupler,
            header="A Scotch yoke driving a coupler: the yoke carries the coupler Y2-B-P of the rocker Q-B.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"sliders.slot": "A in the yoke's vertical slot", "sliders.guide": "the yoke translates along x"}),
    Example("inverted-slider-crank.yaml", inverted_slider_crank,
            header="Inverted slider-crank: the arm A-X slides through the ground pivot Q.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"sliders.sleeve": "Q slides in the arm's slot (the slot line passes through A)"}),
    Example("two-slots.yaml", two_slots,
            header="A pin in two slots: P = crossing of the slotted crank's line and the rail y = 30,\n"
                   "x_P = 30 cot(theta). Written by linkedit.planar.catalog.",
            notes={"sliders.arm": "P in the crank's slot (the line O-A)", "sliders.rail": "and in the rail y = 30"}),
    Example("stephenson-slider.yaml", stephenson_slider,
            header="Stephenson III six-bar with a slider output. Written by linkedit.planar.catalog.",
            notes={"sliders.output": "E slides along y = 20"}),
    Example("invalid/locking-slider-crank.yaml", locking_slider_crank, simulates=False,
            header="A deliberate failure: the rod is too short, so the slider locks up for part of the turn:\n"
                   "  linkedit simulate examples/invalid/locking-slider-crank.yaml  ->  exit 1, slider piston.\n"
                   "Written by linkedit.planar.catalog."),
    Example("lifting-arm.yaml", lifting_arm,
            header="A cylinder-driven boom (linear input): the rod end R extends 0..25 mm out of the barrel.\n"
                   "Written by linkedit.planar.catalog.",
            notes={"sliders.cylinder": "R slides along the barrel P-Q",
                   "motor": "linear input: R's displacement along the barrel from rest"}),
)


def write_examples(directory: str | Path) -> list[Path]:
    """Write every :data:`EXAMPLES` file into ``directory`` (atomically); returns the paths."""
    paths = [Path(directory) / ex.file for ex in EXAMPLES]
    for ex, path in zip(EXAMPLES, paths):
        write_text(path, ex.text())
    return paths
