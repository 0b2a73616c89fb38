"""The extension recipes of docs/architecture.md, proven from outside the package.

``tests/plugins/cornerbif_toys`` is a package of its own: a model (``rotation``: a
contracting rotation of the plane, with its own tangent and orbit problem) and an obstacle
kind (``trapezoid``, built from cam pieces), registered by its entry points alone (the
metadata written below, as ``pip install`` writes it).  No file of cornerbif is edited and
nothing is patched: each command runs in a fresh process that finds the plug-ins.  What the
commands compute is checked against closed forms: the fixed point x* = (I - r R)^-1 (kappa, 0)
and the multipliers r e^(+-i omega) of the rotation, and, for the obstacle, the trapezoid's
height at every recorded impact time.
"""

import math
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from cornerbif import continuation_run

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PLUGINS = os.path.join(ROOT, "tests", "plugins")

pytestmark = pytest.mark.slow


@pytest.fixture
def installed(tmp_path):
    """The toys' package metadata (its one registry line per plug-in) on a path of its own."""
    info = tmp_path / "site" / "cornerbif_toys-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cornerbif-toys\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[cornerbif.models]\ntoy_rotation_plugin = cornerbif_toys.rotation\n\n"
        "[cornerbif.obstacles]\ntrapezoid = cornerbif_toys.trapezoid\n")
    path = os.pathsep.join([str(tmp_path / "site"), PLUGINS])

    def cornerbif(*args):
        env = dict(os.environ, PYTHONPATH=path, MPLBACKEND="Agg")
        return subprocess.run([sys.executable, "-c", "from cornerbif.cli import main; main()",
                               *map(str, args)], capture_output=True, text=True, env=env,
                              cwd=str(tmp_path), timeout=600)
    return cornerbif


ROTATION = """
[scene]
name = "rotation"
model = "toy_rotation_plugin"
[system]
r = 0.5
kappa = 0.1
[sweep]
omega = { start = 0.5, stop = 1.5, num = 3 }
[initial]
count = 2
[run]
transient = 80
record = 4
[output]
keep = ["section", "stability"]
"""


def fixed_point(omega, r=0.5, kappa=0.1):
    A = np.eye(2) - r * np.array([[math.cos(omega), -math.sin(omega)],
                                  [math.sin(omega), math.cos(omega)]])
    return np.linalg.solve(A, [kappa, 0.0])


def test_a_model_plugin_sweeps_plots_has_stability_and_continues(installed, tmp_path):
    (tmp_path / "rot.toml").write_text(ROTATION)
    r = installed("validate", "rot.toml")
    assert r.returncode == 0, r.stderr
    r = installed("sweep", "rot.toml", "-o", "rot.h5", "--no-progress")
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "rot.h5") as f:
        omega = f["omega"][...]
        u, v = f["section/u"][...], f["section/v"][...]
        mu = f["stability/multiplier_re"][...] + 1j * f["stability/multiplier_im"][...]
        assert (f["period"][...] == 1).all()
    for i, w in enumerate(omega):
        x = fixed_point(w)
        assert np.abs(u[i, :, -1] - x[0]).max() < 1e-12 and np.abs(v[i, :, -1] - x[1]).max() < 1e-12
        # the multipliers of the fixed point: r e^(+-i omega), each start
        assert np.abs(np.sort_complex(mu[i, 0]) - np.sort_complex(
            0.5 * np.exp([-1j * w, 1j * w]))).max() < 1e-14
    r = installed("plot", "rot.h5", "-o", "rot.png")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "rot.png").stat().st_size > 10_000

    # continuation in omega through its own orbit problem, against the closed form
    (tmp_path / "cont.toml").write_text(
        ROTATION.replace("[sweep]\nomega = { start = 0.5, stop = 1.5, num = 3 }\n", "")
        + '\n[continue]\nparameter = "omega"\nrange = [0.5, 1.5]\nstart = 1.0\nseed = "all"\n')
    r = installed("continue", "cont.toml", "-o", "cont.h5")
    assert r.returncode == 0, r.stderr + r.stdout
    res = continuation_run.read(str(tmp_path / "cont.h5"))
    (b,) = res["branches"]
    lam = np.asarray(b["param"])
    assert lam.min() <= 0.5 + 1e-9 and lam.max() >= 1.5 - 1e-9 and len(lam) > 5
    for w, a, bb in zip(lam, b["section_u"], b["section_v"]):
        x = fixed_point(w)
        assert abs(np.ravel(a)[0] - x[0]) < 1e-10 and abs(np.ravel(bb)[0] - x[1]) < 1e-10
    assert np.all(b["stable"])


TRAPEZOID = """
[scene]
name = "trapezoid"
[system]
obstacle = "trapezoid"
duty = 0.4
omega = 2.0
beta = 0.5
r = 0.8
[sweep]
kappa = { start = -0.5, stop = -0.3, num = 3 }
[initial]
count = 2
[run]
transient = 300
record = 20
[output]
keep = ["impacts", "section", "stability"]
"""


def trapezoid_height(t, omega, kappa, beta, duty):
    """z(t) of the trapezoid, from its definition (not from the kernel's pieces)."""
    phi = np.mod(omega * t, 2 * math.pi)
    rise = duty * math.pi
    g = np.where(phi < rise, phi,
                 np.where(phi < math.pi, rise,
                          np.where(phi < math.pi + rise, rise - (phi - math.pi), 0.0)))
    return kappa + beta * g


def test_an_obstacle_plugin_sweeps_plots_has_stability_and_is_refused_by_continue(
        installed, tmp_path):
    (tmp_path / "trap.toml").write_text(TRAPEZOID)
    r = installed("validate", "trap.toml")
    assert r.returncode == 0, r.stderr
    r = installed("sweep", "trap.toml", "-o", "trap.h5", "--no-progress")
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "trap.h5") as f:
        kappa = f["kappa"][...]
        t, u = f["impacts/t"][...], f["impacts/u"][...]
        status = f["stability/status"][...]
        mu = f["stability/multiplier_re"][...] + 1j * f["stability/multiplier_im"][...]
        ipc = f["impacts_per_cycle"][...]
        assert f["done"][...].all()
    hit = 0
    for i, k in enumerate(kappa):
        ok = np.isfinite(t[i])
        z = trapezoid_height(t[i][ok], 2.0, k, 0.5, 0.4)
        assert np.abs(u[i][ok] - z).max() < 1e-9           # every impact on the obstacle
        hit += int(ok.sum())
    assert hit > 50
    # multipliers where a cycle was found: det = r^(2N) for N impacts per cycle and no
    # damping (each flight area-preserving, each impact's saltation det r^2)
    ok = status == 0
    assert ok.any()
    det = np.abs(mu[..., 0] * mu[..., 1])[ok]
    assert np.abs(det - 0.8 ** (2 * ipc[ok])).max() < 1e-9
    r = installed("plot", "trap.h5", "-o", "trap.png")
    assert r.returncode == 0, r.stderr
    # its declared capability: no orbit problem, refused before any work
    (tmp_path / "trapc.toml").write_text(
        TRAPEZOID.replace("[sweep]\nkappa = { start = -0.5, stop = -0.3, num = 3 }\n", "")
        + '\n[continue]\nparameter = "kappa"\nrange = [-0.5, -0.3]\nstart = -0.4\n')
    r = installed("continue", "trapc.toml", "-o", "trapc.h5")
    assert r.returncode == 2
    assert "obstacle 'trapezoid' has no orbit solver yet" in r.stderr
    assert not (tmp_path / "trapc.h5").exists()
