"""cornerbif: bifurcation sweeps for impact oscillators with non-smooth forcing.

The system is the one of Budd & Piiroinen, "Corner bifurcations in non-smoothly
forced impact oscillators" (the paper in ``shared/paper``); equation numbers in
docstrings are the paper's.
"""

__version__ = "0.1.0"
FORMAT_VERSION = 1
