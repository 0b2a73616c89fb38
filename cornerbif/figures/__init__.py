"""The figure kinds of ``cornerbif plot``: one module per ``[plot] kind`` (registered in
``registry.FIGURE_MODULES``), each defining ``FIGURE``, a ``model.FigureKind``: what of a scene
it needs (``check``) and how it draws its files (``draw``)."""
