"""The reader on a sweep directory written by the real `netkf sweep` (offline: the core filter
and loss models, no DDS), of Sinopoli's scalar example over its link's loss. Independent
expectations: the points' statistics recomputed from the runs; the theory's verdict against
the closed form λ_c = 1 − 1/A² = 0.36 (Sinopoli et al. 2004, Thm 3 for C invertible: A = −1.25);
and the Fig. 7 example reading it."""
import math
import os
import subprocess
import sys

import pytest

import netkf
from conftest import PYTHON_DIR, REPO, netkf_binary

LOSSES = [0.0, 0.3, 0.5, 0.62, 0.66, 0.7]
SEEDS = 3


@pytest.fixture(scope="module")
def real_sweep(tmp_path_factory):
    exe = netkf_binary()
    out = str(tmp_path_factory.mktemp("sweep") / "sinopoli")
    cmd = [exe, "sweep", os.path.join(REPO, "deploy", "scenarios", "sinopoli-scalar.yaml"), "--vary",
           "sensors.1.link.loss=" + ",".join(str(v) for v in LOSSES), "--seeds", str(SEEDS), "--periods", "2000",
           "--offline", "--out", out]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    return out


def test_reads_the_real_sweep(real_sweep):
    s = netkf.read_sweep(real_sweep)
    assert s.varied == ["sensors.1.link.loss"] and s.mode == "offline" and s.seeds == SEEDS
    assert len(s.runs) == len(LOSSES) * SEEDS and (s.runs["status"] == "ok").all()
    assert len(s.points) == len(LOSSES)
    # Each point's statistics from its runs.
    for _, p in s.points.iterrows():
        x = s.runs[s.runs["point"] == p["point"]]["rms_error"].astype(float)
        mean = x.mean()
        se = x.std(ddof=1) / math.sqrt(len(x))
        assert math.isclose(p["rms_error_mean"], mean, rel_tol=1e-9)
        assert math.isclose(p["rms_error_se"], se, rel_tol=1e-6, abs_tol=1e-12)
        assert p["rms_error_min"] == x.min() and p["rms_error_max"] == x.max()
    # The theory: stable exactly when the arrival rate 1 − loss exceeds λ_c = 1 − 1/1.25².
    critical = 1 - 1 / 1.25 ** 2
    for _, p in s.points.iterrows():
        assert bool(p["theory_stable"]) == (1 - float(p["sensors.1.link.loss"]) > critical), p["sensors.1.link.loss"]


def test_fig7_example_reads_the_real_sweep(real_sweep, tmp_path):
    out = str(tmp_path / "fig7")
    r = subprocess.run([sys.executable, os.path.join(PYTHON_DIR, "examples", "sinopoli_fig7.py"), real_sweep,
                        "--out", out], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "critical arrival rate lambda_c = 0.36 " in r.stdout
    assert "unstable at 0.34, stable at 0.38" in r.stdout  # the sweep's verdicts bracket λ_c
