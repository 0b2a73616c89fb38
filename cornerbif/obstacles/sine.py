"""The smooth wall of section 2.2: z = kappa + beta sin(omega t), period 2 pi / omega, no
corners.  Split at its half periods into 2 pieces (no corner there, but the sign of z'' is
fixed on each half, which tightens the certified search's bound); its jitted pieces are the
``SINE`` branches of ``obstacles/dispatch.py``."""

from ..model import Obstacle


class Sine(Obstacle):
    def resonant_amplitude(self, values):
        """At omega = 2, kappa = 0 with k = 1, no damping and no forcing the orbit
        u = 2 beta (1 + r)/(1 - r) |sin t| of eq (6) (``theory.resonant_amplitude``)."""
        if not (values["omega"] == 2.0 and values["kappa"] == 0.0 and values.get("sigma", 0.0) == 0.0
                and values.get("k", 1.0) == 1.0 and values.get("F", 0.0) == 0.0):
            return None
        from ..theory import resonant_amplitude  # (theory loads numba: checks stay numba-free)
        return resonant_amplitude(values["r"], values["beta"])


OBSTACLE = Sine("sine", 0, "kappa + beta sin(omega t) (section 2.2, no corners)",
                    period_pi=2, pieces=2, corners=False)
