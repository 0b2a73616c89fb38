"""``cornerbif validate`` loads no numba, no kernel and no h5py (docs/architecture.md).

Checking a scene is reading it: the models' declarations (Model, Param, Coord, Field), the
parameter tables, the obstacle's keys, a cam profile's checks, a continuation's seed word.
None of that needs a jitted function, so validate should not pay for numba's import (about
0.16 s, with llvmlite) nor risk a compile: the registry's tables are computed on first use,
the declarations live in modules without numba, and the kernel modules are imported only by
the functions that run kernels.

One child process validates every shipped scene in turn (configs/*.toml: every model and
obstacle, the cam profiles, map2d and the continuation scenes) and reports, after each, which
modules it has loaded: none may be numba, llvmlite, or a package module that imports either
(or the package's jit policy, ``_jit``) at its top, found by reading the package's sources, so
that a new kernel module is covered too.  A cam's check computes in Python what the obstacle's
jitted functions compute; a last test checks that both give the same numbers.
"""

import ast
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import cornerbif

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = sorted(os.path.join(ROOT, "configs", f) for f in os.listdir(os.path.join(ROOT, "configs"))
                if f.endswith(".toml"))
PACKAGE = os.path.dirname(os.path.abspath(cornerbif.__file__))
JIT_MODULE = "cornerbif._jit"

# validate every scene in one process (an import shows in sys.modules for the rest of it), and
# after each say which modules are loaded; the verdict and exit code are kept for the checks
CHILD = r"""
import contextlib, io, json, sys
from cornerbif import _entry
report = []
for path in sys.argv[1:]:
    sys.argv = ["cornerbif", "validate", path]
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        try:
            _entry.main()
            code = 0
        except SystemExit as e:
            code = e.code
    report.append({"scene": path, "code": code, "output": out.getvalue(),
                   "modules": sorted(sys.modules)})
print(json.dumps(report))
"""


def _module_name(path):
    rel = os.path.relpath(path, os.path.dirname(PACKAGE))[:-len(".py")].split(os.sep)
    if rel[-1] == "__init__":
        rel = rel[:-1]
    return ".".join(rel)


def _imports_at_top(path):
    """The modules ``path`` imports outside any function or class (absolute names)."""
    name = _module_name(path)
    package = name if path.endswith("__init__.py") else name.rpartition(".")[0]
    out = set()
    for node in ast.parse(open(path).read()).body:
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")
            if node.level:
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)
    return out


def jitted_modules():
    """The package's modules that import numba (or the package's jit policy, ``_jit``) at
    their top, and every module that imports one of them at its top."""
    tops = {}
    for folder, _, files in os.walk(PACKAGE):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                tops[_module_name(path)] = _imports_at_top(path)
    heavy = {JIT_MODULE}
    grown = True
    while grown:
        grown = False
        for mod, imports in tops.items():
            if mod not in heavy and any(i == "numba" or i.startswith("numba.") or i in heavy
                                        for i in imports):
                heavy.add(mod)
                grown = True
    return heavy


def test_the_scan_finds_the_kernels():
    heavy = jitted_modules()
    for mod in ("cornerbif._jit", "cornerbif.models.flow.kernel", "cornerbif.models.two_particle.kernel",
                "cornerbif.stability", "cornerbif.models.map2d.maps", "cornerbif.analysis",
                "cornerbif.obstacles.dispatch"):
        assert mod in heavy


def test_validate_loads_no_numba_and_no_kernel():
    assert len(SCENES) > 40
    forbidden = jitted_modules()
    r = subprocess.run([sys.executable, "-c", CHILD, *SCENES], capture_output=True, text=True,
                       cwd=ROOT, env=dict(os.environ, MPLBACKEND="Agg"), timeout=600)
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert [x["scene"] for x in report] == SCENES
    for x in report:
        assert x["code"] == 0, x["output"]
        assert x["output"].startswith(f"ok: {x['scene']} is a valid scene"), x["output"]
        loaded = [m for m in x["modules"] if m in forbidden or m in ("numba", "llvmlite")]
        assert not loaded, f"validate {os.path.basename(x['scene'])} loaded {loaded}"
        assert not [m for m in x["modules"] if m.startswith(("numba.", "llvmlite."))]
        # nor the file library: a scene is checked, no file opened (its default output named
        # by outputs.default_output)
        assert "h5py" not in x["modules"], f"validate {os.path.basename(x['scene'])} loaded h5py"


@pytest.mark.parametrize("table", [
    {"period": math.pi, "pieces": [{"span": math.pi, "sine": [1.0, 0.0, 1.0]}]},
    {"period": 2 * math.pi, "pieces": [{"law": "dwell", "span": math.pi / 2},
                                       {"law": "cycloidal", "span": math.pi / 2, "rise": 1.0},
                                       {"law": "constant_velocity", "span": math.pi / 2, "rise": 0.5},
                                       {"law": "polynomial_345", "span": math.pi / 2, "rise": -1.5}]},
])
def test_profile_checks_equal_the_kernels_bounds(table):
    """A cam's scale check reads its bounds in Python (``obstacles.profile.row_bound``,
    ``npp_bound``): the same numbers as the obstacle's jitted functions run as Python, also
    where they overflow (a scene's check meets its extremes)."""
    from cornerbif.models.flow import packed as P
    from cornerbif.obstacles import dispatch as O
    from cornerbif.obstacles import profile as FP
    from cornerbif.obstacles import profile as PR
    prof = PR.read(table)
    for omega, beta, k, sigma in ((2.0, 1.0, 1.0, 0.0), (1e100, 3.0, 1e60, 0.5), (0.7, 0.0, 0.0, 2.0)):
        with np.errstate(all="ignore"):
            row = P.pack({"omega": omega, "beta": beta, "k": k, "sigma": sigma}, "profile", 0.0,
                         0.0, 0.0, None, profile=prof)
            assert FP.row_bound(row, P.PC_G2_LO, P.PC_G2_HI) == O.profile_g2_abs.py_func(row)
            for slot in (P.PC_G3, P.PC_G4):
                assert FP.row_bound(row, slot) == O._profile_max.py_func(row, slot)
            for g in ((1.5, 2.5, 3.5), (1e200, 1e200, 1e200)):
                args = (row[P.BETA], row[P.OMEGA], row[P.SIGMA], row[P.K], *g)
                assert np.array_equal(FP.npp_bound(*args), O.npp_bound.py_func(*args))
