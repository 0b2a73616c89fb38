"""The registries: one object per model (``cornerbif.model.Model``), one per obstacle kind of
the ``flow`` model (``cornerbif.model.Obstacle``) and one per figure kind of ``cornerbif plot``
(``cornerbif.model.FigureKind``).

A new model is its own folder (``models/<name>/``) and one line in ``MODEL_MODULES``; a new
obstacle kind is its own module (``obstacles/<name>.py``) and one line in
``OBSTACLE_MODULES``; a new figure kind its own module (``figures/<name>.py``) and one line in
``FIGURE_MODULES``.  Nothing else in the package names a model or an obstacle
(docs/architecture.md).
"""

from __future__ import annotations

import importlib

# each module defines MODEL, a cornerbif.model.Model instance
MODEL_MODULES = (
    "cornerbif.models.flow.model",
    "cornerbif.models.map2d.model",
    "cornerbif.models.two_particle.model",
)

# each module defines OBSTACLE, a cornerbif.model.Obstacle instance (its code unique)
OBSTACLE_MODULES = (
    "cornerbif.obstacles.sine",
    "cornerbif.obstacles.rectified_sine",
    "cornerbif.obstacles.triangle",
    "cornerbif.obstacles.profile",
)

# each module defines FIGURE, a cornerbif.model.FigureKind instance: one per [plot] kind
FIGURE_MODULES = (
    "cornerbif.figures.diagram",
    "cornerbif.figures.timeseries",
    "cornerbif.figures.corner_curves",
    "cornerbif.figures.obstacle",
    "cornerbif.figures.regions",
    "cornerbif.figures.return_map",
    "cornerbif.figures.orbit",
    "cornerbif.figures.fractions",
)

_MODELS = {}
_OBSTACLES = {}
_FIGURES = {}


def figures() -> dict:
    """Every registered figure kind, name -> FigureKind, in registration order."""
    if not _FIGURES:
        for path in FIGURE_MODULES:
            k = importlib.import_module(path).FIGURE
            _FIGURES[k.name] = k
    return _FIGURES


def obstacles() -> dict:
    """Every registered obstacle kind, name -> Obstacle, in registration order."""
    if not _OBSTACLES:
        for path in OBSTACLE_MODULES:
            o = importlib.import_module(path).OBSTACLE
            _OBSTACLES[o.name] = o
    return _OBSTACLES


def models() -> dict:
    """Every registered model, name -> Model, in registration order."""
    if not _MODELS:
        for path in MODEL_MODULES:
            m = importlib.import_module(path).MODEL
            _MODELS[m.name] = m
    return _MODELS


def names() -> tuple:
    return tuple(models())


def get(name: str):
    """The model called ``name`` (KeyError if there is none)."""
    return models()[name]


DEFAULT_MODEL = "flow"
# the flow model's obstacle when a scene names none: the paper's, eq (8)
DEFAULT_OBSTACLE = "rectified_sine"
