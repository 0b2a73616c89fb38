"""The figure kinds of ``cornerbif plot``: one module per ``[plot] kind``, each defining
``FIGURE``, a ``model.FigureKind``: what of a scene it needs (``check``) and how it draws its
files (``draw``).  A kind module's top level loads neither matplotlib nor h5py nor a kernel.

This is the figure kinds' registry: a new kind is its own module and one line in
``FIGURE_MODULES`` (or, from another package, in its entry points: ``plugins``).
"""

from __future__ import annotations

import importlib

from ..plugins import plugins

FIGURE_MODULES = (
    "cornerbif.figures.diagram",
    "cornerbif.figures.timeseries",
    "cornerbif.figures.corner_curves",
    "cornerbif.figures.obstacle",
    "cornerbif.figures.regions",
    "cornerbif.figures.return_map",
    "cornerbif.figures.orbit",
    "cornerbif.figures.fractions",
    "cornerbif.figures.branches",
    "cornerbif.figures.amplitude",
)
# the figure when a scene's [plot] names none
DEFAULT = "diagram"

_KINDS = {}


def registered() -> dict:
    """Every registered figure kind, name -> FigureKind, in registration order."""
    if not _KINDS:
        for path in FIGURE_MODULES + plugins("cornerbif.figures"):
            k = importlib.import_module(path).FIGURE
            _KINDS[k.name] = k
    return _KINDS
