"""``[plot] kind = "regions"`` (Fig. 9): the starts x0 = (a0, b1) of a scene without sweep axes,
coloured by the map that acts on them (``plot_normal_form``)."""

from .normal_form import NormalFormKind

FIGURE = NormalFormKind("regions", "the starts coloured by the map acting on them (Fig. 9)",
                        files="single_runs", same_starts=True, drawer="figure_regions")
