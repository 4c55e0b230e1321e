"""Motion-curve comparison (after Coros et al. 2013, §5): normalization, features, distances.

* :func:`~linkedit.curves.sources.load_inputs` reads curves from results, CSV and curve sets;
* :func:`~linkedit.curves.descriptors.describe` normalizes a stack (C, M, D) and computes every
  descriptor in one batched pass;
* :func:`~linkedit.curves.distance.term_distances` and :func:`~linkedit.curves.distance.weighted`
  compare them (FFT cross-correlation over cyclic shifts and both directions);
* :func:`~linkedit.curves.learn.learn_weights` fits the weights from labelled pairs;
* :mod:`~linkedit.curves.polyline` resamples polylines by arc length and measures point-to-polyline
  distances (one or many curves at once), for every package.
"""

from linkedit.curves.descriptors import Descriptors, describe, describe_ragged
from linkedit.curves.distance import aligned_rms, term_distances, term_names, weighted
from linkedit.curves.learn import learn_weights
from linkedit.curves.normalize import Normalized, normalize
from linkedit.curves.sources import Curve, load_inputs

__all__ = ["Curve", "Descriptors", "Normalized", "aligned_rms", "describe", "describe_ragged", "learn_weights",
           "load_inputs", "normalize", "term_distances", "term_names", "weighted"]
