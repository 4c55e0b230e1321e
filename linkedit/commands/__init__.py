"""One module per CLI command; each has ``register(app)``. Heavy imports stay inside commands."""
