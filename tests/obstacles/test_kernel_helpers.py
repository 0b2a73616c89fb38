"""The kernels' shared helpers: the per-obstacle quantities of obstacles/dispatch.py, the one
smallest-rotation routine and the one winding number (issue 14)."""

import math
import pathlib
import re

import numpy as np
import pytest

from cornerbif import analysis
from cornerbif.models.flow import packed as P
from cornerbif.models.map2d import maps as maps2d
from cornerbif.numerics.oscillator import derive
from cornerbif.obstacles import dispatch as OB

ROOT = pathlib.Path(__file__).resolve().parents[2]
NAMES = ("sine", "rectified_sine", "triangle")


def _row(obstacle, **kw):
    values = dict(omega=1.999, kappa=-0.01, beta=1.0, r=0.8, sigma=0.0, k=1.0)
    values.update(kw)
    return P.pack(values, obstacle, tol=1e-12, chatter=1e-6, escape=1e6, section_period=None)


@pytest.mark.parametrize("name", NAMES)
def test_obstacle_pieces_match_the_declaration(name):
    p = _row(name)
    L0, L1, per = OB.piece_lengths(p)
    assert L0 > 0.0 and L1 > 0.0 and per == pytest.approx(L0 + L1, rel=1e-15)
    # the early stop's lag is the obstacle's pieces per period (its kind's declaration)
    kind = P.OBSTACLES[name]
    assert OB.cycle_lag(p) == kind.pieces_per_period()
    # the pieces of one forcing period add up to it
    n = kind.pieces_per_period()
    total = sum(OB.piece_length(OB.derived_tuple(derive(p)), j) for j in range(n))
    assert total == pytest.approx(kind.period(p[P.OMEGA]), rel=1e-14)
    assert OB.sinusoidal(p) == (name != "triangle")


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("k,sigma,F", [(1.0, 0.0, 0.0), (1.3, 0.05, 0.3), (0.7, 0.2, 0.0)])
def test_obstacle_bounds_hold_on_a_fine_grid(name, k, sigma, F):
    """zpp_range, zppp_max, zpppp_max, contact_npp and sturm_floors bound what z_state gives."""
    p = _row(name, k=k, sigma=sigma, F=F, Omega=1.3, theta1=1.7, theta2=2.9)
    d = derive(p)
    w = p[P.OMEGA]
    W = p[P.F_OMEGA]
    for j in (0, 1, 2, 3):
        L = OB.piece_length(d, j)
        tau = np.linspace(0.0, L, 2001)
        st = np.array([OB.z_state(p, j, t) for t in tau])
        z, zp, zpp, zppp = st.T
        lo, hi = OB.zpp_range(p, j)
        assert np.all(zpp >= lo - 1e-12) and np.all(zpp <= hi + 1e-12)
        assert np.all(np.abs(zppp) <= OB.zppp_max(p) + 1e-12)
        if OB.sinusoidal(p):
            zpppp = -w * w * zpp
            assert np.all(np.abs(zpppp) <= OB.zpppp_max(p) + 1e-12)
        # |N''| with N = z'' + 2 sigma z' + k^2 z - f: z'''' + 2 sigma z''' + k^2 z'' - f''
        zpppp = -w * w * zpp if OB.sinusoidal(p) else 0.0 * zpp
        t = OB.piece_start(d, j) + tau
        fpp = -F * W * W * np.cos(W * t)
        npp = zpppp + 2.0 * sigma * zppp + k * k * zpp - fpp
        assert np.all(np.abs(npp) <= OB.contact_npp(p, abs(F) * W * W) * (1 + 1e-12) + 1e-12)
        # the Sturm floor: -k^2 z - z'' >= f_min = k^2 * floor
        f0, f1 = OB.sturm_floors(p, d)
        floor = f0 if j % 2 == 0 else f1
        assert np.all(-k * k * z - zpp >= k * k * floor - 1e-12)


def test_kernels_read_no_obstacle_code():
    """A new obstacle touches obstacles/dispatch.py (and its declaration) only: no kernel
    compares obstacle codes."""
    for f in ("models/flow/kernel.py", "models/two_particle/kernel.py", "numerics/roots.py",
              "numerics/oscillator.py"):
        src = (ROOT / "cornerbif" / f).read_text()
        for line in src.splitlines():
            if re.search(r"\b(SINE|RECTIFIED_SINE|TRIANGLE)\b", line) and "==" in line:
                pytest.fail(f"{f}: {line.strip()}")
            if "[P.OBSTACLE]" in line:
                pytest.fail(f"{f}: {line.strip()}")


@pytest.mark.parametrize("word", ["bbg", "gbb", "bgb", "abgab", "b" * 11 + "g" + "b" * 12 + "g",
                                  "g", "ab", "ba", "bbbb"])
def test_smallest_rotation(word):
    codes = np.frombuffer(word.encode(), np.uint8)
    r = analysis.smallest_rotation(codes, 0, len(word))
    rots = [word[i:] + word[:i] for i in range(len(word))]
    assert word[r:] + word[:r] == min(rots)
    assert r == rots.index(min(rots))
    # the same with an offset and with maps2d's region codes (a < b < g as 0 < 1 < 2)
    padded = np.concatenate([np.zeros(3, np.uint8), codes])
    assert analysis.smallest_rotation(padded, 3, len(word)) == r
    regions = np.array(["abg".index(ch) for ch in word], np.int8)
    assert analysis.smallest_rotation(regions, 0, len(word)) == r
    assert maps2d.smallest_rotation is analysis.smallest_rotation


def test_winding_number_reads_every_word_form():
    W = analysis.winding_number
    assert math.isnan(W(""))
    assert W("bbbg") == 0.25
    assert W("bbxg") == 0.25                       # a word of detect_cycle, x included
    assert W("b^11 g") == pytest.approx(1 / 12)    # W = 1/(N+1)
    assert W("b12 g b11 g") == pytest.approx(2 / 25)
    assert W("(\u03b2^3\u03b3)") == 0.25
    with pytest.raises(ValueError):
        W("b^3 q")
