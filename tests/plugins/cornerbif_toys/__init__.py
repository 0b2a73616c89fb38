"""Plug-ins of cornerbif from outside its package (the extension recipes of
docs/architecture.md, proven by tests/architecture/test_extension_recipes.py): a model with its own orbit
problem and tangent (``rotation``) and an obstacle kind (``trapezoid``), registered by the
entry points of this package's metadata alone."""
