"""The Lyapunov spectrum streamed through the flow kernel in chunks (cornerbif/models/flow/
stream.py; docs/stability.md, "Lyapunov exponents"): no impact stored, any window.

Each number against something the stream does not compute: a cycle's Floquet multipliers
(lambda_i = log|mu_i| / duration, ``tangent.cycle_multipliers`` through the stability pass),
the closed-form determinant (lambda_1 + lambda_2 = -2 sigma + 2 N log r / W), the same
spectrum read off one long recorded run (``batch_stability`` over the same impacts), and
Benettin's two-trajectory estimate on the slow exhaustive simulator tests/naive.py.
Windows are a few thousand impacts (the kernel's chunk is 4096, so most cross restarts),
but for the one of 300 000.
"""

import ctypes
import gc
import math
import os

import fd_reference as FD
import h5py
import numpy as np
import pytest

import cornerbif
from cornerbif import config, registry
from cornerbif import stability as S
from cornerbif import status as KS
from cornerbif._jit import Control, KernelStopped
from cornerbif.models.flow import packed as P
from cornerbif.models.flow import stream as ST
from cornerbif.models.flow import tangent as FT
from cornerbif.models.flow.kernel import run_batch
from cornerbif.sweep import run_sweep

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = """
[scene]
name = "stream"
model = "flow"
[system]
obstacle = "{obstacle}"
omega = {omega}
kappa = {kappa}
beta = 1.0
r = 0.8
sigma = {sigma}
k = {k}
[run]
transient = {transient}
record = {record}
[output]
keep = ["impacts", "stability"]
"""


def _scene(omega, obstacle="rectified_sine", transient=600, record=100, kappa=0.0, sigma=0.0,
           k=1.0):
    sc = config.loads(SCENE.format(obstacle=obstacle, omega=omega, kappa=kappa, sigma=sigma,
                                   k=k, transient=transient, record=record))
    spec = registry.get(sc.model)
    return sc, spec, spec.pack_points(sc, [()]), spec.int_settings(sc)


def _stream(omega, warmup, window, ics=((5.0, 0.0),), **kw):
    sc, spec, prm, ints = _scene(omega, **kw)
    return ST.lyapunov_stream(prm, np.array(ics, float), ints, warmup, window)


def _recorded_window(res, ipc):
    """The stability pass's window over a recorded run: (first step, steps), so that the
    stream's warmup = first step and window = steps - first step carry the same impacts."""
    steps = int(np.isfinite(res["t"]).sum()) - 1
    return S.lyapunov_window(steps, ipc, S.WARMUP_SHARE), steps


@pytest.mark.parametrize("omega,system", [(1.8, {}), (2.3, {"sigma": 0.02, "k": 1.2})])
def test_periodic_orbit_gives_the_floquet_exponents_and_the_determinant(omega, system):
    """A period-4 cycle of four impacts (rectified sine, omega = 1.8) and a damped cycle of
    two (omega = 2.3, sigma = 0.02, k = 1.2), both with real multipliers (the cases of
    tests/models/test_lyapunov.py): over 4000 impacts after 5000 aligning ones (whole
    cycles, across the kernel's restarts near 4096 and 8192) the streamed lambda_i equal
    log|mu_i| / duration of the recorded cycle's multipliers to 1e-8 (the recorded
    spectrum's own accuracy there; measured 1.4e-12 and 3e-14), and lambda_1 + lambda_2 =
    -2 sigma + 2 N log r / W (det S = r^2, det M = exp(-2 sigma tau)) to 1e-12 relative
    (measured 7e-14 and 4e-14)."""
    sc, spec, prm, ints = _scene(omega, record=200, **system)
    res = spec.run_items(prm, np.array([[5.0, 0.0]]), ints, sc).fields
    mu = res["mu_re"][0] + 1j * res["mu_im"][0]
    assert res["stability_status"][0] == S.OK and np.all(mu.imag == 0)
    want = np.log(np.abs(mu)) / res["cycle_duration"][0]
    out = _stream(omega, 5000, 4000, record=200, **system)
    assert out["lyapunov_status"][0] == S.OK and out["status"][0] == KS.OK
    assert out["impacts"][0] == 4000
    lam, W = out["lyapunov"][0], out["lyapunov_window"][0]
    assert np.allclose(lam, want, rtol=0, atol=1e-8), (lam, want)
    sigma = system.get("sigma", 0.0)
    det = -2 * sigma + 2 * 4000 * math.log(0.8) / W
    assert math.isclose(lam.sum(), det, rel_tol=1e-12), (lam.sum(), det)


def test_stream_equals_the_recorded_spectrum_on_a_periodic_orbit():
    """Rectified sine, omega = 1.8 (period 4): one run recording 20 000 impacts after a
    transient of 600, its spectrum by the stability pass (``batch_stability``: the first
    quarter aligns, the rest trimmed to whole cycles: steps 4999 .. 19 999), and the same
    impacts streamed (warmup 4999, window 15 000: four restarts): equal to 1e-9 relative,
    the averaging time to 1e-12 (measured 1.3e-12 and 0: the restarts land on the cycle)."""
    sc, spec, prm, ints = _scene(1.8, record=20_000)
    run = spec.run_items(prm, np.array([[5.0, 0.0]]), ints, sc)
    res = {k: v[0] for k, v in run.fields.items()}
    start, steps = _recorded_window(res, int(run.ipc[0]))
    assert (start, steps) == (4999, 19_999) and res["lyapunov_status"] == S.OK
    out = ST.lyapunov_stream(prm, np.array([[5.0, 0.0]]), ints, start, steps - start)
    assert out["lyapunov_status"][0] == S.OK and out["impacts"][0] == steps - start
    assert np.allclose(out["lyapunov"][0], res["lyapunov"], rtol=1e-9, atol=0)
    assert math.isclose(out["lyapunov_window"][0], res["lyapunov_window"], rel_tol=1e-12)


def test_stream_agrees_with_the_recorded_spectrum_of_a_chaotic_run_within_its_spread():
    """Fig. 1(a) (configs/fig01a.toml: sine, kappa = 0, beta = 1, r = 0.8), omega = 2.84 in
    its chaotic window: one run recording the largest record, 100 000 impacts, after a
    transient of 500, its spectrum by the stability pass over steps 24 999 .. 99 999 (no
    cycle: no trimming), and the same 75 000 impacts streamed (24 restarts).  Within its
    first chunk (4096 impacts) the stream is the recorded run, step for step; each restart
    then moves the orbit by the rounding of its time (ulp(t) <= 3e-11 here), which the
    chaos amplifies (lambda_1 ~ 0.2 takes 1e-11 to order 1 in ~130 time units), so the two
    estimates agree within their statistical spread only: that of lambda_1 over ~150 000
    time units is about 1e-3 (0.009 at 1200 time units, docs/stability.md, falling like
    1/sqrt(window)); allowed 5e-3 on lambda_1 and 1e-2 on lambda_2, 1 % on the averaging
    time (measured lambda_1 0.19601 recorded against 0.19723 streamed, lambda_2 -0.42390
    against -0.42507, the averaging time 146 879 against 146 907)."""
    sc, spec, prm, ints = _scene(2.84, obstacle="sine", transient=500, record=100_000)
    assert sc.record == config.MAX_RECORD
    run = spec.run_items(prm, np.array([[5.0, 0.0]]), ints, sc)
    res = {k: v[0] for k, v in run.fields.items()}
    start, steps = _recorded_window(res, int(run.ipc[0]))
    assert run.ipc[0] == 0 and (start, steps) == (24_999, 99_999)
    assert res["lyapunov_status"] == S.OK and res["lyapunov"][0] > 0.1
    out = ST.lyapunov_stream(prm, np.array([[5.0, 0.0]]), ints, start, steps - start)
    assert out["lyapunov_status"][0] == S.OK and out["impacts"][0] == 75_000
    lam = out["lyapunov"][0]
    assert abs(lam[0] - res["lyapunov"][0]) < 5e-3, (lam, res["lyapunov"])
    assert abs(lam[1] - res["lyapunov"][1]) < 1e-2, (lam, res["lyapunov"])
    assert math.isclose(out["lyapunov_window"][0], res["lyapunov_window"], rel_tol=1e-2)
    # within the first chunk nothing was restarted: the numbers of the recorded run's first
    # 4001 impacts (the kernel's own corner offsets: the file's are NaN for the sine)
    first = ST.lyapunov_stream(prm, np.array([[5.0, 0.0]]), ints, 1000, 3000)
    rec = _kernel_record(prm, ints, np.array([[5.0, 0.0]]), 4001)
    np.testing.assert_array_equal(rec[0], res["t"][:4001])
    want = FT.run_lyapunov(prm[0], *rec, 0, 0.25)
    assert first["lyapunov_status"][0] == S.OK and want[3] == S.OK
    assert tuple(first["lyapunov"][0]) == want[:2]


def _kernel_record(prm, ints, ics, n):
    """One run's first n impacts after the transient from the kernel itself (``run_batch``):
    t, u, v-, v+ and the corner offsets as law (5) used them."""
    settings = ST.stream_settings(ints, n)
    o = [np.full((1, n), np.nan) for _ in range(7)]
    st = np.zeros(1, np.int8)
    run_batch(prm, settings, ics, *o[:5], np.zeros((1, n), np.int64), o[5], o[6], st,
              np.zeros((1, 2)), np.zeros(1, np.int64))
    assert st[0] == KS.OK
    return [x[0] for x in o[:5]]


def _hwm_reset():
    """Return the free heap to the system (glibc's malloc_trim: what earlier tests freed
    stays resident otherwise, and an allocation reusing it would not show), reset this
    process's peak resident size (Linux: /proc/self/clear_refs, 5) and return its resident
    size now, in bytes; None where it cannot."""
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return _status("VmRSS")
    except (OSError, AttributeError):
        return None


def _status(key):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    raise KeyError(key)


def test_a_window_past_the_largest_record_is_bounded_by_the_chunk_and_matches_benettin():
    """Fig. 1(a), omega = 2.84: a window of 300 000 impacts (three times run.record's limit
    of 100 000), streamed through buffers of CHUNK = 4096 impacts.  The process's peak
    resident memory grows by less than 4 MB during it (the buffers: 8 x 4096 x 8 B = 256
    KiB; measured 0.25 MB, the free heap returned to the system first), while the same
    measurement of the kernel recording those impacts grows by more than 15 MB (its 8
    outputs x 301 000 x 8 B = 19 MB; measured 19.0 MB).  lambda_1 is positive and within
    0.03 of Benettin's two-trajectory estimate on the slow simulator over 2000 periods
    (~4400 time units) from the kernel's last section state: the spread of that estimate
    is about 0.006 (0.009 measured over 1000 periods, sd over 8 starts, falling like
    1/sqrt(window)), of the streamed one over ~590 000 time units about 4e-4 (sd over 4
    starts); measured 0.1962 streamed against Benettin's 0.2024."""
    sc, spec, prm, ints = _scene(2.84, obstacle="sine", transient=500, record=100)
    ics = np.array([[5.0, 0.0]])
    ST.lyapunov_stream(prm, ics, ints, 10, 10)           # compiled before the measurement
    before = _hwm_reset()
    out = ST.lyapunov_stream(prm, ics, ints, 1000, 300_000)
    if before is not None:
        grown = _status("VmHWM") - before
        assert grown < 4 << 20, grown
        before = _hwm_reset()
        _kernel_record(prm, ints, ics, 301_001)
        assert _status("VmHWM") - before > 15 << 20     # the measurement sees a record
    assert 300_000 > config.MAX_RECORD and out["impacts"][0] == 300_000
    assert out["lyapunov_status"][0] == S.OK and out["status"][0] == KS.OK
    lam = out["lyapunov"][0, 0]
    omega = 2.84
    T = 2 * math.pi / omega
    res = cornerbif.simulate(5.0, 0.0, transient=500, record=600, obstacle="sine", omega=omega,
                             kappa=0.0, beta=1.0, r=0.8)
    su, sv = res["su"][0], res["sv"][0]
    n_sec = int(np.isfinite(su).sum())
    ref = FD.benettin(omega, su[n_sec - 1], sv[n_sec - 1], n_sec * T, 2000)
    assert lam > 0.1 and ref > 0.1
    assert abs(lam - ref) < 0.03, (lam, ref)


def test_sticking_gives_minus_infinity_and_stuck_for_good_too():
    """Smooth wall (sine), omega = 5: the particle sticks once a period (as in
    test_lyapunov.py): the first step of the window that goes through a stick collapses the
    tangent, lambda = -inf, STICKING, the stream ending there (the kernel's status OK).
    kappa = 2, omega = 0.5: the contact force N >= k^2 kappa - beta |k^2 - omega^2| = 1.25
    > 0 for all time, so the run sticks for good (kernel status STUCK) before the window:
    -inf, STICKING, no impact averaged."""
    out = _stream(5.0, 100, 1000, obstacle="sine", transient=500)
    assert out["lyapunov_status"][0] == S.STICKING and out["status"][0] == KS.OK
    assert np.all(out["lyapunov"][0] == -np.inf) and 1 <= out["impacts"][0] < 1000
    out = _stream(0.5, 100, 1000, ics=((4.0, 0.0),), obstacle="sine", transient=0, kappa=2.0)
    assert out["lyapunov_status"][0] == S.STICKING and out["status"][0] == KS.STUCK
    assert np.all(out["lyapunov"][0] == -np.inf) and out["impacts"][0] == 0


def test_a_run_without_impacts_has_no_window_and_says_why():
    """kappa = -10 under a free oscillation of amplitude 1 (omega = 2): no impact within the
    budget, kernel status NO_IMPACT, exponents NaN with NO_WINDOW, nothing averaged."""
    out = _stream(2.0, 10, 100, ics=((1.0, 0.0),), obstacle="sine", transient=0, kappa=-10.0)
    assert out["status"][0] == KS.NO_IMPACT and out["lyapunov_status"][0] == S.NO_WINDOW
    assert np.all(np.isnan(out["lyapunov"][0])) and out["impacts"][0] == 0


def test_a_cam_profile_streams_and_matches_its_recorded_spectrum():
    """configs/cam_345.toml (a follower on a 3-4-5 cam, no corners: r = 0.5, k = 1, F = -2,
    Omega = 0) at omega = 2.0, a periodic orbit: its rows are the profile's wider ones
    (``stream_batch_profile``).  Against the stability pass on one run recording 12 000
    impacts (steps 2999 .. 11 999 trimmed to whole cycles, two restarts on the stream):
    equal to 1e-9 relative, and lambda_1 + lambda_2 = 2 N log r / W (sigma = 0) to 1e-12
    relative (measured -0.3279, -0.5547 both ways, equal to the last bit; the sum 1.5e-13)."""
    sc = config.load(os.path.join(ROOT, "configs", "cam_345.toml"),
                     ["run.record=12000", 'output.keep=["impacts", "stability"]'])
    spec = registry.get(sc.model)
    i = int(np.argmin(np.abs(sc.axes[0].array - 2.0)))
    prm = spec.pack_points(sc, [(i,)])
    assert P.wide_rows(prm) and prm[0, P.OMEGA] == 2.0
    ints = spec.int_settings(sc)
    ics = np.array([[2.0, 0.0]])
    run = spec.run_items(prm, ics, ints, sc)
    res = {k: v[0] for k, v in run.fields.items()}
    start, steps = _recorded_window(res, int(run.ipc[0]))
    assert run.ipc[0] > 0 and res["lyapunov_status"] == S.OK
    out = ST.lyapunov_stream(prm, ics, ints, start, steps - start)
    assert out["lyapunov_status"][0] == S.OK and out["status"][0] == KS.OK
    assert np.allclose(out["lyapunov"][0], res["lyapunov"], rtol=1e-9, atol=0)
    W = out["lyapunov_window"][0]
    assert math.isclose(out["lyapunov"][0].sum(), 2 * (steps - start) * math.log(0.5) / W,
                        rel_tol=1e-12)


def test_a_stopped_control_raises_and_nothing_half_computed_returns():
    """Under a sweep's control whose stop flag is set (``_jit.Control``), the call raises
    ``KernelStopped`` (its outputs incomplete), as the sweep's kernels do."""
    sc, spec, prm, ints = _scene(2.84, obstacle="sine", transient=500)
    control = Control()
    control.stop()
    ints = ints.copy()
    ints[P.I_CONTROL] = control.address
    with pytest.raises(KernelStopped):
        ST.lyapunov_stream(prm, np.array([[5.0, 0.0], [6.0, 0.0]]), ints, 100, 1000)


def test_a_scene_streams_its_exponents_with_run_lyapunov_impacts(tmp_path):
    """``run.lyapunov_impacts = 50000`` in a sweep of the period-4 orbit at omega = 1.8
    (rectified sine; a few starts reach a two-impact cycle): the file's exponents are
    averaged over 50 000 impacts after the transient, far past its record of 100, and equal
    log|mu_i| / duration of each run's cycle multipliers stored beside them (the recorded
    cycle's monodromy) to 1e-9 where they are real (a complex pair: their sum to 1e-9, each
    to 1e-4); the window is the last 37 500 impacts (3/4, whole cycles),
    37 500 / ipc cycle durations."""
    text = SCENE.format(obstacle="rectified_sine", omega=1.8, kappa=0.0, sigma=0.0, k=1.0,
                        transient=600, record=100).replace(
        "[output]", "lyapunov_impacts = 50000\n[output]")
    out = str(tmp_path / "s.h5")
    run_sweep(config.loads(text), out)
    with h5py.File(out) as f:
        lam = f["stability/lyapunov"][...].reshape(-1, 2)
        win = f["stability/lyapunov_window"][...].ravel()
        im = f["stability/multiplier_im"][...].reshape(-1, 2)
        mu = np.hypot(f["stability/multiplier_re"][...].reshape(-1, 2), im)
        dur = f["stability/cycle_duration"][...].ravel()
        ipc = f["impacts_per_cycle"][...].ravel()
        st = f["stability/lyapunov_status"][...].ravel()
    assert (ipc == 4).sum() >= 4 and (ipc > 0).all() and (st == S.OK).all()
    want = np.log(mu) / dur[:, None]
    real = (im == 0.0).all(axis=1)
    assert real.sum() >= 4
    np.testing.assert_allclose(lam[real], want[real], rtol=1e-9)
    # a complex pair: the sum exactly, each within the QR basis's bounded turning over the
    # window (an error ~ 1/window, not geometric)
    np.testing.assert_allclose(lam.sum(axis=1), want.sum(axis=1), rtol=1e-9)
    np.testing.assert_allclose(lam[~real], want[~real], rtol=1e-4)
    np.testing.assert_allclose(win, 37500 / ipc * dur, rtol=1e-9)


@pytest.mark.parametrize("change, said", [
    ('model = "map2d"', "= 1000: exponents streamed over any number of impacts are implemented "
                        "for model 'flow', not 'map2d'"),
    ('keep = ["impacts"]', 'output.keep must contain "stability"'),
    ("lyapunov_impacts = 0", "must be an integer in 1.."),
    ("lyapunov_impacts = 2.5", "must be an integer in 1.."),
])
def test_run_lyapunov_impacts_refuses_what_it_cannot_do(change, said):
    """Refused before any work, naming the key and the value."""
    text = SCENE.format(obstacle="rectified_sine", omega=1.8, kappa=0.0, sigma=0.0, k=1.0,
                        transient=600, record=100).replace(
        "[output]", "lyapunov_impacts = 1000\n[output]")
    if change.startswith("model"):
        text = ('[scene]\nname = "m"\nmodel = "map2d"\n[system]\nomega = 1.999\nkappa = -0.01\n'
                'r = 0.8\n[run]\nlyapunov_impacts = 1000\n[output]\nkeep = ["stability"]\n')
    elif change.startswith("keep"):
        text = text.replace('keep = ["impacts", "stability"]', change)
    else:
        text = text.replace("lyapunov_impacts = 1000", change)
    with pytest.raises(config.SceneError) as e:
        config.loads(text)
    assert "run.lyapunov_impacts" in str(e.value) and said in str(e.value)
