"""Linkage synthesis (after Coros et al. 2013, §4–5): which linkage draws this curve?

* :mod:`~linkedit.synthesis.families` — parameterized topologies (four-bar with a coupler point
  anywhere on the coupler plane), sampled from a documented seeded distribution and evaluated
  batched over linkages *and* samples;
* :mod:`~linkedit.synthesis.atlas` — chunked, seeded, appendable HDF5 atlases of curves and
  their descriptors, built in-process or on a Dask cluster;
* :mod:`~linkedit.synthesis.index` — the fast descriptor query;
* :mod:`~linkedit.synthesis.refine` — refinement of a placed candidate against the target;
* :mod:`~linkedit.synthesis.synthesize` — the whole pipeline behind ``linkedit synthesize``.
"""
