"""Scenes drawn from the whole schema, run through the command line (issue 15).

Every table ([scene], [system], [sweep], [initial], [run], [output], [plot]) of every
registered model, with values that are valid, on a boundary (0, -1, 1, +-inf, nan),
overflowing (2**63, 2**64, 10**30, 1e308), of the wrong type (strings, lists, tables,
booleans), huge sizes (10**9 grid points or starts, 10**8 recorded impacts, a 10**18
transient, 2**70 events, a 2**64 seed), unknown keys and tables, ``--set`` overrides and
``--threads`` values.  Each scene is written as TOML and run in a child process limited to
CHILD_MEMORY bytes of address space, so that an attempt to allocate a 10**9-point grid fails
loudly instead of swapping the machine:

* ``cornerbif validate`` and ``cornerbif sweep --dry-run`` exit 0 or 2, never print a
  traceback and answer within QUICK_SECONDS of CPU time (the issue: "any grid in bounded
  memory and under a second"; CPU time, since the machine is shared, with room for Python's
  start-up); what validate refuses --dry-run refuses, and what --dry-run refuses (disk,
  memory, --threads) the sweep refuses;
* a scene that validates is swept: a small one (decided from the scene as validated) to
  the end, then ``cornerbif info`` on its file; a large one for PROBE_SECONDS, then killed
  (by its process id) if still running, since what is checked there is the start-up (the
  budget checks, the file's creation, the kernel's settings);
* a sweep exits 0, 2 (refused), or 1 only for a documented run-time failure (a write that
  failed, named in the message); never a traceback; within SWEEP_SECONDS (a cold numba
  cache compiles for tens of seconds once per model);
* a refusal (exit 2) leaves nothing in the output's directory: no output, no .partial, no
  .lock; validate and --dry-run never write anything; a finished sweep leaves its output
  and neither .partial nor .lock.

The default size (``SCENE_FUZZ_EXAMPLES``, 15) keeps the test to about a minute; run
``SCENE_FUZZ_EXAMPLES=400 python -m pytest tests/scenes/test_scene_property.py`` to hunt. Under
CI=1 the conftest's derandomized profile applies (the examples are then reproducible).
The ``@example`` scenes are the minimal reproducers of failures this test found; they are
checked on every run.
"""

from __future__ import annotations

import math
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
import tomllib

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from cornerbif import config, registry

CHILD_MEMORY = 2 * 2**30      # RLIMIT_AS of every child process (bytes)
QUICK_SECONDS = 3.0           # validate and --dry-run must answer within this (CPU s)
QUICK_TIMEOUT = 60.0          # ... and are killed after this (a failure either way)
SWEEP_SECONDS = 300.0         # a small sweep ends within this (a cold numba cache included)
PROBE_SECONDS = 10.0          # a large valid sweep is watched this long, then killed
SMALL_RUNS = 300              # a sweep is "small" (run to its end) up to this many runs ...
SMALL_IMPACTS = 1000          # ... of at most this many impacts (transient + record) ...
SMALL_BUDGET = 10**5          # ... with budgets (max_events, max_periods) at most this
EXAMPLES = int(os.environ.get("SCENE_FUZZ_EXAMPLES", "15"))
NCPU = os.cpu_count() or 1

MODELS = registry.models()

# ------------------------------------------------------------------ TOML out
_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k):
    return k if _BARE.match(k) else _str(k)


def _str(s):
    out = []
    for c in s:
        if c in '"\\':
            out.append("\\" + c)
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04x}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def toml_value(v):
    """Any value the strategies draw (bool, int of any size, float incl. nan/inf, str, list,
    dict) as a TOML value; tables inside tables are inline."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _str(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def toml_dumps(raw: dict) -> str:
    """A scene dict as TOML: top-level non-tables first (a key after a [table] header would
    belong to that table), then one [table] per dict."""
    lines = [f"{_key(k)} = {toml_value(v)}" for k, v in raw.items() if not isinstance(v, dict)]
    for k, body in raw.items():
        if isinstance(body, dict):
            lines.append(f"[{_key(k)}]")
            lines += [f"{_key(kk)} = {toml_value(v)}" for kk, v in body.items()]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ values
BOUNDARY = [0, -1, 1, 0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan]
HUGE_INT = [2**31, 2**53 + 1, 2**63 - 1, 2**63, 2**64, 2**70, 10**18, 10**30, -(2**63) - 1]
HUGE_FLOAT = [1e308, -1e308, 1.7976931348623157e308, 5e-324, 1e-300, 1e300]
# huge sizes, and the limits the scene format states (README) and one beyond each
HUGE_SIZE = [10**4, 10**5, 10**5 + 1, 10**6, 2**20, 2**20 + 1, 10**8, 10**8 + 1, 10**9,
             10**18, 2**58, 2**58 + 1, 2**62 - 1, 2**62, 2**63 - 1]
WRONG = [True, False, "", "abc", "1.0", "inf", "flow", [], [1, 2], [[1]], ["a", "b"], {},
         {"a": 1}, {"start": 0, "stop": 1, "num": 2}]
UNKNOWN_KEYS = ["omgea", "kapa", "bogus", "", " ", "a.b", "é", "Model", "transient", "keep",
                "x" * 40]

hostile = (st.sampled_from(BOUNDARY) | st.sampled_from(HUGE_INT) | st.sampled_from(HUGE_FLOAT)
           | st.sampled_from(WRONG) | st.integers() | st.floats() | st.text(max_size=8))


def _pick(valid, weights):
    """``valid`` or a hostile value: ``weights`` is the scene's hostility (0-100); a drawn
    integer below it makes the value hostile (shrinks towards valid)."""
    @st.composite
    def s(draw):
        if draw(st.integers(0, 99)) < weights:
            return draw(hostile)
        return draw(valid)
    return s()


def _param_valid(p):
    """Valid values of a declared parameter: its default and values near it, filtered by
    its own range check."""
    base = 1.0 if not p.default else float(p.default)
    near = st.floats(-1.0, 1.0).map(lambda x: base + x * max(abs(base), 1.0) * 0.5)
    extra = [0.0, 0.5, 1.0, 2.0, 1e-6] + ([math.inf] if p.inf_ok else [])
    # valid but extreme: subnormal, tiny, huge (each still passes the parameter's check)
    extra += [5e-324, 1e-300, 1e-10, 1e10, 1e300, 1e308, -1e308, 1.7976931348623157e308]
    return (st.sampled_from([base] + extra) | near).filter(lambda v: p.problem(v, "k") is None)


def _maybe(draw, table, key, value):
    if draw(st.booleans()):
        table[key] = value


@st.composite
def scenes(draw):
    """A raw scene dict from the whole schema of one registered model."""
    h = draw(st.sampled_from([0, 0, 0, 0, 3, 15, 50, 100]))   # hostility of the scene (%)
    model = draw(st.sampled_from(list(MODELS)))
    spec = MODELS[model]
    raw = {}
    # [scene]
    sc = {}
    _maybe(draw, sc, "name", draw(_pick(st.text(st.characters(codec="utf-8"), min_size=1,
                                                max_size=12), h)))
    _maybe(draw, sc, "title", draw(_pick(st.text(max_size=20), h)))
    sc["model"] = draw(_pick(st.just(model), h // 2))
    raw["scene"] = sc
    # [system]
    sy = {}
    for name, p in spec.params.items():
        if p.obstacles or draw(st.integers(0, 3)) == 0:
            _maybe(draw, sy, name, draw(_pick(_param_valid(p), h)))
    if spec.obstacles:
        _maybe(draw, sy, "obstacle", draw(_pick(st.sampled_from(list(spec.obstacles)), h)))
    if "section_period" in spec.system_extra and draw(st.integers(0, 5)) == 0:
        sy["section_period"] = draw(_pick(st.sampled_from([math.pi, 2 * math.pi / 2.0]), h))
    raw["system"] = sy
    # [sweep]
    if draw(st.integers(0, 2)):
        sw = {}
        names = list(spec.params) + ["omgea"]
        for _ in range(draw(st.integers(0, 3))):
            k = draw(st.sampled_from(names))
            p = spec.params.get(k)
            if p is None:
                sw[k] = {"start": 0.0, "stop": 1.0, "num": 2}
                continue
            v = _param_valid(p)
            if draw(st.booleans()):
                a, b = sorted([draw(v), draw(v)])
                ax = {"start": draw(_pick(st.just(a), h)), "stop": draw(_pick(st.just(b), h)),
                      "num": draw(_pick(st.integers(1, 4), h) | st.sampled_from(HUGE_SIZE)
                                  if h else st.integers(1, 4))}
                if a == b and isinstance(ax.get("num"), int) and ax["num"] > 1:
                    ax["num"] = 1
            else:
                ax = {"values": draw(_pick(st.lists(v, min_size=1, max_size=4), h))}
            if h and draw(st.integers(0, 9)) == 0:
                ax[draw(st.sampled_from(UNKNOWN_KEYS))] = 1
            sw[k] = ax
        _maybe(draw, sw, "follow", draw(_pick(st.sampled_from(config.FOLLOW), h)))
        raw["sweep"] = sw
    # [initial]
    ini = {}
    size = st.sampled_from(HUGE_SIZE) if h else st.nothing()
    _maybe(draw, ini, "count", draw(_pick(st.integers(1, 4), h) | size))
    _maybe(draw, ini, "seed", draw(_pick(st.integers(0, 2**32), h) | size))
    for c in spec.state:
        lo, hi = c.default
        rng = st.tuples(st.floats(lo, hi), st.floats(lo, hi)).map(lambda t: sorted(t))
        _maybe(draw, ini, c.name, draw(_pick(rng | st.just(list(c.default)), h)))
    raw["initial"] = ini
    # [run]
    rn = {}
    _maybe(draw, rn, "preset", draw(_pick(st.sampled_from(list(config.PRESETS)), h)))
    _maybe(draw, rn, "transient", draw(_pick(st.integers(0, 60), h) | size))
    _maybe(draw, rn, "record", draw(_pick(st.integers(1, 60), h) | size))
    _maybe(draw, rn, "tol", draw(_pick(st.sampled_from([1e-12, 1e-10, 1e-8]), h)))
    _maybe(draw, rn, "chatter", draw(_pick(st.sampled_from([1e-6, 1e-4]), h)))
    _maybe(draw, rn, "escape", draw(_pick(st.sampled_from([1e6, 1e3, 1e12]), h)))
    _maybe(draw, rn, "period_tol", draw(_pick(st.sampled_from([1e-6, 1e-9]), h)))
    _maybe(draw, rn, "max_events", draw(_pick(st.integers(1, 20000), h) | size))
    _maybe(draw, rn, "max_periods", draw(_pick(st.integers(1, 20000), h) | size))
    _maybe(draw, rn, "stop", draw(_pick(st.sampled_from(config.STOPS), h)))
    raw["run"] = rn
    # [output]
    obs = list(spec.observables)
    raw["output"] = {"keep": draw(_pick(st.lists(st.sampled_from(obs), unique=True)
                                        if obs else st.just([]), h))}
    # [plot]
    pl = {}
    _maybe(draw, pl, "kind", draw(_pick(st.sampled_from(config.PLOT_KINDS[:1]), h)))
    _maybe(draw, pl, "y", draw(_pick(st.sampled_from(config.PLOT_Y), h)))
    _maybe(draw, pl, "xlim", draw(_pick(st.just([0.0, 1.0]), h)))
    _maybe(draw, pl, "ylim", draw(_pick(st.just([-1.0, 1.0]), h)))
    _maybe(draw, pl, "marker_size", draw(_pick(st.just(0.5), h)))
    _maybe(draw, pl, "title", draw(_pick(st.text(max_size=10), h)))
    _maybe(draw, pl, "cycles", draw(_pick(st.just(2), h)))
    _maybe(draw, pl, "max_panels", draw(_pick(st.just(4), h)))
    _maybe(draw, pl, "ic", draw(_pick(st.just("distinct"), h)))
    if pl:
        raw["plot"] = pl
    # unknown keys and tables, tables of the wrong type, tables dropped
    if h:
        for _ in range(draw(st.integers(0, 2))):
            t = draw(st.sampled_from(list(config.TABLES) + ["bogus", "Run", ""]))
            body = raw.setdefault(t, {})
            if isinstance(body, dict):
                body[draw(st.sampled_from(UNKNOWN_KEYS))] = draw(hostile)
        for t in list(raw):
            r = draw(st.integers(0, 19))
            if r == 0:
                raw[t] = draw(hostile)                       # a table that is not a table
            elif r == 1:
                del raw[t]
    return raw


SET_KEYS = ["sweep.kappa.num", "sweep.omega0.num", "run.transient", "run.record",
            "run.max_events", "initial.seed", "initial.count", "system.omega", "system.mu",
            "run", "bogus", "", "scene.model", "sweep.kappa", "plot.kind"]
# --set KEY=VALUE: a TOML value, or any text (no NUL: a command line cannot hold one)
overrides = st.lists(st.tuples(st.sampled_from(SET_KEYS),
                               (st.sampled_from(BOUNDARY + HUGE_INT + HUGE_SIZE + WRONG)
                                .map(toml_value))
                               | st.text(st.characters(exclude_characters="\x00"), max_size=6)),
                     max_size=2).map(lambda xs: [f"{k}={v}" for k, v in xs])
threads = st.sampled_from([None] * 6 + [1, NCPU, NCPU + 1, 64, 2**31, 2**64, 0, -1])


# ------------------------------------------------------------------ child processes
def _limit():
    resource.setrlimit(resource.RLIMIT_AS, (CHILD_MEMORY, CHILD_MEMORY))


ENV = {k: v for k, v in os.environ.items() if k not in ("COLUMNS",)} | {"PYTHONUNBUFFERED": "1"}


def _cli(args, cwd, timeout):
    """Run ``python -m cornerbif.cli ARGS`` in ``cwd`` under RLIMIT_AS = CHILD_MEMORY.

    Returns (exit code, stdout, stderr, CPU seconds, peak RSS in MiB); the exit code is None
    if the child was still running at ``timeout`` seconds (it is then killed by its process
    id), negative if a signal ended it.  CPU time, not wall time, is what the bounds read:
    the machine is shared, and a busy neighbour stretches the wall clock of Python's start-up.
    """
    with tempfile.TemporaryFile("w+", errors="replace") as fo, \
            tempfile.TemporaryFile("w+", errors="replace") as fe:
        p = subprocess.Popen([sys.executable, "-m", "cornerbif.cli", *args], cwd=cwd, env=ENV,
                             stdin=subprocess.DEVNULL, stdout=fo, stderr=fe, preexec_fn=_limit)
        deadline = time.monotonic() + timeout
        while True:
            pid, status, ru = os.wait4(p.pid, os.WNOHANG)
            if pid:
                rc = os.waitstatus_to_exitcode(status)
                break
            if time.monotonic() > deadline:
                os.kill(p.pid, signal.SIGKILL)
                _, status, ru = os.wait4(p.pid, 0)
                rc = None
                break
            time.sleep(0.02)
        p.returncode = -1 if rc is None else rc      # reaped here, not by Popen
        fo.seek(0)
        fe.seek(0)
        return rc, fo.read(), fe.read(), ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024


def _tail(err, n=6):
    return "\n".join(err.strip().splitlines()[-n:])


def _no_traceback(what, rc, err):
    assert "Traceback" not in err, f"{what}: exit {rc}, a traceback:\n{_tail(err, 12)}"


def _refused_cleanly(what, out_dir, err):
    left = sorted(os.listdir(out_dir))
    assert not left, f"{what}: refused (exit 2) but left {left} behind"
    assert "error" in err.lower(), f"{what}: exit 2 without an error message: {err!r}"


def _small(scene) -> bool:
    """A scene (``config.Scene``, every default resolved) whose sweep ends in seconds."""
    runs = math.prod(scene.shape) * scene.n_ic
    return (runs <= SMALL_RUNS and scene.transient + scene.record <= SMALL_IMPACTS
            and scene.max_events <= SMALL_BUDGET and scene.max_periods <= SMALL_BUDGET)


def check_scene(raw: dict, threads=None, sets=()):
    with tempfile.TemporaryDirectory(prefix="cbfuzz") as work:
        path = os.path.join(work, "scene.toml")
        text = toml_dumps(raw) if isinstance(raw, dict) else raw
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        out_dir = os.path.join(work, "out")
        os.mkdir(out_dir)
        out = os.path.join(out_dir, "o.h5")
        set_args = [a for s in sets for a in ("--set", s)]
        thr = [] if threads is None else ["--threads", str(threads)]

        # validate
        rc, _, err, sec, mib = _cli(["validate", path, *set_args], out_dir, QUICK_TIMEOUT)
        assert rc is not None, f"validate: still running after {QUICK_TIMEOUT} s (killed)"
        _no_traceback("validate", rc, err)
        assert rc in (0, 2), f"validate: exit {rc}:\n{_tail(err)}"
        assert sec < QUICK_SECONDS, \
            f"validate: {sec:.1f} CPU s, {mib:.0f} MiB (bound {QUICK_SECONDS} s)"
        assert not os.listdir(out_dir), f"validate wrote {os.listdir(out_dir)}"
        if rc == 2:
            _refused_cleanly("validate", out_dir, err)
        valid = rc == 0

        # sweep --dry-run: nothing written
        rc, _, err, sec, mib = _cli(["sweep", path, "-o", out, "--dry-run", *thr, *set_args],
                                    out_dir, QUICK_TIMEOUT)
        assert rc is not None, f"sweep --dry-run: still running after {QUICK_TIMEOUT} s (killed)"
        _no_traceback("sweep --dry-run", rc, err)
        assert rc in (0, 2), f"sweep --dry-run: exit {rc}:\n{_tail(err)}"
        assert sec < QUICK_SECONDS, \
            f"sweep --dry-run: {sec:.1f} CPU s, {mib:.0f} MiB (bound {QUICK_SECONDS} s)"
        # what validate refuses, --dry-run refuses; what validate accepts, --dry-run may still
        # refuse for this machine (disk, memory, --threads), with the numbers
        assert rc == 2 or valid, f"sweep --dry-run: exit {rc} but validate refused the scene"
        assert not os.listdir(out_dir), f"sweep --dry-run wrote {os.listdir(out_dir)}"
        if rc == 2:
            _refused_cleanly("sweep --dry-run", out_dir, err)
        if not valid:
            return
        dry_refused = rc == 2

        # the sweep itself: small scenes to the end, large ones for PROBE_SECONDS
        # the child validated it within CHILD_MEMORY: reading it here is bounded too
        small = _small(config.loads(text, list(sets)))
        rc, _, err, sec, mib = _cli(["sweep", path, "-o", out, "--no-progress", *thr, *set_args],
                                    out_dir, SWEEP_SECONDS if small else PROBE_SECONDS)
        _no_traceback("sweep", rc, err)
        assert not dry_refused or rc == 2, \
            f"sweep: --dry-run refused the scene, the sweep gave exit {rc}:\n{_tail(err)}"
        if rc is None:
            assert not small, f"sweep: a small scene still running after {SWEEP_SECONDS} s"
            return                  # a large sweep under way: its start-up was checked
        documented = rc == 1 and re.search(r"^error: .*failed", err, re.M)
        assert rc in (0, 2) or documented, f"sweep: exit {rc}:\n{_tail(err)}"
        if rc == 2:
            _refused_cleanly("sweep", out_dir, err)
        if rc != 0:
            return
        left = sorted(os.listdir(out_dir))
        assert left == ["o.h5"], f"sweep: finished, but the directory holds {left}"
        rc, _, err, _, _ = _cli(["info", out], out_dir, QUICK_TIMEOUT)
        _no_traceback("info", rc, err)
        assert rc == 0, f"info: exit {rc}:\n{_tail(err)}"


# ------------------------------------------------------------------ the property
@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                 HealthCheck.filter_too_much])
@given(raw=scenes(), threads=threads, sets=overrides)
# the minimal reproducers of failures found by this test (see the module's docstring)
# a NUL in a string: the scene attribute cannot be written (h5py: "VLEN strings do not support
# embedded NULLs"), a traceback, and OUT.partial.init left behind
@example(raw={"scene": {"title": "a\x00b"}, "initial": {"count": 1},
              "run": {"transient": 1, "record": 1}}, threads=None, sets=[])
# a control character in a string: written raw into the file's scene attribute, which is then
# not TOML, so that `cornerbif info` refuses the file the sweep just wrote (exit 2)
@example(raw={"scene": {"title": "a\x01b"}, "initial": {"count": 1},
              "run": {"transient": 1, "record": 1}}, threads=None, sets=[])
# a subnormal frequency (valid: > 0): the section period 2 pi / omega is inf, and
# params.section_pieces does round(inf / inf) (flow: "ValueError: cannot convert float NaN to
# integer"; two_particle: "ValueError: two_particle: section_period: np.float64(inf) must be
# finite and > 0"), a traceback, exit 1, OUT.partial left behind
@example(raw={"system": {"omega": 5e-324}, "initial": {"count": 1},
              "run": {"transient": 1, "record": 1}}, threads=None, sets=[])
@example(raw={"scene": {"model": "two_particle"}, "system": {"omega0": 5e-324},
              "initial": {"count": 1}, "run": {"transient": 1, "record": 1}},
         threads=None, sets=[])
# a swept value of 1.8e308 (valid): the sweep ended, then `info` refused the file it had just
# written ("beyond 1e+100 in size, which no figure can place": a figure's limit, not info's),
# and the time estimate said "about inf days"
@example(raw={"scene": {"model": "two_particle"},
              "sweep": {"omega0": {"values": [1.7976931348623157e+308]}},
              "output": {"keep": []}}, threads=None, sets=[])
# 400 004 two-particle runs keeping everything: 9.2 GiB estimated, within the machine's free
# memory but not within the child's address-space limit (CHILD_MEMORY): the sweep started and
# ended in "out of memory" (exit 1); the budget now counts RLIMIT_AS (io.available_memory)
@example(raw={"scene": {"model": "two_particle"},
              "sweep": {"F1": {"values": [1.1, 0.9764568894583722, 0.8861662126613835, 1.0]}},
              "initial": {"count": 4},
              "output": {"keep": ["section", "wall_impacts", "impacts", "stability"]}},
         threads=None, sets=["initial.count=100001"])
# the sizes at the limits the format states: each must validate (or be refused) at once
@example(raw={"sweep": {"kappa": {"start": -0.02, "stop": 0.0, "num": 10**4},
                        "omega": {"start": 1.9, "stop": 2.1, "num": 10**4}}},
         threads=None, sets=[])
@example(raw={"sweep": {"kappa": {"start": -0.02, "stop": 0.0, "num": 10**9}}},
         threads=None, sets=[])
@example(raw={"initial": {"seed": 2**64, "count": 1}, "run": {"transient": 1, "record": 1}},
         threads=None, sets=[])
@example(raw={"run": {"transient": 10**18, "max_events": 2**70, "max_periods": 2**63}},
         threads=None, sets=[])
@example(raw={"initial": {"count": 1}, "run": {"transient": 1, "record": 1}},
         threads=NCPU + 1, sets=[])
def test_any_scene_is_run_or_refused_cleanly(raw, threads, sets):
    check_scene(raw, threads, sets)


def test_the_serializer_round_trips():
    raw = {"top": 2**70, "scene": {"name": 'a"b\\c\x01é', "": 1, "a.b": [1.5, -math.inf]},
           "sweep": {"kappa": {"start": -1e308, "stop": 5e-324, "num": 10**30}}}
    back = tomllib.loads(toml_dumps(raw))
    assert back == raw
    assert math.isnan(tomllib.loads(toml_dumps({"s": {"x": math.nan}}))["s"]["x"])


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, *sys.argv[1:]]))
