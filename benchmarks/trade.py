"""The speed-accuracy trade, measured: sections of ``benchmarks/run.py``.

* ``bench_transient``: transient length against the error of the drawn diagram;
* ``bench_map_vs_flow``: map2d against flow as a function of the distance from
  (omega, kappa) = (2, 0), and the cost of each;
* ``bench_chatter``: the chattering threshold against the error in the accumulation
  time (mpmath reference) and against cost;
* ``bench_profile``: where the time of a Fig. 4(c) sweep goes (stages, and inside the
  flow kernel by counted operations times measured unit costs).

Each function returns plain dicts/lists (JSON) and has a ``plot_*`` companion.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


# ------------------------------------------------------------------ helpers
def _flow_scene(axes, run, system=None, count=4, seed=1, keep=("impacts",)):
    from cornerbif import config
    raw = {"scene": {"name": "bench", "model": "flow"},
           "system": {"obstacle": "rectified_sine", "omega": 1.999, "kappa": 0.0, "r": 0.8,
                      **(system or {})},
           "sweep": {k: {"values": [float(x) for x in v]} for k, v in axes.items()},
           "initial": {"count": count, "seed": seed},
           "run": run, "output": {"keep": list(keep)}}
    return config.from_dict(raw)


def _run_scene(scene, ics=None, tile=1):
    """All items of a one-axis scene through ``sweep.run_items`` (the sweep's own path).

    Returns (out, status, period, words, seconds per item (one thread), ics) with items
    ordered (grid point, start).
    """
    try:
        from cornerbif import engine as sweep
    except ImportError:  # a tree from before the engine split (benchmarks/ab.py compares trees)
        from cornerbif import sweep
    from cornerbif.analysis import words
    from cornerbif.models.flow import packed as P
    n_pts = scene.shape[0]
    idx = [(i,) for i in range(n_pts)]
    params = sweep.pack_points(scene, idx)
    if ics is None:
        kap = np.full(n_pts, -np.inf) if scene.model == "map2d" else params[:, P.KAPPA]
        ics = sweep.draw_initial(scene, np.arange(n_pts), kap)
        ics = ics.reshape(-1, ics.shape[-1])
    prm = np.repeat(params, scene.n_ic, axis=0)
    ics = np.ascontiguousarray(ics)
    ints = sweep.int_settings(scene)
    out, st, final, period, ipc, sym = sweep.run_items(prm, ics, ints, scene)
    dt = _seconds_per_item(prm, ics, ints, scene, tile)
    return out, st, period, words(sym), dt, ics


def _seconds_per_item(prm, ics, ints, scene, tile=1, repeat=2):
    """Best-of-``repeat`` seconds per item of ``sweep.run_items`` on one thread, the items
    tiled ``tile`` times (a few dozen items are too few to time on a shared machine)."""
    import numba

    try:
        from cornerbif import engine as sweep
    except ImportError:  # a tree from before the engine split (benchmarks/ab.py compares trees)
        from cornerbif import sweep
    P2 = np.ascontiguousarray(np.tile(prm, (tile, 1)))
    I2 = np.ascontiguousarray(np.tile(ics, (tile, 1)))
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        best = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            sweep.run_items(P2, I2, ints, scene)
            best = min(best, time.perf_counter() - t0)
    finally:
        numba.set_num_threads(old)
    return best / len(P2)


def _time_kernel(params, ics, record, transient=0, repeat=3):
    """Best-of-``repeat`` seconds of ``models.flow.kernel.run_batch`` alone on these items."""
    from cornerbif.models.flow import packed as P
    from cornerbif.models.flow.kernel import run_batch
    n = params.shape[0]
    ints = np.zeros(P.NINT, np.int64)
    ints[P.I_TRANSIENT] = transient
    ints[P.I_RECORD] = record
    ints[P.I_MAX_EVENTS] = 10 * (transient + record) + 1000
    ints[P.I_MAX_PIECES] = 8
    o = [np.full((n, record), np.nan) for _ in range(5)]
    corner = np.zeros((n, record), np.int64)
    su, sv = np.full((n, record), np.nan), np.full((n, record), np.nan)
    st = np.zeros(n, np.int8)
    final = np.zeros((n, 2))
    rec0 = np.zeros(n, np.int64)        # number of the first recorded impact (early stop)
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        run_batch(params, ints, ics, *o, corner, su, sv, st, final, rec0)
        best = min(best, time.perf_counter() - t0)
    return best


def _per_point(a, n_pts):
    return a.reshape((n_pts, -1) + a.shape[1:])


# ------------------------------------------------------------------ 1. transient
def transient_cases(smoke):
    from cornerbif import theory
    kc = theory.kappa_C(1.999, 0.8)
    n = 8 if smoke else 40
    dk = np.logspace(-7, -3, n // 2)
    return {
        # kappa across kappa_C at distances 1e-7 ... 1e-3: the beta fixed point on the left,
        # beta^N gamma orbits with N ~ log(kappa - kappa_C) / log(r) on the right (5.4)
        "near corner (omega = 1.999, |kappa - kappa_C| in [1e-7, 1e-3])":
            ({"kappa": kc + np.concatenate([-dk[::-1], dk])}, {"omega": 1.999}),
        # the same omega, kappa well inside the period-one (beta) range
        "far in kappa (omega = 1.999, kappa in [-0.03, -0.02])":
            ({"kappa": np.linspace(-0.03, -0.02, n)}, {"omega": 1.999}),
        # the Fig. 4(c) scene: omega in [1.5, 2.5], kappa = 0
        "Fig. 4(c) (kappa = 0, omega in [1.5, 2.5])":
            ({"omega": np.linspace(1.5, 2.5, n)}, {"kappa": 0.0}),
    }


def bench_transient(smoke=False):
    """Transient T against the diagram error: Hausdorff distance per parameter point between
    the impact heights recorded after T impacts and after T_ref (same starts), and the share
    of runs whose attractor word (period, symbols) differs from the reference's.

    Returns {case: {"T_ref", "record", "rows": [{T, median, p90, max, word_wrong, period_wrong,
    seconds_per_item}]}}.
    """
    from cornerbif.plot_diagram import hausdorff_per_point
    Ts = [0, 20, 100, 300, 1000] if smoke else [0, 10, 30, 100, 300, 500, 1000, 3000]
    T_ref = 3000 if smoke else 20000
    record = 200
    count = 2 if smoke else 4
    res = {}
    for name, (axes, system) in transient_cases(smoke).items():
        n_pts = len(next(iter(axes.values())))
        ref_scene = _flow_scene(axes, {"transient": T_ref, "record": record}, system, count)
        rout, rst, rper, rwords, _, ics = _run_scene(ref_scene)
        ref_u = _per_point(rout["u"], n_pts)
        rows = []
        for T in Ts:
            sc = _flow_scene(axes, {"transient": T, "record": record}, system, count)
            out, st, per, words, dt, _ = _run_scene(sc, ics, tile=1 if smoke else 2)
            d = hausdorff_per_point(_per_point(out["u"], n_pts), ref_u, decimals=13)
            d = np.where(np.isnan(d), np.inf, d)
            # a run's attractor is "right" when its word and period equal the reference run's
            wrong_w = np.mean([w != rw for w, rw in zip(words, rwords)])
            wrong_p = float(np.mean(per != rper))
            rows.append({"T": T, "median": float(np.median(d)),
                         "p90": float(np.quantile(d, 0.9)), "max": float(np.max(d)),
                         "word_wrong": float(wrong_w), "period_wrong": wrong_p,
                         "seconds_per_item": dt})
        res[name] = {"T_ref": T_ref, "record": record, "points": n_pts, "starts": count,
                     "ref_periodic_share": float(np.mean(rper > 0)),
                     "ref_status_ok": float(np.mean(rst == 0)), "rows": rows}
    return res


def plot_transient(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4), dpi=120)
    for name, c in res.items():
        T = [max(r["T"], 1) for r in c["rows"]]
        line, = ax[0].loglog(T, [max(r["max"], 1e-17) for r in c["rows"]], "o-",
                             label=name, ms=3)
        ax[0].loglog(T, [max(r["median"], 1e-17) for r in c["rows"]], "--",
                     color=line.get_color(), lw=0.8)
        ax[1].semilogx(T, [100 * r["word_wrong"] for r in c["rows"]], "o-", ms=3,
                       color=line.get_color())
    ax[0].set_xlabel("run.transient (impacts; 0 drawn at 1)")
    ax[0].set_ylabel("Hausdorff distance to reference\n(max solid, median dashed; 0 at 1e-17)")
    ax[0].legend(fontsize=6)
    ax[1].set_xlabel("run.transient")
    ax[1].set_ylabel("% runs with a wrong word")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ------------------------------------------------------------------ 2. map2d against flow
def _pair_scenes(omega, kappas, delta, transient, record, count):
    """The same (omega, kappa) points as a flow scene and a map2d scene (epsilon = 1)."""
    from cornerbif import config
    common = {"sweep": {"kappa": {"values": [float(k) for k in kappas]}},
              "run": {"transient": transient, "record": record},
              "output": {"keep": ["section"]}}
    flow = config.from_dict({"scene": {"name": "cmp", "model": "flow"},
                             "system": {"omega": omega, "r": 0.8},
                             "initial": {"count": count, "seed": 3, "u": [0.0, 20.0],
                                         "v": [-20.0, 20.0]}, **common})
    # map starts: a near a_beta* = 18, b of the order of the iterates (~ kappa)
    bmax = 20.0 * delta
    mp = config.from_dict({"scene": {"name": "cmp", "model": "map2d"},
                           "system": {"omega": omega, "r": 0.8},
                           "initial": {"count": count, "seed": 3, "u": [14.0, 20.0],
                                       "v": [-bmax, bmax]}, **common})
    return flow, mp


def _flow_word(kappa, omega, transient=4000, record=240):
    from cornerbif.sweep import simulate
    res = simulate([16.0, 18.5], [0.0, 0.0], transient=transient, record=record, omega=omega,
                   kappa=kappa, r=0.8)
    s = set(res["symbols"])
    return s.pop() if len(s) == 1 else ""


def _shared_attractor_distance(fsv, fwords, msv, mwords, n, count):
    """Per grid point: the largest Hausdorff distance between the flow's v(nT) and the map's
    b_n over the attractors (words) both models reached there (NaN if none is shared), and
    whether the two sets of words differ (a coexisting attractor found by one model's starts
    only: a question of basins, not of the map's accuracy)."""
    from cornerbif.plot_diagram import hausdorff_per_point
    dist = np.full(n, np.nan)
    differ = np.zeros(n, bool)
    for i in range(n):
        sl = slice(i * count, (i + 1) * count)
        fw, mw = list(fwords[sl]), list(mwords[sl])
        differ[i] = set(fw) != set(mw)
        for w in set(fw) & set(mw) - {""}:
            a = fsv[sl][[x == w for x in fw]]
            b = msv[sl][[x == w for x in mw]]
            d = hausdorff_per_point(a.reshape(1, -1), b.reshape(1, -1), decimals=13)[0]
            dist[i] = np.nanmax([dist[i], d])
    return dist, differ


def ray_ratios(sign, n):
    """kappa / (omega - 2) along a ray.  omega < 2: Fig. 16's range [12, 14.2] (kappa between
    kappa_C and kappa_CC, beta^N gamma and alpha words); omega > 2: outside the hysteresis
    band [kappa_CC, kappa_C] (eqs 11, 17) of the one- and two-impact orbits."""
    if sign < 0:
        return np.linspace(12.0, 14.2, n)
    h = n // 2
    return np.concatenate([np.linspace(0.5, 2.8, h), np.linspace(14.5, 17.0, n - h)])


def bench_map_vs_flow(smoke=False):
    """map2d against flow along rays omega - 2 = +-delta, kappa = c (omega - 2).

    Per delta: the Hausdorff distance between the flow's section values v(nT) and the
    map's b_n at each point, on the attractors both reached (max and median over the
    points of the ray; also divided by delta, the scale of b), the share of points where
    the two models' starts found different sets of attractors, the ends of the
    beta^N gamma plateaus (map: theory.word_interval, exact for the maps; flow: bisection
    with the flow as judge, plateaus.refine_edge) and the cost per parameter point.
    """
    from cornerbif import theory
    from cornerbif.plateaus import refine_edge
    deltas = [1e-3, 1e-2] if smoke else [1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2]
    n = 4 if smoke else 12
    count = 2
    transient, record = (300, 60) if smoke else (3000, 240)
    Ns = [5] if smoke else [5, 12]
    rows = []
    for sign in (-1, 1):
        for delta in deltas:
            omega = 2.0 + sign * delta
            kap = ray_ratios(sign, n) * (omega - 2.0)
            fs, ms = _pair_scenes(omega, kap, delta, transient, record, count)
            fo, fst, fper, fw, ft, _ = _run_scene(fs, tile=1 if smoke else 4)
            mo, mst, mper, mw, mt, _ = _run_scene(ms, tile=10 if smoke else 200)
            ft, mt = ft * count, mt * count             # per grid point (all its starts)
            dist, differ = _shared_attractor_distance(fo["sv"], fw, mo["sv"], mw, n, count)
            row = {"sign": sign, "delta": delta, "omega": omega, "points": n,
                   "b_dist_max": float(np.nanmax(dist)) if np.isfinite(dist).any() else None,
                   "b_dist_median": float(np.nanmedian(dist)) if np.isfinite(dist).any()
                   else None,
                   "b_rel_max": float(np.nanmax(dist) / delta) if np.isfinite(dist).any()
                   else None,
                   "word_mismatch": float(np.mean(differ)),
                   "flow_ok": float(np.mean(fst == 0)), "map_ok": float(np.mean(mst == 0)),
                   "flow_seconds_per_point": ft, "map_seconds_per_point": mt,
                   "cost_ratio": ft / mt, "plateaus": []}
            if sign < 0:
                for N in Ns:
                    word = "b" * N + "g"
                    lo, hi = theory.word_interval(word, omega - 2.0, 0.8)
                    mid = 0.5 * (lo + hi)
                    w = hi - lo
                    pl = {"word": f"b^{N}g", "map_lo": lo, "map_hi": hi}
                    ftr = 1000 if smoke else 4000
                    if _flow_word(mid, omega, ftr) != word:
                        pl["flow_lo"] = pl["flow_hi"] = None
                        pl["note"] = "the flow has another word at the map's plateau centre"
                    else:
                        judge = lambda k, omega=omega, ftr=ftr: _flow_word(k, omega, ftr)  # noqa: E731
                        tol = (1e-3 if smoke else 1e-7) * w
                        pl["flow_lo"] = refine_edge(judge, mid, lo - w, word, tol)
                        pl["flow_hi"] = refine_edge(judge, mid, hi + w, word, tol)
                        pl["end_error"] = max(abs(pl["flow_lo"] - lo), abs(pl["flow_hi"] - hi))
                        pl["end_error_rel_width"] = pl["end_error"] / w
                    row["plateaus"].append(pl)
            rows.append(row)
    return {"transient": transient, "record": record, "starts": count, "rows": rows}


def plot_map_vs_flow(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4), dpi=120)
    for sign, mk in ((-1, "o-"), (1, "s--")):
        rows = [r for r in res["rows"] if r["sign"] == sign]
        d = [r["delta"] for r in rows]
        lab = "omega < 2" if sign < 0 else "omega > 2"
        ax[0].loglog(d, [max(r["b_dist_max"] or np.nan, 1e-17) for r in rows], mk, ms=3,
                     label=f"b: max distance, {lab}")
        if sign < 0:
            for N in sorted({p["word"] for r in rows for p in r["plateaus"]}):
                e = [next((p.get("end_error") for p in r["plateaus"] if p["word"] == N), None)
                     for r in rows]
                ok = [(x, y) for x, y in zip(d, e) if y is not None]
                if ok:
                    ax[0].loglog(*zip(*ok), "^:", ms=3, label=f"plateau ends {N} (kappa)")
        ax[1].loglog(d, [r["cost_ratio"] for r in rows], mk, ms=3, label=lab)
    ax[0].set_xlabel("|omega - 2| (kappa = c (omega - 2))")
    ax[0].set_ylabel("map error")
    ax[0].legend(fontsize=6)
    ax[1].set_xlabel("|omega - 2|")
    ax[1].set_ylabel("cost per point: flow / map2d")
    ax[1].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ------------------------------------------------------------------ 3. chattering threshold
CHATTER_KAPPA = 1.0   # sine obstacle z = kappa + beta sin(omega t), beta = 1, k = 1: the contact
CHATTER_BETA = 1.0    # force N = kappa + beta (1 - omega^2) sin(omega t) > 0 for omega < 1


def chatter_reference(omega, r, w0, dps=60, w_stop=1e-20):
    """Accumulation time of the chattering sequence that starts at t = 0 on the obstacle
    z = kappa + sin(omega t) with relative velocity w0 (u'' = -u, law (5)), in mpmath.

    Every impact is located on the exact free flight u(t) = u_i cos(t - t_i) + v_i sin(t - t_i)
    with ``dps`` digits until the relative velocity falls below ``w_stop``; the rest of the
    sequence (w_stop / (1 - r) long in velocity) is summed with the constant-force formula,
    whose error is O(w_stop^2) (here ~1e-40).  Independent of the engine.
    """
    import mpmath as mp
    mp.mp.dps = dps
    om, kap, be, r = mp.mpf(omega), mp.mpf(CHATTER_KAPPA), mp.mpf(CHATTER_BETA), mp.mpf(r)
    z = lambda t: kap + be * mp.sin(om * t)                         # noqa: E731
    zp = lambda t: be * om * mp.cos(om * t)                         # noqa: E731
    N = lambda t: kap + be * (1 - om * om) * mp.sin(om * t)          # noqa: E731
    t = mp.mpf(0)
    w = mp.mpf(w0)
    n = 0
    while w > w_stop:
        u, v = z(t), zp(t) + w
        g = lambda s, u=u, v=v, t=t: u * mp.cos(s) + v * mp.sin(s) - z(t + s)      # noqa: E731
        guess = 2 * w / N(t)
        lo, hi = guess / 2, guess * 1.5
        while g(hi) > 0:
            hi *= 1.5
        assert g(lo) > 0
        s = mp.findroot(g, (lo, hi), solver="anderson")
        t = t + s
        vin = u * (-mp.sin(s)) + v * mp.cos(s)
        w = r * (zp(t) - vin)        # law (5): v+ - z' = -r (v- - z')
        n += 1
    t_acc = t + 2 * w / (N(t) * (1 - r))
    return float(t_acc), n


def bench_chatter(smoke=False):
    """run.chatter against the error in the accumulation time and against cost.

    Scene: sine obstacle, kappa = 1, beta = 1, omega < 1 (the contact force is positive, so
    every chattering sequence ends in sticking), start on the obstacle at t = 0 with relative
    velocity w0.  The engine's accumulation time at threshold c is the kernel's jump from the
    first impact with relative velocity <= c: t_k + 2 w_k / (N_k (1 - r)) (the chattering
    branch of ``cornerbif/models/flow/kernel.py``; N_k from its ``contact_force``), read from the
    recorded impacts.  Reference: ``chatter_reference`` (mpmath).
    """
    from cornerbif.models.flow import packed as P
    from cornerbif.models.flow.kernel import contact_force
    from cornerbif.numerics.oscillator import derive
    from cornerbif.obstacles.dispatch import z_state
    from cornerbif.sweep import simulate
    cases = [(0.5, 0.8, 0.05), (0.8, 0.5, 0.1)] if smoke else \
        [(w, r, w0) for w in (0.5, 0.8) for r in (0.5, 0.8) for w0 in (0.01, 0.1)]
    thresholds = [1e-2, 1e-6] if smoke else \
        [1e-1, 3e-2, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-10, 1e-12, 1e-14]
    refs = [chatter_reference(w, r, w0) for w, r, w0 in cases]
    om = np.array([c[0] for c in cases])
    rr = np.array([c[1] for c in cases])
    w0 = np.array([c[2] for c in cases])
    u0 = np.full(len(cases), CHATTER_KAPPA)
    v0 = CHATTER_BETA * om + w0
    kw = dict(obstacle="sine", transient=0, record=400, max_periods=2, omega=om,
              kappa=CHATTER_KAPPA, beta=CHATTER_BETA)
    reps = 200 if smoke else 2000     # copies for the cost measurement
    simulate(u0, v0, r=rr, chatter=1e-6, **kw)             # warm
    rows = []
    for c in thresholds:
        res = simulate(u0, v0, r=rr, chatter=c, **kw)
        errs, n_imp = [], []
        for i, (w, r, _) in enumerate(cases):
            t = res["t"][i]
            k = int(np.sum(np.isfinite(t))) - 1
            p = P.pack({"omega": w, "kappa": CHATTER_KAPPA, "beta": CHATTER_BETA, "r": r},
                       "sine", 1e-12, c, 1e6, None)
            d = derive(p)
            L = math.pi / w
            j = int(t[k] // L)
            tau = t[k] - j * L
            _, zp, _, _ = z_state(p, j, tau)
            nf, _ = contact_force(p, d, j, tau)
            wk = res["v_out"][i, k] - zp
            t_acc = t[k] + 2.0 * max(wk, 0.0) / (nf * (1.0 - r))
            errs.append(abs(t_acc - refs[i][0]))
            n_imp.append(k + 1)
        # cost: the same sequences through the kernel alone (run_batch, no Python set-up),
        # each run ending at its last impact before the jump (record = its impact count),
        # so the sticking phase after it is not timed
        dt = 0.0
        for i, (w, r, _) in enumerate(cases):
            p = P.pack({"omega": w, "kappa": CHATTER_KAPPA, "beta": CHATTER_BETA, "r": r},
                       "sine", 1e-12, c, 1e6, None)
            ics = np.tile([u0[i], v0[i]], (reps, 1))
            dt += _time_kernel(np.tile(p, (reps, 1)), ics, n_imp[i])
        # (2000 copies: with a few dozen items the parallel launch dominates)
        rows.append({"chatter": c, "max_error": float(max(errs)),
                     "median_error": float(np.median(errs)),
                     "impacts_per_sequence": float(np.mean(n_imp)),
                     "microseconds_per_sequence": 1e6 * dt / (reps * len(cases)),
                     "microseconds_per_impact": 1e6 * dt / (reps * sum(n_imp))})
    return {"cases": [{"omega": w, "r": r, "w0": x, "t_acc": ref[0], "ref_impacts": ref[1]}
                      for (w, r, x), ref in zip(cases, refs)], "rows": rows}


def plot_chatter(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rows = res["rows"]
    c = [x["chatter"] for x in rows]
    fig, ax = plt.subplots(1, 2, figsize=(8, 3.2), dpi=120)
    ax[0].loglog(c, [max(x["max_error"], 1e-17) for x in rows], "o-", ms=3, label="max")
    ax[0].loglog(c, [max(x["median_error"], 1e-17) for x in rows], "s-", ms=3, label="median")
    ax[0].set_xlabel("run.chatter")
    ax[0].set_ylabel("accumulation-time error")
    ax[0].legend(fontsize=7)
    ax[1].semilogx(c, [x["microseconds_per_sequence"] for x in rows], "o-", ms=3)
    ax[1].set_xlabel("run.chatter")
    ax[1].set_ylabel("microseconds per sequence")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ------------------------------------------------------------------ 4. profile
_COUNT_SCRIPT = r"""
import json, os, sys
import numpy as np
sys.path.insert(0, {root!r})
from cornerbif import config
try:
    from cornerbif import engine as sweep
except ImportError:  # a tree from before the engine split (benchmarks/ab.py compares trees)
    from cornerbif import sweep
import cornerbif.models.flow.kernel as F
from cornerbif.numerics.roots import FOUND, NONE

KEYS = ("eval_gap", "eval_gap_free", "rotations", "steps", "eval_force", "steps_force",
        "calls_found", "calls_none", "evals_found", "evals_none", "steps_found",
        "steps_none", "sturm", "sturm_whole_piece", "impacts")
c = dict.fromkeys(KEYS, 0)
gap_search = [False]      # inside a search of the gap (first_root(GAP), first_impact_free)
sines = [0]               # sine_part calls at flow level: the closed-form evaluations of a
                          # free search (free_state's branch, and its first point after a
                          # Sturm root)
_ev, _fr, _fif, _fs, _sp, _br, _st, _si = (F.evaluate, F.first_root, F.first_impact_free,
    F.free_state, F.sine_part, F.bracket, F.sturm_clear, F.store_impact)
def evaluate(kind, *a):
    c["eval_gap" if kind == F.GAP else "eval_force"] += 1
    return _ev(kind, *a)
def sine_part(*a):
    sines[0] += 1
    if gap_search[0]:
        c["eval_gap"] += 1
        c["eval_gap_free"] += 1
    return _sp(*a)
def free_state(*a):
    before = sines[0]
    res = _fs(*a)
    if sines[0] == before:
        c["rotations"] += 1
    return res
def bracket(*a):
    c["steps" if gap_search[0] else "steps_force"] += 1
    return _br(*a)
def _search(fn, *a):
    before = c["eval_gap"], c["steps"]
    gap_search[0] = True
    try:
        res = fn(*a)
    finally:
        gap_search[0] = False
    key = "found" if res[0] == FOUND else "none"
    c["calls_" + key] += 1
    c["evals_" + key] += c["eval_gap"] - before[0]
    c["steps_" + key] += c["steps"] - before[1]
    return res
def first_root(kind, *a):
    if kind == F.GAP:
        return _search(_fr, kind, *a)
    return _fr(kind, *a)
def first_impact_free(*a):
    return _search(_fif, *a)
def sturm_clear(p, d, j, g0, gp0, rest, *rot):
    res = _st(p, d, j, g0, gp0, rest, *rot)
    c["sturm"] += 1
    c["sturm_whole_piece"] += int(res[0] >= rest)
    return res
def store_impact(*a):
    c["impacts"] += 1
    return _si(*a)
(F.evaluate, F.first_root, F.first_impact_free, F.free_state, F.sine_part, F.bracket,
 F.sturm_clear, F.store_impact) = (evaluate, first_root, first_impact_free, free_state,
                                   sine_part, bracket, sturm_clear, store_impact)
out = {{}}
for tol in {tols!r}:
    for k in c: c[k] = 0
    scene = config.load(os.path.join({root!r}, "configs", "fig04c.toml"),
                        ["sweep.omega.num={n}", "initial.count=1", "run.transient=0",
                         "run.record={rec}", f"run.tol={{tol!r}}"])
    idx = [(i,) for i in range(scene.shape[0])]
    prm = sweep.pack_points(scene, idx)
    ics = sweep.draw_initial(scene, np.arange(len(idx)), prm[:, 1])
    ics = ics.reshape(-1, ics.shape[-1])
    sweep.run_items(prm, ics, sweep.int_settings(scene), scene)
    out[repr(tol)] = dict(c)
print("COUNTS", json.dumps(out))
"""


def _unit_costs(n=200000):
    """Seconds per call of the kernel's pieces, each timed in a jitted loop with the tuples
    the kernel passes (``P.as_tuple``, ``derived_tuple``; Fig. 4(c)-like point omega = 2.1,
    kappa = 0), as throughput (independent calls) and as latency (each call depends on the
    last, as in the kernel's search):

    * ``exact``: a closed-form evaluation of a free flight's state (``flow.free_state``
      forced to its exact branch by an anchor at infinity: eqs (4), (8));
    * ``rotation``: the same state by small-angle rotation from an anchor 0.05 away;
    * ``evaluate``: a gap evaluation of the general path (``flow.evaluate(GAP)``);
    * ``bracket``: one certified search step (``roots.bracket``) from a point with g > 0,
      g' < 0 and a finite bound on g''' (the root too far for ``roots.polish``);
    * ``sturm``: the Sturm certificate (``flow.sturm_clear``) of a flight from a corner
      that finds the root of its comparison sinusoid, with the search's first point on the
      phase grid (``flow.grid_start``); ``sturm_piece``: one that clears the whole piece.
    """
    import numba

    from cornerbif.models.flow import packed as P
    from cornerbif.models.flow.kernel import GAP, evaluate, free_state, grid_start, phase_grid, sturm_clear
    from cornerbif.numerics.oscillator import derive
    from cornerbif.numerics.roots import bracket
    from cornerbif.obstacles.dispatch import derived_tuple

    @numba.njit
    def timed_loop(call, p, d, aux, n, dep):
        acc = 0.0
        for i in range(n):     # dep: each call depends on the last (latency)
            x = call(p, d, aux, 1e-12 * (acc if dep else i))
            acc = x if dep else acc + x
        return acc

    @numba.njit
    def exact(p, d, aux, e):
        return free_state(p, d, 0, 0.1, 3.0, 0.5, 0.2 + e, math.inf, 0.0, 0.0, 0.0, 0.0)[0]

    @numba.njit
    def rotation(p, d, aux, e):
        return free_state(p, d, 0, 0.1, 3.0, 0.5, 0.2 + e, 0.15, 2.9, 0.8, 0.5, 1.9)[0]

    @numba.njit
    def general(p, d, aux, e):
        return evaluate(GAP, p, d, 0, 0.1, 3.0, 0.5, 0.2 + e)[0]

    @numba.njit
    def step(p, d, aux, e):    # the bounds of a flight of amplitude 3 on a Fig. 4(c) piece
        return bracket(0.3 + e, -1.0, -0.5, 1.0, False, 1.2, -3.0, 7.4, 12.3, 20.0, 1e-12,
                       -1.0)[1]

    @numba.njit
    def sturm_root(p, d, aux, e):
        # a flight from a corner whose comparison sinusoid has a root on the piece: the
        # root's half-angle tangent (no arctangent), then the search's first point on the
        # phase grid (flow.grid_start), as the kernel does for every flight from a corner
        s, _, _, _, t = sturm_clear(p, d, 0, 2.0 + e, -0.5, 1.4, 1.0, 0.0, False, True)
        return s + grid_start(p, d, 0, 2.0 + e, -0.5 + 2.1, aux[2], t)[1]

    @numba.njit
    def sturm_piece(p, d, aux, e):
        # a flight from a corner cleared over the whole piece, rotation precomputed (aux)
        return sturm_clear(p, d, 0, 2.0 + e, 0.5, d[0], aux[0], aux[1], True, False)[0]

    row = P.pack({"omega": 2.1, "kappa": 0.0, "beta": 1.0, "r": 0.8}, "rectified_sine", 1e-12,
                 1e-6, 1e6, None)
    p = P.as_tuple(row)
    d = derived_tuple(derive(row))
    aux = (math.cos(d[0]), math.sin(d[0]), phase_grid(p, d))
    out = {}
    for dep, flavour in ((False, "throughput"), (True, "latency")):
        for name, fn in (("exact", exact), ("rotation", rotation), ("evaluate", general),
                         ("bracket", step), ("sturm", sturm_root),
                         ("sturm_piece", sturm_piece)):
            timed_loop(fn, p, d, aux, 10, dep)
            best = math.inf
            for _ in range(3):
                t0 = time.perf_counter()
                timed_loop(fn, p, d, aux, n, dep)
                best = min(best, time.perf_counter() - t0)
            out[f"{name}_{flavour}"] = best / n
    return out


def bench_profile(smoke=False):
    """Where the time of a Fig. 4(c) sweep goes, on one thread.

    Stages (timed directly): set-up (pack parameters, draw starts), kernel
    (``models.flow.kernel.run_batch``), analysis (``analysis.detect_cycles``: clusters, period,
    word), HDF5 write and file bookkeeping (the whole ``sweep.run_sweep`` minus the rest).

    Inside the kernel (counted, not timed: a timer per event would cost more than the
    event): a ``NUMBA_DISABLE_JIT=1`` run of the same kernel on a sample of the scene
    counts, per impact at tol = 1e-12 and at tol = 1e-4, what the gap searches do: exact
    gap evaluations (``flow.evaluate(GAP)`` on the general path, and the closed-form
    branch of ``flow.free_state`` on the free undamped flights of this scene, seen by its
    call of ``sine_part``), small-angle rotations (the other branch of ``free_state``),
    certified search steps (``roots.bracket`` inside ``first_root(GAP)`` and
    ``first_impact_free``), searches that found an impact or none, and Sturm
    certificates.  Root bracketing = the searches' work at tol = 1e-4, refinement = the
    extra work at 1e-12, Sturm exclusion = the certificates, each priced with unit costs
    measured in jitted loops (``_unit_costs``: exact evaluation, rotation, search step,
    certificate) both as throughput (independent calls: a lower bound) and as latency
    (dependent calls: an upper bound); the share quoted is their mean.
    Bookkeeping = the rest of the kernel time (flight set-up, carrying the flight across
    pieces, impact law, recording).  As a check, the refinement is also timed as a variant
    run (kernel time at tol 1e-12 against 1e-4, same scene; ``refinement_timed``).
    """
    import tempfile

    import numba

    from cornerbif import config
    try:
        from cornerbif import engine as sweep
    except ImportError:  # a tree from before the engine split (benchmarks/ab.py compares trees)
        from cornerbif import sweep
    from cornerbif.analysis import detect_cycles
    from cornerbif.models.flow import packed as P
    n_om = 20 if smoke else 1000
    sets = [f"sweep.omega.num={n_om}"]
    scene = config.load(os.path.join(ROOT, "configs", "fig04c.toml"), sets)
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        idx = [(i,) for i in range(scene.shape[0])]
        t0 = time.perf_counter()
        params = sweep.pack_points(scene, idx)
        ics = sweep.draw_initial(scene, np.arange(len(idx)), params[:, P.KAPPA])
        prm = np.repeat(params, scene.n_ic, axis=0)
        ics = np.ascontiguousarray(ics.reshape(-1, ics.shape[-1]))
        t_setup = time.perf_counter() - t0
        ints = sweep.int_settings(scene)
        sweep.run_items(prm[:4], ics[:4], ints, scene)                      # warm
        rep = 1 if smoke else 3
        t_items = math.inf
        for _ in range(rep):
            t0 = time.perf_counter()
            out, st, final, period, ipc, sym = sweep.run_items(prm, ics, ints, scene)
            t_items = min(t_items, time.perf_counter() - t0)
        n = len(prm)
        per, ip, sy = np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros((n, scene.record),
                                                                            np.uint8)
        corner = np.zeros((n, scene.record), np.int64)   # analysis cost does not depend on it
        cornered = np.ones(n, np.bool_)
        t_analysis = math.inf
        for _ in range(rep):
            t0 = time.perf_counter()
            detect_cycles(out["t"], out["v_in"], out["corner_offset"], corner, cornered,
                          scene.period_tol, per, ip, sy)
            t_analysis = min(t_analysis, time.perf_counter() - t0)
        t_sweep = math.inf
        from cornerbif.sweep import run_sweep
        with tempfile.TemporaryDirectory() as tmp:
            for _ in range(1 if smoke else 2):
                t0 = time.perf_counter()
                run_sweep(scene, os.path.join(tmp, "p.h5"), threads=1, overwrite=True)
                t_sweep = min(t_sweep, time.perf_counter() - t0)
            size = os.path.getsize(os.path.join(tmp, "p.h5"))
    finally:
        numba.set_num_threads(old)
    t_kernel = t_items - t_analysis
    t_write = max(t_sweep - t_items - t_setup, 0.0)
    impacts = n * (scene.transient + scene.record)
    stages = {"setup": t_setup, "kernel": t_kernel, "analysis": t_analysis,
              "write_and_file": t_write}
    # ---- inside the kernel: counts (Python mode) x unit costs (jitted)
    n_s, rec = (4, 30) if smoke else (40, 200)
    code = _COUNT_SCRIPT.format(root=ROOT, tols=[1e-12, 1e-4], n=n_s, rec=rec)
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    line = [x for x in p.stdout.splitlines() if x.startswith("COUNTS")]
    if not line:
        raise RuntimeError(p.stderr[-2000:])
    counts = json.loads(line[0][len("COUNTS "):])
    fine, coarse = counts[repr(1e-12)], counts[repr(1e-4)]
    units = _unit_costs(20000 if smoke else 200000)
    # refinement, timed: the same kernel at tol = 1e-4 on the same scene (variant run)
    sc4 = config.load(os.path.join(ROOT, "configs", "fig04c.toml"), sets + ["run.tol=1e-4"])
    numba.set_num_threads(1)
    try:
        prm4 = np.repeat(sweep.pack_points(sc4, idx), sc4.n_ic, axis=0)
        ts = {}
        for name, pp in (("1e-12", prm), ("1e-4", prm4)):
            best = math.inf
            for _ in range(1 if smoke else 2):
                t0 = time.perf_counter()
                sweep.run_items(pp, ics, ints, scene)
                best = min(best, time.perf_counter() - t0)
            ts[name] = best - t_analysis
    finally:
        numba.set_num_threads(old)
    per_imp = lambda c, k: c[k] / c["impacts"]                              # noqa: E731
    k_imp = t_kernel / impacts
    inner = {"kernel_ns_per_impact": 1e9 * k_imp, "kernel_ns_per_impact_tol_1e-4":
             1e9 * ts["1e-4"] / impacts,
             "refinement_timed": 1.0 - ts["1e-4"] / ts["1e-12"]}

    def search(c, flavour):
        """Seconds per impact of the gap searches: exact evaluations, rotations, steps."""
        u = lambda k: units[f"{k}_{flavour}"]                               # noqa: E731
        return (per_imp(c, "eval_gap_free") * u("exact") + per_imp(c, "rotations")
                * u("rotation") + (per_imp(c, "eval_gap") - per_imp(c, "eval_gap_free"))
                * u("evaluate") + per_imp(c, "steps") * u("bracket"))
    for flavour in ("throughput", "latency"):
        inner[f"bracketing_{flavour}"] = search(coarse, flavour) / k_imp
        inner[f"refinement_{flavour}"] = max(search(fine, flavour) - search(coarse, flavour),
                                             0.0) / k_imp
        # a certificate that clears the rest of the piece takes the short path (no square
        # root, no arctangent); the others find the root of the comparison sinusoid
        whole = per_imp(fine, "sturm_whole_piece")
        inner[f"sturm_{flavour}"] = (whole * units[f"sturm_piece_{flavour}"]
                                     + (per_imp(fine, "sturm") - whole)
                                     * units[f"sturm_{flavour}"]) / k_imp
    # point estimate: the mean of the two pricings; bookkeeping = what is left
    for part in ("bracketing", "refinement", "sturm"):
        inner[part] = 0.5 * (inner[f"{part}_throughput"] + inner[f"{part}_latency"])
    priced = inner["bracketing"] + inner["sturm"] + inner["refinement"]
    if priced > 1.0:      # the unit costs came out slower than the kernel: scale them down
        for part in ("bracketing", "refinement", "sturm"):
            inner[part] /= priced
    inner["priced_sum_before_scaling"] = priced
    inner["bookkeeping"] = max(1.0 - priced, 0.0)
    return {"scene": f"fig04c, omega.num = {n_om}, 4 starts, 500 + 100 impacts, 1 thread",
            "impacts": impacts, "seconds": stages, "sweep_seconds": t_sweep,
            "file_bytes": size,
            "shares": {k: v / sum(stages.values()) for k, v in stages.items()},
            "counts_per_impact": {t: {k: v / c["impacts"] for k, v in c.items() if k != "impacts"}
                                  for t, c in counts.items()},
            "count_sample": f"{n_s} omega values x 1 start x {rec} impacts",
            "kernel_variant_seconds": ts,
            "unit_ns": {k: 1e9 * v for k, v in units.items()}, "kernel": inner}


def plot_profile(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 2.4), dpi=120)
    sh = res["shares"]
    kern = res["kernel"]
    parts = [("setup", sh["setup"]), ("analysis", sh["analysis"]),
             ("HDF5 write + file", sh["write_and_file"])]
    kparts = [("kernel: bracketing", kern["bracketing"]), ("kernel: refinement", kern["refinement"]),
              ("kernel: Sturm exclusion", kern["sturm"]), ("kernel: bookkeeping",
                                                           kern["bookkeeping"])]
    parts = [(n, v * sh["kernel"]) for n, v in kparts] + parts
    left = 0.0
    for (name, v), col in zip(parts, plt.cm.tab10.colors):
        ax.barh([0], [100 * v], left=100 * left, color=col, label=f"{name} {100 * v:.1f} %")
        left += v
    ax.set_xlim(0, 100)
    ax.set_yticks([])
    ax.set_xlabel("% of a Fig. 4(c) sweep on one thread")
    ax.legend(fontsize=6, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.45))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# ------------------------------------------------------------------ report sections
def _e(x):
    if x is None:
        return "n/a"
    return "inf" if x == math.inf else f"{x:.1e}"


def render_transient(res, r):
    L = ["## Transient length against the error of the drawn diagram", "",
         "Per run (grid point x start), the impact heights recorded after `run.transient` = T "
         "impacts against those of the same start after T_ref impacts; error per grid point = "
         "the Hausdorff distance between the two sets (all starts pooled, as drawn); "
         "'wrong word' = share of runs whose attractor word or period differs from the "
         "reference run's. Curves: `transient.png`.", ""]
    for name, c in res.items():
        L += [f"**{name}**: {c['points']} points x {c['starts']} starts, record "
              f"{c['record']}, T_ref = {c['T_ref']} (periodic at T_ref: "
              f"{100 * c['ref_periodic_share']:.0f} % of runs).", "",
              "| T | median | 90th pct | max | wrong word | us per run (1 thread) |",
              "|---|---|---|---|---|---|"]
        for x in c["rows"]:
            L.append(f"| {x['T']} | {_e(x['median'])} | {_e(x['p90'])} | {_e(x['max'])} | "
                     f"{100 * x['word_wrong']:.1f} % | {1e6 * x['seconds_per_item']:.0f} |")
        L.append("")
    return L


def render_map_vs_flow(res, r):
    L = ["## map2d against flow, by distance from (omega, kappa) = (2, 0)", "",
         f"Rays omega - 2 = +-delta, kappa = c (omega - 2) (omega < 2: c in [12, 14.2], "
         f"Fig. 16's range; omega > 2: c in [0.5, 2.8] (one-impact orbit) and [14.5, 17] "
         f"(two-impact orbit), outside the band [kappa_CC, kappa_C]). Both models run "
         f"{res['transient']} + {res['record']} steps from "
         f"{res['starts']} starts per point through `sweep.run_items`. b error: Hausdorff "
         "distance between the flow's v(nT) and the map's b_n per point on the attractors both "
         "models reached (max over the ray); 'attractors differ': points where the starts of "
         "the two models found different sets of words (coexistence and basins, not accuracy). "
         "Plateau ends: the beta^N gamma interval of the maps (theory.word_interval) against "
         "the flow's (bisection with the flow as judge). Curves: `map_vs_flow.png`.", "",
         "| omega - 2 | b error max | b error / delta | attractors differ | plateau-end error "
         "(kappa) | flow / map cost per point |", "|---|---|---|---|---|---|"]
    for x in res["rows"]:
        pe = ", ".join(f"{p['word']}: {_e(p['end_error'])}" if p.get("end_error") is not None
                       else f"{p['word']}: flow word differs" for p in x["plateaus"]) or "-"
        L.append(f"| {x['sign'] * x['delta']:+.0e} | {_e(x['b_dist_max'])} | "
                 f"{_e(x['b_rel_max'])} | {100 * x['word_mismatch']:.0f} % | {pe} | "
                 f"{x['cost_ratio']:.0f}x ({1e3 * x['flow_seconds_per_point']:.2f} ms / "
                 f"{1e3 * x['map_seconds_per_point']:.3f} ms) |")
    return L + [""]


def render_chatter(res, r):
    L = ["## Chattering threshold against accumulation-time error and cost", "",
         "Sine obstacle z = 1 + sin(omega t), u'' = -u, starts on the obstacle at t = 0 "
         "with relative velocity w0 (cases: " + "; ".join(
             f"omega {c['omega']}, r {c['r']}, w0 {c['w0']}" for c in res["cases"]) +
         "). Reference: every impact located in mpmath (60 digits) down to w = 1e-20 "
         "(`trade.chatter_reference`). Engine: the kernel's jump from the first impact with "
         "w <= `run.chatter` (tol 1e-12). Cost: the kernel alone (2 threads, 2000 copies of each "
         "case), per sequence, up to the jump. "
         "Curves: `chatter.png`.", "",
         "| run.chatter | max error | median error | impacts per sequence | us per sequence |",
         "|---|---|---|---|---|"]
    for x in res["rows"]:
        L.append(f"| {x['chatter']:.0e} | {_e(x['max_error'])} | {_e(x['median_error'])} | "
                 f"{x['impacts_per_sequence']:.1f} | {x['microseconds_per_sequence']:.2f} |")
    return L + [""]


def _rng(ks, k, part):
    a, b = sorted([100 * ks * k[f"{part}_throughput"], 100 * ks * k[f"{part}_latency"]])
    return f"{a:.1f} - {b:.1f}"


def render_profile(res, r):
    sh, k = res["shares"], res["kernel"]
    c12 = res["counts_per_impact"][repr(1e-12)]
    c4 = res["counts_per_impact"][repr(1e-4)]
    un = res["unit_ns"]
    ks = sh["kernel"]
    L = ["## Profile of a Fig. 4(c) sweep (one thread)", "",
         f"Scene: {res['scene']}; {res['impacts'] / 1e6:.1f} M impacts, whole "
         f"`run_sweep` {res['sweep_seconds']:.2f} s, file {res['file_bytes'] / 2**20:.1f} MiB. "
         "Stages timed directly (best of 3; HDF5 write = the whole sweep minus the other "
         "stages); inside the kernel: operations counted in a "
         f"NUMBA_DISABLE_JIT run ({res['count_sample']}) x unit costs from jitted loops "
         "(mean of throughput and latency pricing, range in brackets), bracketing = the gap "
         "searches' work (exact evaluations, small-angle rotations, certified steps) at tol "
         "1e-4, refinement = the extra work at 1e-12, bookkeeping = the rest. "
         "Bar: `profile.png`.", ""]
    if "steps" not in c12:
        return L + ["(These counts predate the free-flight search `flow.first_impact_free` "
                    "and are not shown: run `python benchmarks/run.py --only profile`.)", ""]
    general = c12["eval_gap"] - c12["eval_gap_free"]
    return L + [
        "| part | share of the sweep |", "|---|---|",
        f"| set-up (parameters, starts) | {100 * sh['setup']:.1f} % |",
        f"| kernel: root bracketing | {100 * ks * k['bracketing']:.1f} % "
        f"({_rng(ks, k, 'bracketing')}) |",
        f"| kernel: refinement (tol 1e-4 -> 1e-12) | {100 * ks * k['refinement']:.1f} % "
        f"({_rng(ks, k, 'refinement')}) |",
        f"| kernel: Sturm exclusion | {100 * ks * k['sturm']:.1f} % "
        f"({_rng(ks, k, 'sturm')}) |",
        f"| kernel: bookkeeping (flight set-up, piece crossing, impact law, recording) | "
        f"{100 * ks * k['bookkeeping']:.1f} % |",
        f"| analysis (detect_cycles) | {100 * sh['analysis']:.2f} % |",
        f"| HDF5 write and file handling | {100 * sh['write_and_file']:.1f} % |", "",
        f"Per impact at tol 1e-12 (1e-4): {c12['calls_found'] + c12['calls_none']:.2f} gap "
        f"searches, {c12['calls_none']:.2f} of them proving a piece impact-free; "
        f"{c12['steps']:.2f} ({c4['steps']:.2f}) certified search steps; "
        f"{c12['eval_gap']:.2f} ({c4['eval_gap']:.2f}) exact gap evaluations"
        + (f" ({general:.2f} on the general path, `flow.evaluate`)" if general > 0 else "")
        + f" and {c12['rotations']:.2f} ({c4['rotations']:.2f}) small-angle rotations from "
        f"the last exact point; {c12['sturm']:.2f} Sturm certificates "
        f"({c12['sturm_whole_piece']:.2f} clearing a whole piece). Unit costs (ns, "
        f"throughput / latency): exact evaluation {un['exact_throughput']:.0f} / "
        f"{un['exact_latency']:.0f}, rotation {un['rotation_throughput']:.0f} / "
        f"{un['rotation_latency']:.0f}, search step {un['bracket_throughput']:.0f} / "
        f"{un['bracket_latency']:.0f}, Sturm clearing the piece "
        f"{un.get('sturm_piece_throughput', float('nan')):.0f} / "
        f"{un.get('sturm_piece_latency', float('nan')):.0f}, Sturm finding the root of its "
        f"sinusoid and the search's first point on the phase grid "
        f"{un['sturm_throughput']:.0f} / {un['sturm_latency']:.0f}; "
        f"kernel {k['kernel_ns_per_impact']:.0f} ns per impact; variant runs: "
        f"{1e9 * res['kernel_variant_seconds']['1e-12'] / res['impacts']:.0f} ns at tol 1e-12, "
        f"{k['kernel_ns_per_impact_tol_1e-4']:.0f} at 1e-4 (timed variant: refinement "
        f"{100 * k['refinement_timed']:+.0f} % of the kernel; on this shared machine "
        "that difference is within the noise)."
        + (f" The priced parts summed to {100 * k['priced_sum_before_scaling']:.0f} % of the "
           "kernel time (unit costs measured while the machine was busier) and were scaled "
           "to 100 %: bookkeeping is then below the resolution of this method."
           if k.get("priced_sum_before_scaling", 0) > 1 else ""), ""]
