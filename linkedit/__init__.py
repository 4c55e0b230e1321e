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

from __future__ import annotations

import types

TYPE_CHECKING = False  # not `typing`'s: importing typing costs the entry point 10-60 ms before it handles Ctrl-C
if TYPE_CHECKING:
    from typing import Any

__version__ = "0.1.0"

_NOTEBOOK = ("Motion", "simulate", "load", "load_spec", "solve3d", "features")
__all__ = ["__version__", "edit", *_NOTEBOOK]


class _EditPackage(types.ModuleType):
    """``linkedit.edit`` is a subpackage (so it is the attribute ``linkedit.edit``) and, for
    notebooks, also callable: ``le.edit(spec, script)`` is :func:`linkedit.notebook.edit`."""

    def __call__(self, spec: Any, script: Any) -> Any:
        from linkedit.notebook import edit as run

        return run(spec, script)


if TYPE_CHECKING:  # what a type checker sees: the notebook functions, typed (imported lazily at run time)
    from linkedit.notebook import Motion, edit, features, load, load_spec, simulate, solve3d  # noqa: F401
else:
    from linkedit import edit  # its __init__ imports nothing: stays light

    edit.__class__ = _EditPackage


def __getattr__(name: str) -> Any:
    if name in _NOTEBOOK:
        from linkedit import notebook

        return getattr(notebook, name)
    raise AttributeError(f"module 'linkedit' has no attribute {name!r}")
