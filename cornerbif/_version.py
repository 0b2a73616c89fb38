"""The package's version and its file format's version (``cornerbif.__version__``,
``cornerbif.FORMAT_VERSION``), in a module of their own so that the modules that stamp them
into a file need not import the package's ``__init__``."""

__version__ = "0.1.0"
FORMAT_VERSION = 1
