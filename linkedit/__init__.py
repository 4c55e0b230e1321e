"""linkedit: design planar and spatial mechanisms.

Layers (no module imports "upwards"): ``spec`` (validated input models) →
``planar`` / ``gcs`` / ``curves`` (array code) → ``edit`` (optimization) →
``io`` (HDF5, SVG) → ``cli`` (the command line).
"""

__version__ = "0.1.0"
