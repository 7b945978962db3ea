#!/usr/bin/env python3
"""Sinopoli et al. 2004, Fig. 7, from a `netkf sweep` directory: the expected state error
covariance of the time-varying (intermittent Kalman) filter against the arrival rate λ, with
the bounds S̄ ≤ E[P] ≤ V̄ (Thm 4, 6), the critical arrival rate λ_c, and the paper's static-gain
estimators (eq. 25) for comparison.

  netkf sweep deploy/scenarios/sinopoli-scalar.yaml --vary sensors.1.link.loss=0:0.62:12 \\
      --seeds 20 --periods 300 --offline --out sweep-fig7
  python3 python/examples/sinopoli_fig7.py sweep-fig7 --out fig7

writes fig7.csv (one row per λ) and, when Debian's python3-matplotlib is installed, fig7.png;
prints the table. The paper's figure averages 10000 runs of t = 1..300; the sweep's seeds are
the runs here, each run's mean over its periods one sample (its standard error is over seeds).

The paper's P_t is the prediction covariance P_{t|t-1}; netkf's mean_trace_P is Tr P_{k|k},
mapped exactly for a scalar plant by E[P_{k+1|k}] = A² E[P_{k|k}] + Q. So the scenario must be
scalar (n = m = 1), like the paper's example (A = -1.25, C = 1, Q = 1, R = 2.5).

Static gain K (eq. 25: x̂_{t+1} = A x̂_t + γ_t K (y_t - C x̂_t)): the error variance obeys
P_{t+1} = (λ (A - KC)² + (1 - λ) A²) P_t + Q + λ K² R, so its steady state is
(Q + λ K² R) / (1 - λ (A - KC)² - (1 - λ) A²) where the denominator is positive, else
unbounded. Gains as in the paper: K_SS, the steady-state Kalman gain (λ = 1); K = A/C, the
gain with the largest stability range; K_λ = A P̄ C / (C² P̄ + R) with P̄ = g_λ(P̄) at the design
rate (0.6).
"""
import argparse
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))  # python/, for `import netkf` from a checkout

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402

import netkf  # noqa: E402


def scalar_plant(path):
    with open(path) as f:
        s = yaml.safe_load(f)
    try:
        A, Q = s["plant"]["A"], s["plant"]["Q"]
        (sensor,) = s["sensors"]
        C, R = sensor["C"], sensor["R"]
    except (KeyError, TypeError, ValueError):
        sys.exit("%s: Fig. 7 is the paper's scalar example: one sensor, plant A and Q, sensor C and R" % path)
    if any(len(M) != 1 or len(M[0]) != 1 for M in (A, Q, C, R)):
        sys.exit("%s: Fig. 7 needs a scalar plant and measurement (n = m = 1)" % path)
    return float(A[0][0]), float(C[0][0]), float(Q[0][0]), float(R[0][0])


def g_fixed_point(lam, A, C, Q, R):
    """P̄ = g_λ(P̄) (Sinopoli eq. 17) by iteration from Q; inf when it does not converge."""
    p = Q
    for _ in range(200000):
        nxt = A * p * A + Q - lam * (A * p * C) ** 2 / (C * p * C + R)
        if not math.isfinite(nxt) or nxt > 1e12:
            return math.inf
        if abs(nxt - p) <= 1e-13 * nxt:
            return nxt
        p = nxt
    return math.inf


def static_steady_state(K, lam, A, C, Q, R):
    den = 1 - lam * (A - K * C) ** 2 - (1 - lam) * A ** 2
    return (Q + lam * K * K * R) / den if den > 0 else math.inf


def find_scenario(sweep, given):
    if given:
        return given
    s = sweep.config.get("scenario")
    if isinstance(s, dict):  # netkf sweep writes {path, sha256}
        s = s.get("path")
    if not s:
        sys.exit("%s: sweep.yaml names no scenario; pass --scenario" % sweep.directory)
    for base in (os.getcwd(), sweep.directory, os.path.dirname(os.path.dirname(HERE))):
        p = os.path.join(base, s)
        if os.path.exists(p):
            return p
    sys.exit("scenario %s (from sweep.yaml) not found; pass --scenario" % s)


def table(sweep, key, A, C, Q, R, design_rate):
    st = sweep.stats("mean_trace_P")
    lam = 1.0 - st[key].astype(float)
    k_ss = A * g_fixed_point(1.0, A, C, Q, R) * C / (C * C * g_fixed_point(1.0, A, C, Q, R) + R)
    p_design = g_fixed_point(design_rate, A, C, Q, R)
    k_lam = A * p_design * C / (C * C * p_design + R)
    gains = {"static_K_SS": k_ss, "static_K_A_over_C": A / C, "static_K_lambda": k_lam}
    out = pd.DataFrame({
        "lambda": lam, "loss": st[key].astype(float), "seeds": st["seeds"],
        # E[P_{k+1|k}] = A² E[P_{k|k}] + Q (scalar), and its standard error over seeds
        "E_P_pred": A * A * st["mean"] + Q, "E_P_pred_se": A * A * st["se"],
        "S_bar": st["theory_trace_S_bar"], "V_bar": st["theory_trace_V_bar"], "theory_stable": st["theory_stable"],
    })
    for name, K in gains.items():
        out[name] = [static_steady_state(K, l, A, C, Q, R) for l in lam]
    return out.sort_values("lambda").reset_index(drop=True), gains


def theory_bracket(t):
    """(largest λ the sweep's theory calls unstable, smallest it calls stable)."""
    known = t.dropna(subset=["theory_stable"])
    unstable = known[known["theory_stable"] == False]["lambda"]  # noqa: E712 (nullable boolean)
    stable = known[known["theory_stable"] == True]["lambda"]  # noqa: E712
    return (unstable.max() if len(unstable) else math.nan, stable.min() if len(stable) else math.nan)


def plot(t, lam_c, gains, plant, design_rate, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.errorbar(t["lambda"], t["E_P_pred"], yerr=t["E_P_pred_se"], fmt="o-", color="k", capsize=3,
                label="time-varying filter (netkf, mean ± s.e. over seeds)")
    ax.plot(t["lambda"], t["V_bar"], "--", label="V̄ (upper bound)")
    ax.plot(t["lambda"], t["S_bar"], ":", label="S̄ (lower bound)")
    grid = np.linspace(0.0, 1.0, 501)  # the static gains' closed form, drawn densely
    for (name, K), label in zip(gains.items(), ("static K_SS", "static K = A/C", "static K_λ (λ = %g)" % design_rate)):
        y = np.array([static_steady_state(K, l, *plant) for l in grid])
        ax.plot(grid, np.where(np.isfinite(y), y, np.nan), "-", alpha=0.6, label=label)
    ax.axvline(lam_c, color="r", lw=1, label="λ_c = %.3g" % lam_c)
    ax.set_xlabel("arrival rate λ")
    ax.set_ylabel(r"$E[P_{k|k-1}]$")
    ax.set_yscale("log")
    ax.set_xlim(0, 1)
    ax.set_ylim(0.5, 1e3)
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title("Sinopoli et al. 2004, Fig. 7, from a netkf sweep")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sweep", help="a netkf sweep directory (runs.csv, points.csv, sweep.yaml)")
    ap.add_argument("--scenario", help="the swept scenario (default: sweep.yaml's `scenario`)")
    ap.add_argument("--key", help="the varied link loss key (default: the sweep's one varied key)")
    ap.add_argument("--design-rate", type=float, default=0.6, help="the arrival rate K_λ is designed for (0.6)")
    ap.add_argument("--out", default="fig7", help="output prefix: OUT.csv, OUT.png (default fig7)")
    args = ap.parse_args()

    sweep = netkf.read_sweep(args.sweep)
    key = args.key or (sweep.varied[0] if len(sweep.varied) == 1 else None)
    if key is None or not key.endswith(".link.loss") or key not in sweep.varied:
        sys.exit("give --key: the varied link loss (the sweep varies %s)" % ", ".join(sweep.varied))
    A, C, Q, R = scalar_plant(find_scenario(sweep, args.scenario))
    t, gains = table(sweep, key, A, C, Q, R, args.design_rate)
    lam_c = 1 - 1 / (A * A)  # scalar: lower = upper bound on λ_c (Sinopoli Thm 3, 5; Sec. IV)
    lo, hi = theory_bracket(t)
    t.to_csv(args.out + ".csv", index=False, float_format="%.10g")
    print("Sinopoli Fig. 7 from %s: A=%g C=%g Q=%g R=%g, %s" % (sweep.directory, A, C, Q, R, sweep))
    print("critical arrival rate lambda_c = %.6g (1 - 1/A^2); the sweep's theory: unstable at %.4g, stable at %.4g"
          % (lam_c, lo, hi))
    print("static gains: " + ", ".join("%s = %.4f" % (k[9:], v) for k, v in gains.items()))
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(t.to_string(index=False, float_format=lambda v: "%.4g" % v))
    print("wrote %s.csv" % args.out)
    if plot(t, lam_c, gains, (A, C, Q, R), args.design_rate, args.out + ".png"):
        print("wrote %s.png" % args.out)
    else:
        print("no plot: python3-matplotlib is not installed (apt-get install python3-matplotlib)")


if __name__ == "__main__":
    main()
