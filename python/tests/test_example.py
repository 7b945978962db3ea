"""python/examples/sinopoli_fig7.py on the sweep fixture, against the paper's numbers
(Sinopoli et al. 2004, Sec. IV-V: λ_c = 0.36 for A = -1.25; K_SS = -0.70; with λ = 0.6,
P̄ = 7.32 and K_λ = -0.93, and the static gain K_λ reaches V̄ at λ = 0.6)."""
import math
import os
import subprocess
import sys

import numpy as np
import pandas as pd

import netkf
from conftest import DATA, PYTHON_DIR


def test_fig7_table(tmp_path):
    out = str(tmp_path / "fig7")
    sweep_dir = os.path.join(DATA, "sweep-sinopoli")
    r = subprocess.run([sys.executable, os.path.join(PYTHON_DIR, "examples", "sinopoli_fig7.py"), sweep_dir,
                        "--out", out], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "critical arrival rate lambda_c = 0.36 " in r.stdout
    assert "unstable at 0.3, stable at 0.38" in r.stdout  # the sweep's theory brackets λ_c
    assert "static gains: SS = -0.7008, A_over_C = -1.2500, lambda = -0.9320" in r.stdout
    t = pd.read_csv(out + ".csv")
    assert t["lambda"].tolist() == sorted(t["lambda"]) and len(t) == 8
    row = t[np.isclose(t["lambda"], 0.6)].iloc[0]
    assert round(row["V_bar"], 2) == 7.33 and math.isclose(row["static_K_lambda"], row["V_bar"], rel_tol=1e-6)
    # Each static gain does no better than the time-varying filter's bound V̄ (paper, Fig. 6).
    stable = t[t["theory_stable"] == True]  # noqa: E712
    for col in ("static_K_SS", "static_K_A_over_C", "static_K_lambda"):
        assert (stable[col] >= stable["V_bar"] * (1 - 1e-9)).all(), col
    # K = A/C is stable down to λ_c (its λ_s equals λ_c); K_SS is not (λ_s > λ_c).
    assert math.isinf(t[np.isclose(t["lambda"], 0.38)].iloc[0]["static_K_SS"])
    assert math.isfinite(t[np.isclose(t["lambda"], 0.38)].iloc[0]["static_K_A_over_C"])
    # E[P_{k+1|k}] = A² E[P_{k|k}] + Q from the points' mean_trace_P
    pts = netkf.read_sweep(sweep_dir).stats("mean_trace_P")
    expect = (1.5625 * pts["mean"] + 1.0).to_numpy()[::-1]  # the fixture's losses ascend: λ descends
    assert np.allclose(t["E_P_pred"].to_numpy(), expect, rtol=1e-9)


def test_fig7_refuses_a_non_scalar_scenario(tmp_path):
    sweep_dir = os.path.join(DATA, "sweep-sinopoli")
    scenario = os.path.join(os.path.dirname(PYTHON_DIR), "deploy", "scenarios", "default.yaml")
    r = subprocess.run([sys.executable, os.path.join(PYTHON_DIR, "examples", "sinopoli_fig7.py"), sweep_dir,
                        "--scenario", scenario, "--out", str(tmp_path / "x")], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode != 0 and "scalar" in r.stderr
