"""Write cornerbif/compile_plan.py: what a second process compiles beside a kernel's first compile.

    python benchmarks/compile_plan.py [--check]

numba compiles one function at a time in a process.  On a first run the kernel's helpers
(``_jit.InnerDispatcher``) can be compiled by a second process into numba's cache, and the
first process then loads each one it reaches instead of compiling it
(``engine.compiling_aside``).  For that the second process needs the helpers' exact argument
types; this script records them: for each kernel entry below it runs the entry's command in
an empty numba cache (what the entry shares with others already compiled, as
benchmarks/compile_time.py does), with a listener on numba's compile events, and finds the
function whose callees take most of the compile (e.g. the flow's ``run_one``).  Of its direct
callees, in the order the compile reached them, the last ones, about half of the callees'
compile time, are the plan: the second process compiles them (each with its own callees),
last reached first, while the first compiles the rest.

``--only LABEL ...`` records those plans alone and replaces them in the file (or adds them),
keeping the others as they are.  ``--check`` compares the plan with the file and exits 1
when they differ (a helper's arguments changed: run this script).  tests/runs/test_warm.py
checks the file against a real first run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TARGET = os.path.join(ROOT, "cornerbif", "compile_plan.py")
TINY = ["--no-progress", "--set", "initial.count=1", "--set", "run.transient=4",
        "--set", "run.record=8"]


def sweep(scene, axis, *sets):
    cmd = ["sweep", f"configs/{scene}.toml", "-o", "{tmp}/out.h5", "--overwrite", *TINY,
           "--set", f"sweep.{axis}.num=2"]
    for s in sets:
        cmd += ["--set", s]
    return cmd


def cont(scene):
    return ["continue", f"configs/{scene}.toml", "-o", "{tmp}/cont.h5", "--overwrite"]


STAB = 'output.keep=["impacts", "section", "stability"]'
# (the name ``Model.compiles`` gives the kernel, its command, a command run first, untimed,
# what the second process takes: "half" of the heaviest function's callees, "all" that the
# command compiles beyond the command run first: a kernel of its own, or "top:PREFIX" the
# functions under that name the command compiles at the top)
ENTRIES = [
    ("the flow kernel", sweep("fig04c", "omega"), None, "half"),
    # a first cam or two-particle sweep may be the first run of all: recorded in an empty cache
    ("the flow kernel for a cam profile", sweep("cam_cycloidal", "omega"), None, "half"),
    ("the two-particle kernel", sweep("fig19a", "omega0"), None, "half"),
    ("the flow stability kernel", sweep("fig04c", "omega", STAB), sweep("fig04c", "omega"),
     "all"),
    ("the two-particle stability kernel", sweep("fig19a", "omega0", STAB),
     sweep("fig19a", "omega0"), "all"),
    ("the flow continuation's functions", cont("cont_beta"), sweep("fig04c", "omega"), "all"),
    ("the two-particle continuation's functions", cont("cont_fig19"),
     sweep("fig19a", "omega0"), "all"),
    ("the linear kernel", sweep("bouncing_ball", '"contact.T.beta"'), None, "half"),
    # its kernel's first sweep compiles the stability pass too (the chaos test of the runs
    # without a cycle): recorded in an empty cache, the pass's own entry taken ("top:")
    ("the linear stability pass", sweep("bouncing_ball", '"contact.T.beta"',
                                        'output.keep=["impacts", "stability"]'),
     None, "top:models.linear.tangent."),
]

RECORD = r"""
import json, sys, time
from numba.core import event
from cornerbif._jit import InnerDispatcher
from cornerbif.cli import main
stack, rows = [], []
class L(event.Listener):
    def on_start(self, ev):
        d = ev.data["dispatcher"]
        stack.append([len(rows), time.perf_counter()])
        rows.append({"name": d.py_func.__module__ + "." + d.py_func.__qualname__,
                     "inner": isinstance(d, InnerDispatcher),
                     "args": "(" + ", ".join(map(repr, ev.data["args"])) + ")",
                     "parent": stack[-2][0] if len(stack) > 1 else -1})
    def on_end(self, ev):
        i, t0 = stack.pop()
        rows[i]["seconds"] = time.perf_counter() - t0
event.register("numba:compile", L())
try:
    main(sys.argv[1:])
except SystemExit as e:
    assert e.code in (0, None), e.code
print(json.dumps(rows))
"""


def record(cmd, before):
    with tempfile.TemporaryDirectory() as tmp:
        # the compile as one process does it (no second process compiling beside it)
        env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "cache"),
                   CORNERBIF_COMPILE_BESIDE="0")
        if before:
            subprocess.run([sys.executable, "-c", "from cornerbif.cli import main; main()",
                            *[c.replace("{tmp}", tmp) for c in before]], cwd=ROOT, env=env,
                           check=True, capture_output=True)
        p = subprocess.run([sys.executable, "-c", RECORD, *[c.replace("{tmp}", tmp) for c in cmd]],
                           cwd=ROOT, env=env, check=True, capture_output=True, text=True)
        return json.loads(p.stdout.strip().splitlines()[-1])


def short(name):
    """A function's name under the package, as ``_jit.dispatchers`` takes it."""
    return name.removeprefix("cornerbif.")


def plan_all(rows):
    """Every function the command compiled at the top (each with its callees)."""
    top = [r for r in rows if r["parent"] < 0 and r["name"].startswith("cornerbif.")]
    return {"under": "the command", "seconds": round(sum(r["seconds"] for r in top), 2),
            "of": round(sum(r["seconds"] for r in rows if r["parent"] < 0), 2),
            "functions": [(short(r["name"]), r["args"]) for r in top]}


def plan_top(rows, prefix):
    """The functions the command compiled at the top whose names start with ``prefix``."""
    top = [r for r in rows if r["parent"] < 0 and short(r["name"]).startswith(prefix)]
    return {"under": "the command", "seconds": round(sum(r["seconds"] for r in top), 2),
            "of": round(sum(r["seconds"] for r in rows if r["parent"] < 0), 2),
            "functions": [(short(r["name"]), r["args"]) for r in top]}


def plan(rows):
    """The late half of the callees of the function whose callees cost most, descending while
    one callee takes most of them."""
    kids = {}
    for i, r in enumerate(rows):
        kids.setdefault(r["parent"], []).append(i)
    def callees_time(i):
        return sum(rows[k]["seconds"] for k in kids.get(i, []))
    heavy = max(range(len(rows)), key=callees_time)
    while kids.get(heavy):        # down while one callee takes most (run_batch -> run_one)
        top = max(kids[heavy], key=lambda k: rows[k]["seconds"])
        if rows[top]["seconds"] < 0.6 * callees_time(heavy) or not kids.get(top):
            break
        heavy = top
    callees = [k for k in kids.get(heavy, []) if rows[k]["inner"]]
    total = sum(rows[k]["seconds"] for k in callees)
    chosen, acc = [], 0.0
    for k in reversed(callees):
        if acc + rows[k]["seconds"] > 0.55 * total:
            continue
        chosen.append(k)
        acc += rows[k]["seconds"]
    return {"under": short(rows[heavy]["name"]), "seconds": round(acc, 2),
            "of": round(total, 2),
            "functions": [(short(rows[k]["name"]), rows[k]["args"]) for k in chosen]}


def block(label, p):
    """One plan's lines in PLANS."""
    lines = [f"    # {len(p['functions'])} functions of {p['under']}: {p['seconds']} s of "
             f"{p['of']} s when recorded", f"    {label!r}: ("]
    for name, args in p["functions"]:
        lines.append(f"        ({name!r},")
        lines.append(f"         {args!r}),")
    lines.append("    ),")
    return lines


def merged(text, plans):
    """The file ``text`` with the blocks of ``plans`` replaced or added (``--only``)."""
    lines = text.splitlines()
    for label, p in plans.items():
        head = f"    {label!r}: ("
        if head in lines:
            i = lines.index(head) - 1            # its comment line
            j = lines.index("    ),", i)
            lines[i:j + 1] = block(label, p)
        else:
            end = lines.index("}")
            lines[end:end] = block(label, p)
    half = [label for label, _, _, mode in ENTRIES if mode == "half"]
    k = next(i for i, line in enumerate(lines) if line.startswith("HALF_PLANS = "))
    lines[k] = f"HALF_PLANS = {tuple(half)!r}"
    return "\n".join(lines) + "\n"


def render(plans):
    lines = ["# ruff: noqa: E501 (written by benchmarks/compile_plan.py: one type signature per line)",
             '"""What a second process compiles beside a kernel\'s first compile',
             "(``engine.compiling_aside``): per kernel (as ``Model.compiles`` names it) the",
             "helpers, each with the argument types a first run compiles it for, last reached",
             "first.  Written by ``python benchmarks/compile_plan.py`` (which says how they are",
             'chosen); tests/runs/test_warm.py checks them against a real first run."""', "",
             "PLANS = {"]
    for label, p in plans.items():
        lines += block(label, p)
    lines.append("}")
    half = [label for label, _, _, mode in ENTRIES if mode == "half"]
    lines += ["", "# the plans that are part of a kernel (the rest are kernels of their own)",
              f"HALF_PLANS = {tuple(half)!r}"]
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--only", nargs="+", metavar="LABEL",
                    help="record these plans alone and replace them in the file (the others kept)")
    a = ap.parse_args()
    unknown = set(a.only or ()) - {e[0] for e in ENTRIES}
    if unknown:
        ap.error(f"--only: no such plan {sorted(unknown)}; plans: {[e[0] for e in ENTRIES]}")
    plans = {}
    for label, cmd, before, mode in ENTRIES:
        if a.only and label not in a.only:
            continue
        rows = record(cmd, before)
        plans[label] = (plan(rows) if mode == "half" else
                        plan_top(rows, mode.removeprefix("top:")) if mode.startswith("top:") else
                        plan_all(rows))
        print(f"{label}: {len(plans[label]['functions'])} callees of {plans[label]['under']}, "
              f"{plans[label]['seconds']} s of {plans[label]['of']} s", flush=True)
    if a.check:
        sys.path.insert(0, ROOT)
        from cornerbif.compile_plan import PLANS
        same = all(set(PLANS.get(k, ())) == set(map(tuple, p["functions"]))
                   for k, p in plans.items())
        print("compile_plan.py is current" if same else "compile_plan.py differs: run this script")
        sys.exit(0 if same else 1)
    if a.only:
        with open(TARGET) as fh:
            text = merged(fh.read(), plans)
    else:
        text = render(plans)
    with open(TARGET, "w") as fh:
        fh.write(text)
    print(f"wrote {TARGET}")


if __name__ == "__main__":
    main()
