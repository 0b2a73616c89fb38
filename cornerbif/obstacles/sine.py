"""The smooth wall of section 2.2: z = kappa + beta sin(omega t), period 2 pi / omega, no
corners.  Split at its half periods into 2 pieces (no corner there, but the sign of z'' is
fixed on each half, which tightens the certified search's bound); its jitted pieces are the
``SINE`` branches of ``obstacles/dispatch.py``."""

from ..model import Obstacle


def resonant_amplitude(r: float, beta: float = 1.0) -> float:
    """b = 2 beta (1 + r)/(1 - r): the orbit u = b |sin t| of the smooth wall at omega = 2, eq (6)."""
    return 2.0 * beta * (1.0 + r) / (1.0 - r)


class Sine(Obstacle):
    def resonant_amplitude(self, values):
        """At omega = 2, kappa = 0 with k = 1, no damping and no forcing: the orbit u = b |sin t|
        of eq (6) (``resonant_amplitude``)."""
        if not (values["omega"] == 2.0 and values["kappa"] == 0.0 and values.get("sigma", 0.0) == 0.0
                and values.get("k", 1.0) == 1.0 and values.get("F", 0.0) == 0.0):
            return None
        return resonant_amplitude(values["r"], values["beta"])


OBSTACLE = Sine("sine", 0, "kappa + beta sin(omega t) (section 2.2, no corners)", period_pi=2,
                pieces=2, corners=False)
