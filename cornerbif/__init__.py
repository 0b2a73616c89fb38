"""cornerbif: bifurcation sweeps for impact oscillators with non-smooth forcing.

The system is the one of Budd & Piiroinen, "Corner bifurcations in non-smoothly
forced impact oscillators"; equation numbers in docstrings are the paper's (README.md cites
it; docs/discrepancies.md lists where this code departs from its printed formulas).

Public entry points: ``simulate`` (any model from Python), ``load_scene``
(a scene file -> ``Scene``), ``run_sweep`` (a scene to its HDF5 file), ``explore`` (a
file's diagram as a Panel app, for Jupyter; the ``explore`` extra), and the model
registry in ``cornerbif.registry``.  See README.md.
"""

from ._version import FORMAT_VERSION, __version__
from .errors import SweepError

__all__ = ["simulate", "load_scene", "run_sweep", "explore", "Scene", "SceneError",
           "SweepError", "__version__", "FORMAT_VERSION"]


def __getattr__(name):
    # lazy, for start-up: importing the package pulls in neither numba nor h5py
    if name == "simulate":
        from .api import simulate  # start-up: the models' registry and numpy
        return simulate
    if name == "load_scene":
        from .config import load  # start-up: the registries
        return load
    if name == "run_sweep":
        from .sweep import run_sweep  # start-up: loads h5py
        return run_sweep
    if name == "explore":
        from .explorer.session import app  # optional: the explore extra (Panel, HoloViews)
        return app
    if name in ("Scene", "SceneError"):
        from . import config  # start-up: the registries
        return getattr(config, name)
    raise AttributeError(f"module 'cornerbif' has no attribute {name!r}")
