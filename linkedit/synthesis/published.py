"""Published precision-point path-synthesis problems (``linkedit bench -s synthesis``), with their published
solutions' error.

Sources (the numbers are copied as printed there):

* Morgan & Wampler, "Solving a planar four-bar design problem using continuation", ASME J. Mech. Design 112
  (1990) 544–550, Problem 7: five points on a straight line, the fixed pivots given at (0, 0) and (1, 0); its
  points as PHCpack's documentation copies them (janverschelde/PHCpack, src/Python/PHCpy3/doc/source/fourbar.rst,
  "copied from Problem 7 of the paper by Morgan and Wampler"): 15 real four-bars pass exactly through them.
* Wampler, Morgan & Sommese, "Complete solution of the nine-point path synthesis problem for four-bar linkages",
  ASME J. Mech. Design 114 (1992) 153–159: nine points fix a four-bar's coupler curve up to finitely many
  (1442 triples of Roberts cognates, solved by homotopy continuation). The point sets are those of
  HomotopyContinuation.jl's nine-point example, which follows the paper's examples
  (JuliaHomotopyContinuation/juliahomotopycontinuation.github.io, content/examples/9point.md, its
  ``coupler_points``; FourBarLinkages.jl, examples.jl, ``example1``–``example4``, there scaled ×10, ×10, ×10, ×5:
  the fit is scale-free, so the unscaled numbers are kept). The sources draw a real four-bar exactly through each
  set.

Every published solution passes exactly through its points: its error is 0. None is published as a crank-rocker
turning its crank fully inside the 20° transmission band (for the nine points through two circles an exact
crank-rocker exists whose transmission angle falls to 12.1°: outside the band, reached with ``--margin 10``); the
Morgan–Wampler designs also keep the given fixed pivots, which ``synthesize`` leaves free.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Problem:
    """A published point set: ``name``, ``points`` (x, y) as printed, ``source`` (short citation) and ``published``
    (what the published solution is)."""

    name: str
    points: tuple[tuple[float, float], ...]
    source: str
    published: str

    def array(self) -> np.ndarray:
        """The points (N,) complex."""
        return np.array([complex(x, y) for x, y in self.points])


EXACT_NINE = "exact four-bars (homotopy continuation); not shown to turn a crank fully in the 20° band"

PROBLEMS = (
    Problem("Morgan & Wampler 1990, problem 7 (5 on a line)",
            ((0.50, 1.06), (-0.83, -0.27), (-0.34, 0.22), (-0.13, 0.43), (0.22, 0.78)),
            "Morgan & Wampler 1990 via PHCpack fourbar.rst",
            "15 exact four-bars on pivots (0, 0), (1, 0); not shown to turn a crank fully in the 20° band"),
    Problem("Wampler et al. 1992, nine points (8 near a circle)",
            ((0.8961867, -0.09802917), (1.2156535, -1.18749100), (1.5151435, -0.85449808),
             (1.6754775, -0.48768058), (1.7138690, -0.30099232), (1.7215236, 0.03269953),
             (1.6642029, 0.33241088), (1.4984171, 0.74435576), (1.3011834, 0.92153806)),
            "9point.md coupler_points; FourBarLinkages.jl example1", EXACT_NINE),
    Problem("Wampler et al. 1992, nine points on an oval",
            ((0.0, 0.0), (0.30, -0.1), (0.70, 0.0), (0.82, 0.2), (0.90, 0.4), (0.90, 0.7), (0.60, 0.7),
             (0.10, 0.5), (0.00, 0.3)),
            "FourBarLinkages.jl example2", EXACT_NINE),
    Problem("Wampler et al. 1992, nine points on two circles",
            ((0.25, 0.00), (0.52, 0.10), (0.80, 0.70), (1.20, 1.00), (1.40, 1.30), (1.10, 1.48), (0.70, 1.40),
             (0.20, 1.00), (0.02, 0.40)),
            "FourBarLinkages.jl example3", EXACT_NINE),
    Problem("Wampler et al. 1992, nine points (4 on a line)",
            ((1.000, 0.875), (0.750, 0.625), (0.500, 0.375), (0.250, 0.125), (0.000, 0.000),
             (0.96824583, 1.32287565), (1.56124949, 1.73205080), (1.85404962, 1.93649167),
             (1.98431348, 2.00000000)),
            "FourBarLinkages.jl example4", EXACT_NINE),
)
