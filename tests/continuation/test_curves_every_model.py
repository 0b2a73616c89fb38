"""Two-parameter curves of corner collisions for every model (issue 31): the maps' and the
two-particle system's through ``continuation.EventCurve`` (the orbit's equations and the
colliding impact's corner distance = 0), checked against a closed form and against the
kernel."""

import numpy as np

import cornerbif
from cornerbif import continuation as C
from cornerbif import theory
from cornerbif.models.map2d import orbit as MO
from cornerbif.models.two_particle import orbit as TO
from cornerbif.models.two_particle import packed as TPM

X0 = [0.18982259867467574, 16.49606490380678, 1.7221809107866082, 149.66189899401783]


def test_the_maps_corner_curve_is_the_word_interval():
    """map2d: the beta fixed point's corner collision continued in omega over
    [1.98, 2.02] lies on the end of theory.word_interval (the exact interval where the
    word's orbit is admissible) to 1e-13."""
    prob, X = MO.map_seed(dict(omega=1.999, kappa=-0.02, r=0.8), "kappa", "b")
    br = C.follow(prob, X, -0.02, (-0.03, 0.03), +1, switch=False, ds=1e-4)[0]
    e = br.events[-1]
    assert e.kind == "corner"
    pts = []
    for d in (+1, -1):
        om, ka, *_ = C.corner_curve(e, "omega", (1.98, 2.02), d)
        pts += list(zip(om, ka))
    assert min(w for w, _ in pts) == 1.98 and max(w for w, _ in pts) == 2.02
    err = max(abs(k - theory.word_interval("b", w - 2.0, 0.8)[1]) for w, k in pts)
    assert err < 1e-13, err


def test_the_two_particle_corner_curve_is_the_1d_continuation_and_the_kernels():
    """two_particle (Fig. 19): omega0_C, where the z-u impact meets the w-z impact,
    continued in r2 over [0.75, 0.85].  At a point of the curve, a one-parameter
    continuation in omega0 at that r2 ends at the same omega0_C (to 1e-11), and the kernel's
    own bisection between the simple word and the period-adding words brackets it to 3e-9
    (measured 1.8e-9 at r2 = 0.837; the one-parameter test at r2 = 0.8 allows 2e-9)."""
    vals = {k: p.default for k, p in TPM.PARAMS.items()} | {"omega0": 2.0}
    prob, X = TO.two_particle_seed(vals, "omega0", X0, 1)
    ev = C.follow(prob, X, 2.0, (1.9995, 2.002), -1, ds=1e-4)[0].events[-1]
    assert ev.kind == "corner"
    r2s, wcs, *_ = C.corner_curve(ev, "r2", (0.75, 0.85), +1)
    assert r2s[-1] == 0.85 and np.all(np.diff(wcs) > 0.0)
    r2, wc = r2s[-3], wcs[-3]
    other = vals | {"r2": r2}
    run = cornerbif.simulate(*X0, transient=2000, record=20, model="two_particle", **other)
    p2, X2 = TO.two_particle_seed(other, "omega0", run["final"][0], 1)
    again = C.follow(p2, X2, 2.0, (1.9995, 2.002), -1, ds=1e-4)[0].events[-1]
    assert again.kind == "corner" and abs(again.lam - wc) < 1e-11
    xs = cornerbif.simulate(1.0, 0.0, 10.0, 0.0, transient=1000, record=60, omega0=wc + 1e-4,
                            r2=r2, model="two_particle")["final"][0]

    def is_b(w):
        q = cornerbif.simulate(*xs, transient=1500, record=80, omega0=w, r2=r2,
                               model="two_particle")
        return q["symbols"][0] == "b"
    lo, hi = wc - 1e-5, wc + 1e-5
    assert not is_b(lo) and is_b(hi)
    while hi - lo > 1e-9:
        m = 0.5 * (lo + hi)
        lo, hi = (lo, m) if is_b(m) else (m, hi)
    assert lo - 3e-9 <= wc <= hi + 3e-9, (wc, lo, hi)
