"""The model registry: one object per model (``cornerbif.model.Model``).

A new model is its own folder (``models/<name>/``) and one line in ``MODEL_MODULES``.  The
obstacle kinds and the figure kinds have registries of their own, each the ``__init__`` of
their package (``obstacles.registered``, ``figures.registered``), so that loading one kind of
plug-in never loads a module that imports its registry (no cycle, the loads included).
Nothing else in the package names a model, an obstacle or a figure kind
(docs/architecture.md).
"""

from __future__ import annotations

import importlib

from .plugins import plugins

# each module defines MODEL, a cornerbif.model.Model instance
MODEL_MODULES = (
    "cornerbif.models.flow.model",
    "cornerbif.models.map2d.model",
    "cornerbif.models.two_particle.model",
    "cornerbif.models.linear.model",
)

_MODELS = {}


def models() -> dict:
    """Every registered model, name -> Model, in registration order: this package's
    (``MODEL_MODULES``), then the installed plug-ins' (``plugins``)."""
    if not _MODELS:
        for path in MODEL_MODULES + plugins("cornerbif.models"):
            m = importlib.import_module(path).MODEL
            _MODELS[m.name] = m
    return _MODELS


def names() -> tuple:
    return tuple(models())


def get(name: str):
    """The model called ``name`` (KeyError if there is none)."""
    return models()[name]


DEFAULT_MODEL = "flow"
