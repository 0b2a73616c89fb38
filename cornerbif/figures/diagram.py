"""``[plot] kind = "diagram"`` (the default): a file's recorded values against its one swept
parameter (a bifurcation diagram, files overlaid, continuation branches over it), its chart
over two swept parameters, or its basin over two swept start coordinates
(``plot_diagram.figure_diagram``)."""

from ..model import FigureKind


class Diagram(FigureKind):
    shares = False          # the fractions kind: the shares of the starts, not a diagram

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
        from ..plot_diagram import figure_diagram
        return figure_diagram(plt, datas, out, y, title, plot_cfg, color_by, branches,
                              shares=self.shares)


FIGURE = Diagram("diagram", "a diagram, a chart or a basin", colors_by=True)
