"""The linear model's jitted event loop against an independent brute force over thousands of
random systems and grazing flights (issue 33: "a brute-force search over thousands of random
systems (N = 1-4, random contacts and obstacles, grazing flights down to 1e-12) finds no
impact the kernel missed"):

    python benchmarks/certify_linear.py [--systems 2000] [--grazes G] [--seed S] [--smoke]
                                        [--out DIR]

System i is ``linear_bruteforce.random_case(S + i)`` (tests/linear_bruteforce.py: N = 1..4,
a random SPD mass, a PSD stiffness of random rank, free masses included, damping and
gyroscopic terms, harmonic and constant forces sometimes, 1..3 contacts of random gap
vectors on fixed, sine, rectified-sine and triangle obstacles, beta of either sign, r in
[0, 1)), run by ``kernel.run_system`` for 10 impacts or to a time budget of 30, each
impact checked against the brute force restarted from the kernel's state after the impact
before (``check_run``: nothing missed, each impact real, the state and the law).  Grazing
flight g is ``check_graze(S + g, ...)`` with ``graze_plan(g)``: dips and clearances of
1e-6 .. 1e-12 at smooth low points and at corners (default: as many as systems).

Soft stops and sticking (``--hybrid H``, default as many as systems; 0: none): H systems
``random_soft_case(S + i)`` (1..3 contacts, soft stops with or without a hard contact; 10
events or to a time budget of 30) and H systems ``random_stick_case(S + i)`` (land, chatter
or stick at once, are released or not; 40 events), each recorded event checked by
``check_hybrid`` (the brute force's own hybrid run between two recorded events, its exits
and releases its own: nothing missed, each event real, the state and the law), and
``--hybrid-grazes G`` (default H / 4) grazes ``check_hybrid_graze(S + g, ...)`` with
``hybrid_graze_plan(g)``: a soft stop's entry and exit, a hold's release, at -+1e-6 ..
-+1e-12 (the release's dips of 1e-8 .. 1e-11 only with ``--slow-releases``: the kernel
takes seconds on each).

Prints a summary (systems by status, impacts compared, misses, the worst differences, grazes
by depth, wall time) and every problem with its reproduction (the [system] table, the start,
the kernel's and the brute force's times); ``--out DIR`` writes it all to
DIR/certify_linear.json.  One process (the brute force is numpy and scipy; set
OPENBLAS_NUM_THREADS=1 to keep BLAS to one thread).  tests/models/test_linear_certify.py
runs a sample of the same draws.
"""

from __future__ import annotations

import argparse
import collections
import hashlib
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))


def _revision():
    """The checkout's commit, whether the package's files differ from it, and the sha1 of the
    kernel's source as imported (taken at the start: the tree may change during a run)."""
    def git(*args):
        try:
            return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                                  timeout=30).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""
    from cornerbif.models.linear import kernel
    with open(kernel.__file__, "rb") as f:
        sha = hashlib.sha1(f.read()).hexdigest()[:12]
    return {"commit": git("log", "-1", "--format=%h"),
            "changed": git("diff", "--stat", "--", "cornerbif").splitlines(),
            "kernel": kernel.__file__, "kernel_sha1": sha}


def _worst(acc, key, value, where):
    if value > acc.get(key, (-1.0, None))[0]:
        acc[key] = (float(value), where)


def _hybrid(bf, seed, systems, grazes, slow_releases, problems):
    """The soft-stop and sticking systems and the hybrid grazes (module docstring): the
    summary's rows and the report's dict; problems appended to ``problems``."""
    rows, report = [], {}
    if not systems and not grazes:
        return {"rows": rows, "report": report}
    for kind, case, count in (("soft", bf.random_soft_case, 10), ("stick", bf.random_stick_case, 40)):
        t0 = time.perf_counter()
        n = collections.Counter()
        worst = {}
        for i in range(systems):
            table, ts, x0, v0 = case(seed + i)
            res = bf.check_hybrid(table, ts, x0, v0, count=count)
            n["status " + res["status"]] += 1
            for key in ("events", "entries", "impacts", "holds", "exits", "releases"):
                n[key] += res[key]
            n["misses"] += sum(1 for p in res["problems"] if p["what"] == "missed")
            for key in ("early_depth", "gap_at_event", "allowance_used", "state_worst", "law_worst"):
                _worst(worst, key, res[key], seed + i)
            if res["problems"]:
                problems.append({"kind": kind, "seed": seed + i, "problems": res["problems"],
                                 "table": table, "t0": ts, "x0": x0, "v0": v0,
                                 "kernel": {"status": res["status"], "t": res["kernel_t"],
                                            "contact": res["kernel_contact"]},
                                 "brute_force": {"switches": res["switches"]}})
            if (i + 1) % 500 == 0:
                print(f"  {kind}: {i + 1} systems, {n['events']} events "
                      f"({time.perf_counter() - t0:.0f} s)", flush=True)
        wall = time.perf_counter() - t0
        report[kind] = {"systems": systems, "counts": dict(n), "worst": worst, "wall": wall}
        st = ", ".join(f"{k[7:]} {v}" for k, v in sorted(n.items()) if k.startswith("status "))
        rows.append((f"{kind} systems", f"{systems} (seeds {seed}..{seed + systems - 1}): {st}; "
                     f"{n['events']} events ({n['entries']} entries, {n['impacts']} impacts, "
                     f"{n['holds']} holds), the brute force's {n['exits']} exits and {n['releases']} "
                     f"releases; {n['misses']} missed; {wall:.1f} s"))
        if systems:
            rows.append((f"{kind} worst", "gap before {:.2g} (seed {}), at {:.2g} (seed {}); allowance "
                         "used {:.2g}; state {:.2g}; law {:.2g}".format(
                             *worst["early_depth"], *worst["gap_at_event"], worst["allowance_used"][0],
                             worst["state_worst"][0], worst["law_worst"][0])))
    t0 = time.perf_counter()
    tested, wrong, not_built = collections.Counter(), collections.Counter(), 0
    slowest = (0.0, None)
    for g in range(grazes):
        kind, delta = bf.hybrid_graze_plan(g, slow_releases)
        tg = time.perf_counter()
        case, verdict, res = bf.check_hybrid_graze(seed + g, kind, delta)
        tg = time.perf_counter() - tg
        if tg > slowest[0]:
            slowest = (tg, (seed + g, kind, delta))
        if case is None:
            not_built += 1
            continue
        tested[(kind, delta)] += 1
        if not verdict["ok"] or res["problems"]:
            wrong[(kind, delta)] += 1
            problems.append({"kind": "hybrid graze", "seed": seed + g, "verdict": verdict,
                             "problems": res["problems"], "table": case["table"], "t0": case["t0"],
                             "x0": case["x0"], "v0": case["v0"],
                             "kernel": {"status": res["status"], "t": res["kernel_t"],
                                        "contact": res["kernel_contact"]},
                             "brute_force": {"switches": res["switches"]}})
    wall = time.perf_counter() - t0
    if grazes:
        depth = min((abs(d) for (_, d) in tested), default=None)
        rows.append(("hybrid grazes", f"{sum(tested.values())} ({not_built} not built): "
                     + ", ".join(f"{k} {sum(v for (kk, _), v in tested.items() if kk == k)}"
                                 for k in bf.HYBRID_GRAZES)
                     + f"; {sum(wrong.values())} decided wrong; smallest depth {depth:g}; {wall:.1f} s "
                     f"(slowest {slowest[0]:.1f} s: seed, kind, delta {slowest[1]})"))
        report["grazes"] = {f"{k} {d:+.0e}": {"tested": v, "wrong": wrong[(k, d)]}
                            for (k, d), v in sorted(tested.items())}
        report["grazes_wall"] = wall
    return {"rows": rows, "report": report}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--systems", type=int, default=2000)
    ap.add_argument("--grazes", type=int, default=None, help="grazing flights (default: --systems)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--smoke", action="store_true", help="a tiny run (20 systems, 20 grazes)")
    ap.add_argument("--out", default=None, help="a folder for certify_linear.json")
    ap.add_argument("--hybrid", type=int, default=None,
                    help="soft-stop systems and sticking systems, of each (default: --systems)")
    ap.add_argument("--hybrid-grazes", type=int, default=None, help="hybrid grazes (default: --hybrid / 4)")
    ap.add_argument("--slow-releases", action="store_true",
                    help="the release's dips of 1e-8 .. 1e-11 too (the kernel takes seconds on each)")
    ap.add_argument("--only-hybrid", action="store_true", help="skip the impacts' systems and grazes")
    a = ap.parse_args(argv)
    if a.smoke:
        a.systems, a.grazes = 20, 20
    grazes = a.systems if a.grazes is None else a.grazes
    hybrid = a.systems if a.hybrid is None else a.hybrid
    hybrid_grazes = hybrid // 4 if a.hybrid_grazes is None else a.hybrid_grazes
    if a.only_hybrid:
        a.systems, grazes = 0, 0

    import linear_bruteforce as bf

    import cornerbif

    rev = _revision()
    t_start = time.perf_counter()
    bf.check_run(*bf.random_case(a.seed))              # the kernel compiled (or loaded)
    t_compile = time.perf_counter() - t_start

    status = collections.Counter()
    chatter_impacts = impacts = flights = 0
    worst, problems = {}, []
    t0 = time.perf_counter()
    for i in range(a.systems):
        seed = a.seed + i
        table, ts, x0, v0 = bf.random_case(seed)
        res = bf.check_run(table, ts, x0, v0)
        status[res["status"]] += 1
        impacts += res["impacts"]
        flights += res["flights"]
        if res["status"] == "CHATTERS":
            chatter_impacts += res["impacts"]
        for key in ("early_depth", "gap_at_impact", "allowance_used", "dt_worst", "dt_gap_worst",
                    "state_worst", "law_worst"):
            _worst(worst, key, res[key], seed)
        if res["problems"]:
            problems.append({"kind": "system", "seed": seed, "problems": res["problems"],
                             "table": table, "t0": ts, "x0": x0, "v0": v0,
                             "kernel": {"status": res["status"], "t": res["kernel_t"],
                                        "contact": res["kernel_contact"]},
                             "brute_force": {"t": res["bf_t"], "contact": res["bf_contact"]}})
        if (i + 1) % 200 == 0:
            print(f"  {i + 1} systems, {impacts} impacts, {len(problems)} with problems "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    t_systems = time.perf_counter() - t0

    t0 = time.perf_counter()
    gz, gz_rounding, gz_wrong = (collections.Counter() for _ in range(3))
    gz_dt, gz_err = {}, []
    not_built = 0
    for g in range(grazes):
        where, delta = bf.graze_plan(g)
        case, verdict, res = bf.check_graze(a.seed + g, delta, where)
        if case is None:
            not_built += 1
            continue
        gz[(where, delta)] += 1
        if verdict["dt"] is not None and verdict["ok"]:
            _worst(gz_dt, f"{where} {delta:+.0e}", verdict["dt"], a.seed + g)
        if verdict["rounding"]:
            gz_rounding[(where, delta)] += 1
            gz_err.append((verdict["kernel_gap_error"], a.seed + g, where, delta))
        if verdict["wrong"] or res["problems"]:
            gz_wrong[(where, delta)] += 1
            problems.append({"kind": "graze", "seed": a.seed + g, "verdict": verdict,
                             "problems": res["problems"],
                             "kernel": {"status": res["status"], "t": res["kernel_t"],
                                        "contact": res["kernel_contact"]},
                             "brute_force": {"t": res["bf_t"], "contact": res["bf_contact"]}})
        if (g + 1) % 200 == 0:
            print(f"  {g + 1} grazes ({time.perf_counter() - t0:.0f} s)", flush=True)
    t_grazes = time.perf_counter() - t0

    hy = _hybrid(bf, a.seed, hybrid, hybrid_grazes, a.slow_releases, problems)

    if not a.systems:
        worst = {k: (0.0, None) for k in ("early_depth", "gap_at_impact", "allowance_used", "dt_worst",
                                          "dt_gap_worst", "state_worst", "law_worst")}
    misses = sum(1 for p in problems if p["kind"] == "system"
                 for q in p["problems"] if q["what"].startswith("missed"))
    kinds = collections.Counter(q["what"] for p in problems for q in p["problems"])
    offs = ", ".join(f"{e[0]:+.2g} (seed {e[1]})" for e in gz_err[:6])
    print()
    print(f"cornerbif {cornerbif.__file__}  commit {rev['commit']}"
          + (f" with changes: {rev['changed'][-1]}" if rev["changed"] else " (clean)")
          + f"; kernel.py sha1 {rev['kernel_sha1']} (at the start)")
    rows = [
        ("systems", f"{a.systems} (seeds {a.seed}..{a.seed + a.systems - 1}): "
                    + ", ".join(f"{k} {v}" for k, v in sorted(status.items()))),
        ("impacts compared", f"{impacts} ({chatter_impacts} in runs ending CHATTERS), "
                             f"{flights} flights"),
        ("misses", f"{misses} impacts missed; problems by kind: {dict(kinds) or 'none'}"),
        ("worst gap before an impact", "{:.2g} (1 + |a||y|), seed {}".format(*worst["early_depth"])),
        ("worst gap at an impact", "{:.2g} (1 + |a||y|), seed {}".format(*worst["gap_at_impact"])),
        ("allowance used", "{:.2g} of it at most (seed {})".format(*worst["allowance_used"])),
        ("worst time difference", "{:.2g} (seed {}); as a gap |dt w|: {:.2g} (1 + |a||y|) (seed {})"
         .format(*worst["dt_worst"], *worst["dt_gap_worst"])),
        ("worst state, law", "{:.2g} (seed {}), {:.2g} (seed {})"
         .format(*worst["state_worst"], *worst["law_worst"])),
        ("grazes tested", f"{sum(gz.values())} ({not_built} not built): "
                          f"{sum(gz_wrong.values())} decided wrong, {sum(gz_rounding.values())} "
                          "decided by the kernel's rounding"
                          + (f" (its gap off by {offs} there)" if gz_err else "")),
        ("wall time", f"{t_systems:.1f} s systems, {t_grazes:.1f} s grazes, "
                      f"{t_compile:.1f} s first run"),
    ] + hy["rows"]
    w = max(len(r[0]) for r in rows)
    for k, v in rows:
        print(f"{k:<{w}}  {v}")
    print()
    print(f"{'graze':<16}{'tested':>8}{'wrong':>7}{'rounding':>10}  worst |t_kernel - t_dip|")
    for (where, delta), n in sorted(gz.items(), key=lambda kv: (kv[0][0], -abs(kv[0][1]), kv[0][1])):
        d = gz_dt.get(f"{where} {delta:+.0e}")
        print(f"{where + ' ' + format(delta, '+.0e'):<16}{n:>8}{gz_wrong[(where, delta)]:>7}"
              f"{gz_rounding[(where, delta)]:>10}  " + ("-" if d is None else f"{d[0]:.2g}"))
    for p in problems:
        print()
        print(f"PROBLEM ({p['kind']} seed {p['seed']}): {p['problems'][:3]}"
              + (f" verdict {p['verdict']}" if p["kind"] == "graze" else ""))
        if p["kind"] in ("system", "soft", "stick", "hybrid graze"):
            print(f"  table = {json.dumps(p['table'])}")
            print(f"  t0 = {p['t0']!r}, x0 = {p['x0']!r}, v0 = {p['v0']!r}")
        print(f"  kernel {p['kernel']}")
        print(f"  brute force {p['brute_force']}")
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        report = {"revision": rev, "cornerbif": cornerbif.__file__, "systems": a.systems,
                  "seed": a.seed, "status": dict(status), "impacts": impacts,
                  "chatter_impacts": chatter_impacts, "flights": flights, "misses": misses,
                  "problem_kinds": dict(kinds), "worst": worst,
                  "grazes": {f"{k[0]} {k[1]:+.0e}": {"tested": v, "wrong": gz_wrong[k],
                                                      "rounding": gz_rounding[k]}
                             for k, v in gz.items()},
                  "grazes_by_rounding": gz_err,
                  "grazes_not_built": not_built, "graze_dt_worst": gz_dt,
                  "wall": {"systems": t_systems, "grazes": t_grazes, "first": t_compile},
                  "hybrid": hy["report"],
                  "problems": problems}
        with open(os.path.join(a.out, "certify_linear.json"), "w") as f:
            json.dump(report, f, indent=1, default=float)
        print(f"\nwrote {os.path.join(a.out, 'certify_linear.json')}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
