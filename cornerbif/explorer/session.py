"""A session's page: a diagram's (``app.Explorer``) or a chart's (``chart.ChartPage``), and
``cornerbif.explore``, the same page in Jupyter."""

from __future__ import annotations

import tempfile

from .app import Explorer, Files
from .chart import ChartPage
from .points import Chart


def page_for(files: Files, k: int = 0):
    """The page of file ``k`` of ``files``: a chart's when it sweeps two axes, else a
    diagram's."""
    return ChartPage(files, k) if isinstance(files.get(k), Chart) else Explorer(files, k)


def app(path_or_files, side_dir=None, k: int = 0):
    """The explorer's page over a file (a path) or a server's ``Files``: a Panel object
    (in Jupyter, displayed as it is)."""
    if isinstance(path_or_files, Files):
        files = path_or_files
    else:
        files = Files([path_or_files], side_dir or tempfile.mkdtemp(prefix="cornerbif-explore-"))
    return page_for(files, k).view()
