"""The example mechanisms, built from their link lengths: the source of ``examples/*.yaml``.

Every rest pose is computed exactly (circle–circle intersections in double precision) from the
mechanism's defining lengths, not typed in as rounded coordinates, so link lengths are the
designer's numbers to the last bit. Each function returns a validated :class:`LinkageSpec`;
:func:`~linkedit.spec.linkage_yaml.dump_linkage` writes one as YAML (with optional comments) and :data:`EXAMPLES` says which
file holds which mechanism. Regenerate the files with ``python -m linkedit.planar.catalog``.

One module per kind of mechanism (:mod:`.legs`, :mod:`.four_bars`, :mod:`.six_bars`,
:mod:`.sliders`), each with its designers' numbers; :mod:`.geometry` builds the exact rest poses
and :mod:`.examples` lists the files. The builders are importable from here (``catalog.jansen_leg()``).
"""

from linkedit.planar.catalog.examples import EXAMPLES, Example, write_examples
from linkedit.planar.catalog.four_bars import crank_rocker, hoekens
from linkedit.planar.catalog.legs import jansen_leg, klann_leg, strandbeest
from linkedit.planar.catalog.six_bars import complex_loop, figure_eight_six_bar, stephenson_six_bar, watt_six_bar
from linkedit.planar.catalog.sliders import (inverted_slider_crank, lifting_arm, locking_slider_crank, quick_return,
                                             scotch_yoke, scotch_yoke_coupler, slider_crank, stephenson_slider,
                                             two_slots)

__all__ = ["EXAMPLES", "Example", "complex_loop", "crank_rocker", "figure_eight_six_bar", "hoekens",
           "inverted_slider_crank", "jansen_leg", "klann_leg", "lifting_arm", "locking_slider_crank", "quick_return",
           "scotch_yoke", "scotch_yoke_coupler", "slider_crank", "stephenson_six_bar", "stephenson_slider",
           "strandbeest", "two_slots", "watt_six_bar", "write_examples"]
