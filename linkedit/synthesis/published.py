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

The metaheuristic (GA, DE, swarm) problems, with the four-bars the literature reports for them: no paper's tables
were reachable, so the numbers are those of the MATLAB code published with Nguyen-Van, Lieu, Xuan-Mung & Nguyen,
"A new study on optimization of four-bar mechanisms based on a hybrid-combined differential evolution and Jaya
algorithm", Symmetry 14 (2022) 381 (github.com/sy-nguyen-van/DE_Jaya_Synthesis_Four_Bar_Mechanisms, commit a18dcd4;
the points in CaseK/ObjfK.m, the earlier authors' linkages in the columns of Case1/Check_Case1.m (header "Cabrera
(GA) Acharyya (GA PSO DE) MUMSA IOA"; the 7th column is the one Case1/Check.m names "WY Lin and KM Hsiao: A new
differential evolution algorithm with a combined mutation strategy for optimum synthesis of path-generating four-bar
mechanisms"), Case2/CheckCASE2.m (variables Kunjur, Cabrera, MUMSA, IOA), Case3/CheckCASE3.m (header "Cabrera
Kunjur MUMSA IOA"), Case4/CheckCASE4.m (its columns unnamed), Case5/CheckCase5.m (header "MUMSA IOA WYLin"),
the paper's own in CaseK/x_best_HCDJ_CaseK.txt; Case4's does not turn its crank fully, column 4 is kept instead).
MainOptim.m's header states one error per problem (the sum of squared distances at the crank angles): 4.06717e-12,
4.27e-6, 0.03375, 1.216, 4.02e-4; the linkage marked ``stated`` reproduces it. Only the columns the code names are
kept (Case1's "Acharyya" columns are not, its own comments label them inconsistently). A linkage is the sources'
vector as printed: ground r1, crank r2, coupler r3, rocker r4, the coupler point (rcx, rcy) in the coupler's frame
(x along the crank pin → rocker pin), the crank axle (x0, y0), the ground line's angle θ0 (rad), then the crank
angles (rad, from the ground line) where the timing is free, or the first one where it steps; the sources' closed
form assembles the rocker pin on the left of the crank pin → rocker pivot line (the family's branch +1). Their
timing is scored by the sources, not by the bench: ``synthesize`` and the bench's published column both take each
point's distance to the whole coupler curve (free timing, free placement).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from linkedit.spec.linkage import LinkageSpec
from linkedit.synthesis import fourbar
from linkedit.synthesis import points as precision


@dataclass(frozen=True)
class FourBar:
    """A published four-bar: ``label`` (its authors), ``x`` the sources' vector as printed (module docstring: r1 r2
    r3 r4 rcx rcy x0 y0 θ0, then crank angles; six numbers where the placement is fixed at the origin) and
    ``stated``, the sum of squared distances at its crank angles that the source states (None: none stated)."""

    label: str
    x: tuple[float, ...]
    stated: float | None = None

    def placed(self) -> tuple[np.ndarray, complex, complex]:
        """(row, factor, shift): the :mod:`~linkedit.synthesis.fourbar` parameters (6,) and the placement
        z ↦ shift + factor·z of the family frame."""
        r1, r2, r3, r4, rcx, rcy = self.x[:6]
        x0, y0, theta0 = self.x[6:9] if len(self.x) > 6 else (0.0, 0.0, 0.0)
        u = complex(rcx, rcy) / r3
        return (np.array([r2 / r1, r3 / r1, r4 / r1, u.real, u.imag, 1.0]), r1 * complex(np.exp(1j * theta0)),
                complex(x0, y0))

    def to_spec(self) -> LinkageSpec:
        """The linkage as a linkedit spec, crank at angle 0, track ``target`` = the coupler point."""
        row, factor, shift = self.placed()
        return fourbar.to_spec(row, phase=0.0, scale=abs(factor), turn=factor / abs(factor), shift=shift,
                               mirrored=False, name="published", units="1", description=self.label)

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Distances (N,) from ``points`` (N,) complex to its coupler curve: exact, as ``synthesize --points``
        scores its own result (:func:`~linkedit.synthesis.points.family_closest`)."""
        row, factor, shift = self.placed()
        return precision.family_closest(fourbar, row[None], np.array([factor]), np.array([shift]), False,
                                        points)[0]


@dataclass(frozen=True)
class Problem:
    """A published point set: ``name``, ``points`` (x, y) as printed, ``source`` (short citation), ``published``
    (what the published solutions are), ``linkages`` (the published four-bars; none: exact solutions, error 0) and
    the sources' timing: ``crank`` the prescribed crank angles (rad), or ``step`` the prescribed increment from a
    free first angle, else free (each linkage's own angles)."""

    name: str
    points: tuple[tuple[float, float], ...]
    source: str
    published: str
    linkages: tuple[FourBar, ...] = ()
    crank: tuple[float, ...] = ()
    step: float = 0.0

    def array(self) -> np.ndarray:
        """The points (N,) complex."""
        return np.array([complex(x, y) for x, y in self.points])

    def angles(self, linkage: FourBar) -> np.ndarray:
        """The crank angles (N,) rad at which the sources score ``linkage`` on the points."""
        n = len(self.points)
        if self.crank:
            return np.array(self.crank)
        if self.step:
            return linkage.x[9] + self.step * np.arange(n)
        return np.array(linkage.x[9:9 + n])

    def best(self) -> tuple[FourBar, np.ndarray] | None:
        """The published linkage nearest the points by the bench's measure (mean distance to its curve) and its
        distances (N,) over the points' RMS radius; None for exact solutions (error 0)."""
        if not self.linkages:
            return None
        z = self.array()
        scored = [(linkage, linkage.distances(z) / precision.rms_radius(z)) for linkage in self.linkages]
        return min(scored, key=lambda pair: float(pair[1].mean()))


#: The metaheuristic problems' source (module docstring) and the paper's own linkages (HCDJ).
GA_SOURCE = "Nguyen-Van et al. 2022 code (sy-nguyen-van/DE_Jaya_Synthesis_Four_Bar_Mechanisms)"
HCDJ = "Nguyen-Van et al. 2022 (HCDJ)"
PI = float(np.pi)

GA_PROBLEMS = (
    Problem("GA case 1: six points on a vertical line",
            ((20, 20), (20, 25), (20, 30), (20, 35), (20, 40), (20, 45)),
            GA_SOURCE, "Cabrera GA, MUMSA, IOA, Lin & Hsiao DE, HCDJ (free timing)",
            (FourBar("Cabrera et al. (GA)", (39.46629, 8.56291, 19.09486, 47.83886, 13.38556, 12.21961, 29.72250,
                                             23.45450, 6.20163, 6.11937, 0.19304, 0.44083, 0.68467, 0.95835,
                                             1.35533)),
             FourBar("MUMSA", (31.78826, 8.20465, 24.93213, 31.38593, 34.19372, 14.41567, -6.36652, 56.83676,
                               4.01596, 1.36655, 2.33077, 2.87104, 3.39459, 3.97096, 4.96349)),
             FourBar("IOA", (54.71582, 18.73099, 31.22310, 42.22374, -27.29874, 31.65051, 43.07086, 27.41706,
                             5.97746, 6.42411, 6.53496, 0.36230, 0.46906, 0.57765, 0.69047)),
             FourBar("Lin & Hsiao (DE)", (45.9540268793200, 10.1413352283990, 36.1198616002200, 49.7905570636800,
                                          51.4935231082160, 16.4957302836340, 59.9251894962240, -0.2672551778894,
                                          0.8623849541875, 4.4968313984955, 3.9468529220684, 3.5120853909802,
                                          3.1107812488088, 2.7101093119519, 2.2654986625734), 4.06717e-12),
             FourBar(HCDJ, (14.201369, 8.0143127, 16.309922, 12.253871, 27.797721, 11.305412, -2.309531, 45.695083,
                            4.5172417, 6.2532447, 2.4038981, 2.9362397, 3.4905751, 4.0650776, 5.2095019)))),
    Problem("GA case 2: five points, crank at 30°..90°",
            ((3, 3), (2.759, 3.363), (2.372, 3.663), (1.890, 3.862), (1.355, 3.943)),
            GA_SOURCE, "Kunjur, Cabrera, MUMSA, IOA, HCDJ (crank at 30..90° by 15°, axle at 0, ground on x)",
            (FourBar("Kunjur & Krishnamurty", (3.509643, 1.857606, 4.725835, 3.518721, 1.959538, 1.558898)),
             FourBar("Cabrera et al.", (3.0630424, 1.9959624, 3.305823, 2.524706, 1.645158, 1.708959)),
             FourBar("MUMSA", (3.77326856, 2.00000403, 4.11697104, 2.74615671, 1.67848787, 1.67098007)),
             FourBar("IOA", (2.803607, 1.99226, 3.030461, 2.474117, 1.64413, 1.714536), 4.27e-6),
             FourBar(HCDJ, (4.2930812, 1.9978324, 4.7374099, 2.9417301, 1.7074051, 1.6441696))),
            crank=(PI / 6, PI / 4, PI / 3, 5 * PI / 12, PI / 2)),
    Problem("GA case 3: 18 points, crank steps of 20°",
            ((0.5, 1.1), (0.4, 1.1), (0.3, 1.1), (0.2, 1.0), (0.1, 0.9), (0.05, 0.75), (0.02, 0.6), (0.0, 0.5),
             (0.0, 0.4), (0.03, 0.3), (0.1, 0.25), (0.15, 0.2), (0.2, 0.3), (0.3, 0.4), (0.4, 0.5), (0.5, 0.7),
             (0.6, 0.9), (0.6, 1.0)),
            GA_SOURCE, "Cabrera, Kunjur, MUMSA, IOA, HCDJ (crank steps of 20°)",
            (FourBar("Cabrera et al.", (3.057878, 0.237803, 4.828954, 2.056456, 0.767038, 1.850828, 1.776808,
                                        -0.641991, 1.002168, 0.226186), 0.03375),
             FourBar("Kunjur & Krishnamurty", (1.87966, 0.274853, 1.180253, 2.138209, -0.833592, -0.37877, 1.132062,
                                               0.663433, 4.354224, 2.558625)),
             FourBar("MUMSA", (4.453772, 0.297057, 3.913095, 0.849372, -2.067338, 1.6610626, -1.309243, 2.806964,
                               2.7387359, 4.853543)),
             FourBar("IOA", (4.040435, 0.245216, 6.38294, 2.620532, 1.139106, 1.866109, 1.891805, -0.761339,
                             1.187751, 0.0)),
             FourBar(HCDJ, (49.800886, 0.28817159, 48.476138, 1.633642, -23.41281, 7.6644886, -14.836153, 20.140223,
                            2.5286091, 5.0644224))),
            step=PI / 9),
    Problem("GA case 4: six points on an arc, crank at 30°..180°",
            ((0, 0), (1.9098, 5.8779), (6.9098, 9.5106), (13.09, 9.5106), (18.09, 5.8779), (20, 0.0)),
            GA_SOURCE, "unnamed (crank at 30..180° by 30°; the crank barely turns fully: μ 0.1°)",
            (FourBar("Case4/CheckCASE4.m column 4", (49.999217, 1.3476638, 1.3476825, 49.999235, 11.383058,
                                                     4.4426855, 10.1944353, -3.6925458, 6.2157809), 1.216),),
            crank=(PI / 6, PI / 3, PI / 2, 2 * PI / 3, 5 * PI / 6, PI)),
    Problem("GA case 5: ten points on an ellipse (first = last)",
            ((20, 10), (17.66, 15.142), (11.736, 17.878), (5, 16.928), (0.60307, 12.736), (0.60307, 7.2638),
             (5, 3.0718), (11.736, 2.1215), (17.66, 4.8577), (20, 10)),
            GA_SOURCE, "MUMSA, IOA, W.Y. Lin, HCDJ (free timing)",
            (FourBar("MUMSA", (79.516068, 9.723973, 45.842524, 51.432848, 8.213922, -2.9539575, 2.021109, 13.2165878,
                               5.5969445, 0.6376873, 1.3255329, 2.0080339, 2.6955659, 3.3845794, 4.08293762,
                               4.79845482, 5.51170565, 6.2127919, 0.6371866)),
             FourBar("IOA", (65.428771, 8.016387, 47.221655, 44.13656, -11.570858, -1.904914, 10.635414, -1.675477,
                             3.86733, 2.419931, 3.109267, 3.81295, 4.50644, 5.181139, 5.88342, 0.296263, 0.991153,
                             1.707787, 2.418865)),
             FourBar("W.Y. Lin", (80.0, 8.045662, 50.81902, 42.20801, -10.63697, -2.29109, 8.494813, -0.7579678,
                                  3.88921, 2.449437, 3.153969, 3.837114, 4.520171, 5.204799, 5.898536, 0.316204,
                                  1.023555, 1.738992, 2.449437), 4.02e-4),
             FourBar(HCDJ, (79.999856, 8.1232008, 50.870344, 42.360533, -10.853763, 0.091433127, 7.5379031,
                            -0.52254141, 4.0121195, 2.3428599, 3.0535127, 3.7417464, 4.4255457, 5.1086716, 5.7983829,
                            0.21286893, 0.91658554, 1.6304135, 2.3428152)))),
)

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
) + GA_PROBLEMS
