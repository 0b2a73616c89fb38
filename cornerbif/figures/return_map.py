"""``[plot] kind = "return_map"`` (Fig. 10): A0, the section value one period T = 2 pi / omega
after each start, against a0 = u(0), for starts on a line b1 = const (``plot_normal_form``)."""

from .normal_form import NormalFormKind


class ReturnMap(NormalFormKind):
    def check(self, w):
        problems = super().check(w)
        if w.run_setting("transient") != 0:
            problems.append("plot.kind: 'return_map' needs run.transient = 0 (A0 is the first "
                            "section value after the start)")
        return problems


FIGURE = ReturnMap("return_map", "the first return A0 against a0 (Fig. 10)",
                   files="single_runs", drawer="figure_return_maps",
                   needs_keep=("section",))
