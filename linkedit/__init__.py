"""linkedit: design planar and spatial mechanisms.

Layers (no module imports "upwards"): ``spec`` (validated input models) →
``planar`` / ``gcs`` / ``curves`` (array code) → ``edit`` (optimization) →
``io`` (HDF5, SVG) → ``cli`` (the command line).

In a notebook::

    import linkedit as le
    m = le.simulate("examples/jansen.yaml")   # a Motion; shows its motion plot in Jupyter
    m.tracks["foot"].position                 # (360, 2)
    df = m.to_dataframe()                     # pandas; m.to_xarray() for xarray
    m2 = le.load("out/jansen.h5")             # a result file back into a Motion

``le.edit(spec, script)``, ``le.solve3d(spec)`` and ``le.features(*curves)`` likewise
(:mod:`linkedit.notebook`). Imports are lazy: ``import linkedit`` stays fast.
"""

from typing import Any

__version__ = "0.1.0"

_NOTEBOOK = ("Motion", "simulate", "load", "load_spec", "edit", "solve3d", "features")
__all__ = ["__version__", *_NOTEBOOK]


def __getattr__(name: str) -> Any:
    if name in _NOTEBOOK:
        from linkedit import notebook

        return getattr(notebook, name)
    raise AttributeError(f"module 'linkedit' has no attribute {name!r}")
