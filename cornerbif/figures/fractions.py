"""``[plot] kind = "fractions"``: the share of the starts reaching each attractor against the
one swept parameter (``plot_diagram.figure_diagram``, from the file's attractor table)."""

from ..model import IC_PREFIX
from .diagram import Diagram


class Fractions(Diagram):
    shares = True

    def check(self, w):
        if len(w.axes) == 1 and not w.axes[0].name.startswith(IC_PREFIX):
            return []
        return ["plot.kind: 'fractions' draws the share of the starts reaching each attractor "
                "against one swept parameter; this scene sweeps "
                + (", ".join(a.name for a in w.axes) or "nothing")]


FIGURE = Fractions("fractions", "basin fractions against one swept parameter", files="one",
                   one_axis=True)
