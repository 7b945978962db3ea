"""Writes python/tests/data/sweep-sinopoli/ : a hand-made stand-in for a `netkf sweep` directory
(issue 21's runs.csv / points.csv / sweep.yaml layout), NOT written by netkf. It sweeps the loss
of Sinopoli's scalar example (deploy/scenarios/sinopoli-scalar.yaml: A = -1.25, C = 1, Q = 1,
R = 2.5, P0 = 1), 3 seeds of 300 periods per point; each run is this file's own NumPy
simulation of the intermittent Kalman filter (Sinopoli et al. 2004, eq. 6-10); the theory
columns are the closed forms of the scalar case: S̄ = Q / (1 - (1-λ) A²) (Thm 4's lower bound,
finite for (1-λ) A² < 1), V̄ the fixed point of g_λ (eq. 17), stable iff λ > λ_c = 1 - 1/A².
Run from the repository: /usr/bin/python3 python/tests/data/make_sweep_fixture.py
"""
import csv
import math
import os

import numpy as np

A, C, Q, R, P0, X0 = -1.25, 1.0, 1.0, 2.5, 1.0, 0.0
LOSSES = [0.0, 0.2, 0.4, 0.5, 0.55, 0.6, 0.62, 0.7]
SEEDS = [1, 2, 3]
PERIODS = 300
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "sweep-sinopoli")
QUANTITIES = ["periods", "rms_error", "rms_error_final", "mean_trace_P", "late_fraction", "fused_fraction",
              "periods_diverging", "pipeline_latency_p50_ms", "pipeline_latency_p99_ms", "link.1.samples",
              "link.1.delivered", "link.1.dropped", "link.1.observed_loss", "link.1.fused"]


def simulate(loss, seed):
    rng = np.random.default_rng(1000 * seed + int(round(loss * 100)))
    x, xhat, P = X0 + math.sqrt(P0) * rng.standard_normal(), X0, P0
    err2, traces, fused = [], [], 0
    for _ in range(PERIODS):
        y = C * x + math.sqrt(R) * rng.standard_normal()
        if rng.random() >= loss:  # the sample arrives (γ_k = 1)
            K = P * C / (C * P * C + R)
            xhat, P = xhat + K * (y - C * xhat), P - K * C * P
            fused += 1
        err2.append((x - xhat) ** 2)
        traces.append(P)
        x = A * x + math.sqrt(Q) * rng.standard_normal()
        xhat, P = A * xhat, A * P * A + Q
    rms = math.sqrt(float(np.mean(err2)))
    return {"periods": PERIODS, "rms_error": rms, "rms_error_final": rms, "mean_trace_P": float(np.mean(traces)),
            "late_fraction": 0.0, "fused_fraction": fused / PERIODS, "periods_diverging": 0,
            "pipeline_latency_p50_ms": "", "pipeline_latency_p99_ms": "", "link.1.samples": PERIODS,
            "link.1.delivered": fused, "link.1.dropped": PERIODS - fused, "link.1.observed_loss": 1 - fused / PERIODS,
            "link.1.fused": fused}


def theory(loss):
    lam = 1 - loss
    lam_c = 1 - 1 / A ** 2
    stable = lam > lam_c
    if not stable:
        return {"theory_stable": "false", "theory_trace_S_bar": "", "theory_trace_V_bar": "",
                "theory_critical_margin": lam - lam_c}
    s_bar = Q / (1 - (1 - lam) * A ** 2)
    v = Q
    for _ in range(100000):  # V̄ = g_λ(V̄), eq. 17, by iteration from Q
        v_next = A * v * A + Q - lam * (A * v * C) ** 2 / (C * v * C + R)
        if abs(v_next - v) < 1e-13 * v:
            break
        v = v_next
    return {"theory_stable": "true", "theory_trace_S_bar": s_bar, "theory_trace_V_bar": v_next,
            "theory_critical_margin": lam - lam_c}


def fmt(v):
    return "%.17g" % v if isinstance(v, float) else str(v)


def main():
    os.makedirs(OUT, exist_ok=True)
    key = "sensors.1.link.loss"
    runs, points = [], []
    for p, loss in enumerate(LOSSES):
        rows = []
        for seed in SEEDS:
            r = simulate(loss, seed)
            rows.append(r)
            runs.append([p, seed, loss, "ok"] + [r[q] for q in QUANTITIES])
        stats = []
        for q in QUANTITIES:
            vals = [r[q] for r in rows if r[q] != ""]
            if not vals:
                stats += ["", "", "", ""]
                continue
            a = np.array(vals, dtype=float)
            stats += [float(a.mean()), float(a.std(ddof=1) / math.sqrt(len(a))), float(a.min()), float(a.max())]
        t = theory(loss)
        points.append([p, loss, len(SEEDS)] + stats + [t[c] for c in ("theory_stable", "theory_trace_S_bar",
                                                                      "theory_trace_V_bar", "theory_critical_margin")])
    with open(os.path.join(OUT, "runs.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["point", "seed", key, "status"] + QUANTITIES)
        w.writerows([[fmt(v) for v in r] for r in runs])
    with open(os.path.join(OUT, "points.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["point", key, "seeds"] + ["%s_%s" % (q, s) for q in QUANTITIES for s in ("mean", "se", "min", "max")]
                   + ["theory_stable", "theory_trace_S_bar", "theory_trace_V_bar", "theory_critical_margin"])
        w.writerows([[fmt(v) for v in r] for r in points])
    with open(os.path.join(OUT, "sweep.yaml"), "w") as f:
        f.write("# A hand-made stand-in for a netkf sweep directory (python/tests/data/make_sweep_fixture.py),\n"
                "# not written by netkf: its runs are a NumPy simulation of the scalar filter.\n")
        f.write("command: netkf sweep deploy/scenarios/sinopoli-scalar.yaml --vary %s=%s --seeds %d --periods %d "
                "--offline --out sweep-sinopoli\n" % (key, ",".join(str(v) for v in LOSSES), len(SEEDS), PERIODS))
        f.write("scenario: deploy/scenarios/sinopoli-scalar.yaml\nmode: offline\nseeds: %d\nperiods: %d\n"
                % (len(SEEDS), PERIODS))
        f.write("vary:\n  - key: %s\n    values: [%s]\n" % (key, ", ".join(str(v) for v in LOSSES)))


if __name__ == "__main__":
    main()
