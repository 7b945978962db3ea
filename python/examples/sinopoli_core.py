#!/usr/bin/env python3
"""Sinopoli et al. 2004, Fig. 2 and Fig. 7, from the core's Python bindings (docs/python.md,
"The core in Python"), and a `netkf sweep` directory's points against bounds().

  python3 python/examples/sinopoli_core.py [--runs 10000] [--sweep SWEEP_DIR] [--out PREFIX]

Fig. 2: the bounds S̄ ≤ lim E[P_{k|k-1}] ≤ V̄ of the scalar example (A = -1.25, C = 1, Q = 1,
R = 2.5) against the arrival rate λ, both going to infinity at λ_c = 1 - 1/A² = 0.36.
Fig. 7: the time-varying filter's empirical E[P_{k|k-1}] at t = 300, the mean over --runs Monte
Carlo runs (the paper's 10000), between the bounds. With --sweep: the sweep's measured
mean Tr P_{k|k} per point, mapped to P_{k+1|k} = A² P_{k|k} + Q (scalar), beside bounds() at the
point's arrival rate. Writes PREFIX-fig2.csv and PREFIX-fig7.csv (PREFIX-*.png too with Debian's
python3-matplotlib) and prints the tables.
"""
import argparse
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))  # python/, for `import netkf` from a checkout

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import yaml  # noqa: E402

import netkf  # noqa: E402

SCALAR = os.path.join(os.path.dirname(os.path.dirname(HERE)), "deploy", "scenarios", "sinopoli-scalar.yaml")


def fig2(scenario):
    lam = np.linspace(0.3, 1.0, 71)
    lower, upper = netkf.bounds(scenario, lam)                     # Tr S̄, Tr V̄ (NaN: unbounded)
    return pd.DataFrame({"lambda": lam, "S_bar": lower, "V_bar": upper})


def fig7(scenario, runs, rates=(0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)):
    s = yaml.safe_load(open(scenario))                             # the scenario as a dict, link changed per λ
    rows = []
    for lam in rates:
        s["sensors"][0]["link"] = {"model": "bernoulli", "loss": round(1 - lam, 12)}
        mc = netkf.simulate(s, runs=runs, steps=300, series=False)  # E[P_{k|k-1}] at k = 299
        lower, upper = netkf.bounds(s, [lam])
        rows.append({"lambda": lam, "mc_P": mc["mean_trace_P_pred"], "mc_P_se": mc["mean_trace_P_pred_se"],
                     "S_bar": lower[0], "V_bar": upper[0]})
    return pd.DataFrame(rows)


def sweep_against_bounds(sweep_dir, scenario):
    sweep = netkf.read_sweep(sweep_dir)
    key = sweep.varied[0]                                          # sensors.1.link.loss
    points = sweep.stats("mean_trace_P")
    A, Q = netkf.load_scenario(scenario).A[0, 0], netkf.load_scenario(scenario).Q[0, 0]
    lam = 1 - points[key].to_numpy()
    lower, upper = netkf.bounds(scenario, lam)
    return pd.DataFrame({"lambda": lam, "measured_P": A * A * points["mean"].to_numpy() + Q,
                         "measured_P_se": A * A * points["se"].to_numpy(), "S_bar": lower, "V_bar": upper})


def plot(table, columns, path, title):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for c in columns:
        ax.plot(table["lambda"], table[c], marker="o" if len(table) < 20 else None, label=c)
    ax.axvline(netkf.critical_rate(SCALAR)["lower"], linestyle="-.", color="gray", label="lambda_c")
    ax.set_ylim(0, 20)
    ax.set_xlabel("arrival rate lambda")
    ax.set_title(title)
    ax.legend()
    fig.savefig(path, dpi=100)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=10000, help="Monte Carlo runs per arrival rate (the paper's 10000)")
    ap.add_argument("--sweep", help="a `netkf sweep` directory of the scalar scenario over sensors.1.link.loss")
    ap.add_argument("--out", default="sinopoli", help="prefix of the CSV (and PNG) files")
    a = ap.parse_args()
    rates = netkf.critical_rate(SCALAR)
    print("critical arrival rate: lower %.6f, upper (LMI) %.6f, exact %.6f" % (rates["lower"], rates["upper"],
                                                                              rates["exact"]))
    tables = {"fig2": fig2(SCALAR), "fig7": fig7(SCALAR, a.runs)}
    if a.sweep:
        tables["sweep"] = sweep_against_bounds(a.sweep, SCALAR)
    for name, table in tables.items():
        table.to_csv("%s-%s.csv" % (a.out, name), index=False)
        print("\n%s\n%s" % (name, table.to_string(index=False, float_format=lambda v: "%.4f" % v)))
    plot(tables["fig2"], ["S_bar", "V_bar"], a.out + "-fig2.png", "Sinopoli Fig. 2: bounds on lim E[P]")
    plot(tables["fig7"], ["mc_P", "S_bar", "V_bar"], a.out + "-fig7.png", "Sinopoli Fig. 7: empirical E[P]")


if __name__ == "__main__":
    main()
