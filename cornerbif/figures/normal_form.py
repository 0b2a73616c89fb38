"""What the three figure kinds of the corner normal form share (``regions``, ``return_map``,
``orbit``: sections 4-5, Figs 9-11): single runs of a scene without sweep axes, of a model
that is a side of the normal form (``Model.normal_form``), drawn by ``plot_normal_form``."""

from dataclasses import dataclass

from .. import registry
from ..model import FigureKind


def normal_form_needs() -> str:
    """Which models (and obstacles) the (a0, b1)-plane figures accept, in words."""
    parts = []
    sides = [m for m in registry.models().values() if m.normal_form is not None]
    for m in sorted(sides, key=lambda m: not m.normal_form.maps):
        if m.normal_form.maps:
            parts.append(f"model {m.name!r}")
        else:
            obs = [o for o, d in m.obstacles.items() if d.normal_form]
            parts.append(f"{m.name!r} with obstacle " + " or ".join(repr(o) for o in obs))
    return " or ".join(parts)


@dataclass(frozen=True)
class NormalFormKind(FigureKind):
    drawer: str = ""    # the function of ``plot_normal_form`` that draws this kind
    needs_keep: tuple = ()      # the observables it reads from the file (``output.keep``)

    def check(self, w):
        problems = []
        for k in self.needs_keep:
            if k not in w.keep:
                problems.append(f"plot.kind: {self.name!r} draws the recorded {k} values; "
                                f"output.keep must contain {k!r}")
        if not w.spec.has_normal_form(w.obstacle):
            problems.append(f"plot.kind: {self.name!r} draws the corner normal form of z = kappa "
                            f"+ beta |sin omega t| (sections 4-5): it needs {normal_form_needs()} "
                            f"(this scene: model {w.model!r}"
                            + (f", obstacle {w.obstacle!r}" if w.spec.obstacles else "") + ")")
        if w.axes:
            problems.append(f"plot.kind: {self.name!r} draws a scene without sweep axes; this "
                            f"one sweeps {', '.join(a.name for a in w.axes)}")
        return problems

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
        from .. import plot_normal_form
        return plot_normal_form.figure(datas, out, plot_cfg, title,
                                       getattr(plot_normal_form, self.drawer))
