"""Obstacles z(t) of the ``flow`` model: one module per kind (``sine``, ``rectified_sine``,
``triangle``, ``profile``), each defining ``OBSTACLE``, a ``model.Obstacle``: its declaration
and its Python side; ``dispatch``, the jitted switch over their codes, the only place that
reads a code.

This is the obstacles' registry: a new kind is its own module and one line in
``OBSTACLE_MODULES`` (or, from another package, in its entry points: ``plugins``).
"""

from __future__ import annotations

import importlib

from ..plugins import plugins

OBSTACLE_MODULES = (
    "cornerbif.obstacles.sine",
    "cornerbif.obstacles.rectified_sine",
    "cornerbif.obstacles.triangle",
    "cornerbif.obstacles.profile",
)
# the flow model's obstacle when a scene names none: the paper's, eq (8)
DEFAULT = "rectified_sine"
# the kind a still obstacle z = kappa (a linear contact's fixed stop) is packed as, with beta = 0
STILL = "sine"

_KINDS = {}


def registered() -> dict:
    """Every registered obstacle kind, name -> Obstacle, in registration order (each code
    unique)."""
    if not _KINDS:
        for path in OBSTACLE_MODULES + plugins("cornerbif.obstacles"):
            o = importlib.import_module(path).OBSTACLE
            _KINDS[o.name] = o
    return _KINDS
