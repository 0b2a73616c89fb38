"""Models, obstacle kinds and figure kinds from outside the package: the modules installed
packages register in the entry-point groups ``cornerbif.models``, ``cornerbif.obstacles`` and
``cornerbif.figures``, read by the three registries (``registry``, ``obstacles``,
``figures``)."""

from __future__ import annotations

import functools
from importlib.metadata import entry_points


def plugins(group: str) -> tuple:
    """The modules that installed packages register in the entry-point ``group``
    (``cornerbif.models``, ``cornerbif.obstacles``, ``cornerbif.figures``): a model, an
    obstacle kind or a figure kind from outside this package is one line of its own
    package's metadata, e.g. in its pyproject.toml::

        [project.entry-points."cornerbif.models"]
        my_model = "my_package.my_model"
    """
    return tuple(e.value for e in _installed().select(group=group))


@functools.cache
def _installed():
    """The installed packages' entry points, read once (the three registries ask in turn)."""
    return entry_points()
