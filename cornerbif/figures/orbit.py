"""``[plot] kind = "orbit"`` (Fig. 11): the recorded section points (a_n, b_n) of each start,
with Sigma_1, the beta fixed point and its image marked (``plot_normal_form``)."""

from .normal_form import NormalFormKind

FIGURE = NormalFormKind("orbit", "the recorded section points in the (a, b) plane (Fig. 11)",
                        files="single_runs", drawer="figure_orbits",
                        needs_keep=("section",))
