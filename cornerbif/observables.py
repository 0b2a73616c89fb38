"""What the models declare alike: the per-impact, section and stability datasets of a file
(``Field``s), the cycle series of an impact model's attractors, the particle's state
coordinates u and v, and the cycle analysis every impact model's sweep runs.  Pure
declarations: checking a scene reads them without loading a kernel."""

from __future__ import annotations

from .model import Coord, CycleSeries, Field

IMPACT_FIELDS = (
    Field("impacts/t", "t", "impact time t", "time"),
    Field("impacts/u", "u", "impact height u = z(t)", "length"),
    Field("impacts/v_in", "v_in", "velocity just before impact v-", "length/time"),
    Field("impacts/v_out", "v_out", "velocity just after impact v+ (law 5)", "length/time"),
    Field("impacts/corner_offset", "corner_offset",
          "signed offset of the impact to the nearest corner (t - t_k)", "time"),
)


SECTION_FIELDS = (
    Field("section/u", "su", "u at the Poincare section t = nT"),
    Field("section/v", "sv", "v at the Poincare section t = nT"),
)
STABILITY_FIELDS = (
    Field("stability/multiplier_re", "mu_re", "real part of the Floquet multipliers of the "
          "run's cycle, by decreasing modulus (docs/stability.md)", axis=("multiplier", 2)),
    Field("stability/multiplier_im", "mu_im", "imaginary part of the Floquet multipliers",
          axis=("multiplier", 2)),
    Field("stability/cycle_duration", "cycle_duration", "duration of the cycle", "time",
          axis=()),
    Field("stability/status", "stability_status", "how the multipliers were found: 0 ok, "
          "1 grazing impact (none), 2 the cycle sticks (exactly 0), 3 no cycle (none); "
          "two_particle: 5 a particle sticks (none), 6 the w-z table filled (none)",
          axis=(), dtype="i1", fill=-1),
    Field("stability/lyapunov", "lyapunov", "Lyapunov exponents over the recorded window "
          "(with run.lyapunov_impacts: over that many impacts, streamed), largest first, per "
          "unit time (QR through flights and impacts, docs/stability.md)",
          "1/time", axis=("exponent", 2)),
    Field("stability/lyapunov_window", "lyapunov_window", "time over which the Lyapunov "
          "exponents are averaged (after the warm-up, whole cycles where there is one)",
          "time", axis=()),
    Field("stability/lyapunov_status", "lyapunov_status", "how the exponents were found: 0 "
          "ok, 1 grazing impact (none), 2 the window sticks (-inf), 4 too few impacts, or "
          "the run ended before a streamed window did (none); "
          "two_particle: 5 a particle sticks (none), 6 the w-z table filled (none)",
          axis=(), dtype="i1", fill=-1),
)


def stability_fields(size: int) -> tuple:
    """The stability datasets with ``size`` multipliers and exponents (the state's
    dimension: the two-particle model's 4, a linear system's 2N) in place of the flow's 2."""
    return tuple(Field(f.name, f.source, f.long_name, f.units, axis=(f.axis[0], size),
                       dtype=f.dtype, fill=f.fill) if f.axis else f
                 for f in STABILITY_FIELDS)


# an attractor's identity beside its word: the impact heights and velocities over one cycle
IMPACT_CYCLE = CycleSeries(end="t", a="u", b="v_in", per="impacts", names=("u", "v_in"),
                           long_names=("impact height u", "velocity before impact v-"))
U = Coord("u", (0.0, 20.0), 0, "wall", "initial position u(0)",
          "u at the last section crossed (the state a followed sweep carries on)")
V = Coord("v", (-20.0, 20.0), 1, None, "initial velocity v(0)", "v at the last section crossed")


# the cycle analysis and the file's chunk writer: every sweep of the flow and two-particle
# models calls them
ANALYSIS_KERNELS = ("analysis.detect_cycles", "analysis.cycle_signatures",
                    "chunkwrite._shuffle_bytes", "numerics.fill._fill")
# the part of it that ``Model.run_items`` calls (``cornerbif.simulate``: no file)
RUN_ANALYSIS_KERNELS = ("analysis.detect_cycles", "numerics.fill._fill")
# their cold compile, in seconds, measured by ``python benchmarks/compile_time.py``
ANALYSIS_SECONDS = 1.7
