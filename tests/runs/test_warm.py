"""``cornerbif warm``: what it compiles is what a first run compiles.

The check is independent of the warm-up scenes' own claims: after ``cornerbif warm flow`` in an
empty numba cache, a *different* process asks numba's cache, kernel by kernel, whether the
shipped quick-start scene, a cam scene and a continuation scene would compile anything
(``engine.cold_compiles``, which reads numba's cache index), and then runs the quick start and
counts numba's compile events (none may happen)."""

import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from cornerbif import config, registry, warm
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.parametrize("model", ["flow", "two_particle", "map2d"])
def test_every_warm_up_scene_is_a_valid_scene_of_its_model(model):
    ws = registry.get(model).warmups
    assert ws, f"{model} declares no warm-up"
    for w in ws:
        scene = config.loads(w.scene)
        assert scene.model == model
        assert w.command in ("sweep", "continue")
        assert (w.command == "continue") == bool(scene.cont)


def test_warm_refuses_bad_input_before_any_work():
    r = CliRunner().invoke(main, ["warm", "flwo"])
    assert r.exit_code == 2 and "unknown model 'flwo'" in r.output and "flow" in r.output
    r = CliRunner().invoke(main, ["warm", "flow", "--all"])
    assert r.exit_code == 2 and "not both" in r.output


def test_groups_run_longest_first_by_the_declared_compile_times():
    todo = warm.groups(["flow", "map2d"])
    secs = {g: warm.expected_seconds(ws) for g, ws in todo.items()}
    assert secs["flow"] > secs["map2d"] > 0


CHECK = r"""
import json, sys
from numba.core import event
from cornerbif import config, engine
from cornerbif.cli import main
cold = {}
for name, what in [("fig06a", ("sweep",)), ("cam_cycloidal", ("sweep",)),
                   ("cont_beta", ("continuation",))]:
    scene = config.load(f"configs/{name}.toml")
    cold[name] = [n for n, _ in engine.cold_compiles(scene, what)]
compiled = []
class L(event.Listener):
    def on_start(self, ev):
        f = ev.data["dispatcher"].py_func
        compiled.append(f.__module__ + "." + f.__qualname__)
    def on_end(self, ev):
        pass
event.register("numba:compile", L())
scene, axis = (sys.argv[2], sys.argv[3]) if len(sys.argv) > 3 else ("fig06a", "kappa")
try:
    main(["sweep", f"configs/{scene}.toml", "-o", sys.argv[1], "--no-progress",
          "--set", f"sweep.{axis}.num=3", "--set", "initial.count=2"])
except SystemExit as e:
    assert e.code in (0, None), e.code
print(json.dumps({"cold": cold, "compiled": compiled}))
"""


@pytest.mark.slow
def test_after_warm_a_first_run_compiles_nothing(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-c", "from cornerbif._entry import main; main()", "warm",
                        "flow"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "compiling the flow kernel" in r.stderr       # the cache was empty: announced
    assert "ready: flow" in r.stdout
    r = subprocess.run([sys.executable, "-c", CHECK, str(tmp_path / "q.h5")], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    import json
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["cold"] == {"fig06a": [], "cam_cycloidal": [], "cont_beta": []}
    assert out["compiled"] == []


@pytest.mark.slow
def test_the_analysis_compiled_aside_is_the_one_a_sweep_loads(tmp_path):
    """``engine.compiling_aside`` compiles the cycle analysis in a second process: only worth
    it if that process compiles the very signatures a sweep calls, which numba then loads
    from its cache instead of compiling (counted here by numba's compile events)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), CORNERBIF_COMPILE_BESIDE="0")
    r = subprocess.run([sys.executable, "-c", "from cornerbif.engine import compile_analysis; "
                        "compile_analysis()"], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    r = subprocess.run([sys.executable, "-c", CHECK, str(tmp_path / "q.h5")], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    import json
    compiled = json.loads(r.stdout.strip().splitlines()[-1])["compiled"]
    assert "cornerbif.models.flow.kernel.run_batch" in compiled    # cold: compiled here
    for name in ("analysis.detect_cycles", "analysis.detect_cycle", "analysis.cycle_signatures",
                 "chunkwrite._shuffle_bytes_py"):
        assert "cornerbif." + name not in compiled, name


@pytest.mark.slow
@pytest.mark.parametrize("kernel, scene, axis", [
    ("the flow kernel", "fig06a", "kappa"),
    ("the flow kernel for a cam profile", "cam_cycloidal", "omega"),
    ("the two-particle kernel", "fig19a", "omega0"),
    ("the linear kernel", "bouncing_ball", '"contact.T.beta"')])
def test_the_compile_plan_is_what_a_first_sweep_compiles(tmp_path, kernel, scene, axis):
    """``compile_plan.PLANS`` lists helpers with the argument types a first run compiles them
    for (benchmarks/compile_plan.py recorded them).  After a second process compiled a
    kernel's plan, a first sweep must load every planned helper from numba's cache: a helper
    whose arguments changed since would be compiled again here (run
    benchmarks/compile_plan.py), and its plan entry would be wasted work."""
    from cornerbif.compile_plan import PLANS
    planned = {"cornerbif." + name for name, _ in PLANS[kernel]}
    assert len(planned) >= 5
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), CORNERBIF_COMPILE_BESIDE="0")
    r = subprocess.run([sys.executable, "-c", "import sys; from cornerbif.engine import "
                        "compile_beside; compile_beside(sys.argv[1:])", kernel], cwd=ROOT,
                       env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    r = subprocess.run([sys.executable, "-c", CHECK, str(tmp_path / "q.h5"), scene, axis],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    import json
    compiled = set(json.loads(r.stdout.strip().splitlines()[-1])["compiled"])
    # the event loop, not planned: compiled here
    assert any(c.endswith((".run_one", "._flights")) for c in compiled)
    assert not planned & compiled, sorted(planned & compiled)


ALL_PLAN = r"""
import sys
from cornerbif import config, engine
from cornerbif.engine import compile_beside
scene_path, what, sets, kernel = sys.argv[1], sys.argv[2], sys.argv[3:-1], sys.argv[-1]
compile_beside([kernel])
scene = config.load(scene_path, sets)
cold = [name for name, _ in engine.cold_compiles(scene, (what,))]
assert kernel not in cold, cold
print("ok", cold)
"""


@pytest.mark.slow
@pytest.mark.parametrize("kernel, scene, what, sets", [
    ("the flow stability kernel", "fig04c", "sweep",
     ['output.keep=["impacts", "section", "stability"]']),
    ("the two-particle stability kernel", "fig19a", "sweep",
     ['output.keep=["impacts", "section", "stability"]']),
    ("the flow continuation's functions", "cont_beta", "continuation", []),
    ("the two-particle continuation's functions", "cont_fig19", "continuation", []),
    ("the linear stability pass", "bouncing_ball", "sweep", ['output.keep=["impacts", "stability"]'])])
def test_a_kernel_compiled_beside_is_the_one_a_first_run_would_compile(tmp_path, kernel, scene,
                                                                        what, sets):
    """A kernel that ``compile_plan.PLANS`` gives whole to the second process: after that
    process ran, numba's cache holds every function the announcement of a first run checks
    for it (``engine.cold_compiles`` reads the cache index), so the first run loads it."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), CORNERBIF_COMPILE_BESIDE="0")
    r = subprocess.run([sys.executable, "-c", ALL_PLAN, f"configs/{scene}.toml", what, *sets,
                        kernel], cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]


@pytest.mark.slow
@pytest.mark.parametrize("model, kwargs, kernel", [
    ("map2d", "omega=1.999, kappa=-0.01, r=0.8", "the map2d kernels"),
    ("flow", "omega=1.999, kappa=-0.01, beta=1.0, r=0.8", "the flow kernel")])
def test_simulate_says_its_first_compile(tmp_path, model, kwargs, kernel):
    """``cornerbif.simulate`` from Python says a first compile on stderr, as the commands do;
    once cached it says nothing (it announces only what it calls: no file writer)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    code = (f"import cornerbif; r = cornerbif.simulate(1.0, 0.01, model={model!r}, {kwargs}, "
            "transient=10, record=8); print(r['status'])")
    first = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                           text=True, timeout=900)
    assert first.returncode == 0, first.stderr[-2000:]
    assert f"compiling {kernel}" in first.stderr
    again = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                           text=True, timeout=900)
    assert again.returncode == 0 and "compiling" not in again.stderr, again.stderr[-2000:]
