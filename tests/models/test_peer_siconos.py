"""The Siconos benchmark peer (benchmarks/peer_siconos.py) and its reference helper."""

import json
import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PEER = os.path.join(ROOT, "benchmarks", "peer_siconos.py")
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))

import siconos_ref  # noqa: E402

SYSTEM_PYTHON = "/usr/bin/python3"


def _has_siconos(python):
    if not os.path.exists(python):
        return False
    return subprocess.run([python, "-c", "import siconos.kernel"],
                          capture_output=True).returncode == 0


def test_one_step_reference_on_the_eq6_orbit():
    """Paper eq 6 (w = 2, kappa = 0, r = 0.8): from the impact at t = pi (u = 0, v+ = 18)
    the next impact is at exactly 2 pi; a state 1e-4 below the wall (as Moreau-Jean
    leaves it) is projected onto the wall first, so the answer is the same."""
    q = dict(obstacle="sine", omega=2.0, kappa=0.0, beta=1.0, r=0.8, t0=math.pi, u0=0.0,
             v0=18.0, t_next=2 * math.pi)
    assert siconos_ref.one_step(q) == pytest.approx(2 * math.pi, abs=1e-9)
    assert siconos_ref.one_step(dict(q, u0=-1e-4)) == pytest.approx(2 * math.pi, abs=1e-9)


def test_without_siconos_writes_unavailable(tmp_path):
    """CI has no Siconos: one line on stdout and {"available": false}, exit code 0."""
    if _has_siconos(sys.executable):
        pytest.skip("this interpreter has siconos")
    out = tmp_path / "peer.json"
    p = subprocess.run([sys.executable, PEER, "--json", str(out), "--smoke"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert len(p.stdout.strip().splitlines()) == 1 and "siconos" in p.stdout
    assert json.loads(out.read_text())["available"] is False


@pytest.mark.skipif(not _has_siconos(SYSTEM_PYTHON), reason="python3-siconos not installed")
def test_siconos_event_driven_on_the_eq6_orbit(tmp_path):
    """Siconos event-driven, started on u = 18|sin t| (eq 6), impacts at n pi with
    v+ = 18; Moreau-Jean h = 0.01 is first order: off by more than h/10 but less than 10 h."""
    out = tmp_path / "peer.json"
    p = subprocess.run([SYSTEM_PYTHON, PEER, "--json", str(out), "--smoke", "--ref-python",
                        ""], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    res = json.loads(out.read_text())
    assert res["available"] is True and "error" not in res
    rows = {(r["scheme"].split()[0], r["scene"][:4]): r for r in res["rows"]}
    ed = rows[("event-driven", "eq6:")]
    assert ed["n_impacts"] == 20 and ed["impacts_at_consecutive_n_pi"]
    assert ed["max_impact_time_error"] < 1e-9 and ed["max_v_out_error"] < 1e-9
    mj = rows[("Moreau-Jean", "eq6:")]
    assert 1e-3 < mj["max_impact_time_error"] < 0.1
    # the grazing family: eps = -1e-3 is deep enough for every scheme
    for g in res["grazing"].values():
        assert g["runs"][1]["eps"] == -1e-3 and g["runs"][1]["impact_near_top"]
