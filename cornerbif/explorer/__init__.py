"""``cornerbif explore``: a sweep's diagram in the browser (docs/explore.md).

A Panel app on a Bokeh server bound to 127.0.0.1 with a token in its URL (``server``): the
file's every point (or cell, ``chart``) drawn by Datashader at screen resolution
(``points``), a refine of the visible window swept in the background into a side file, the
orbit of a clicked point recomputed and continued from (``jobs``, ``orbit``), the view saved
as a scene or a figure (``app``); ``session.app`` is ``cornerbif.explore``.  Needs the
optional extra: ``pip install "cornerbif[explore]"``."""
