"""Result files: HDF5 (one versioned layout per kind) and SVG pictures."""
