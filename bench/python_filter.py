#!/usr/bin/env python3
"""Cost of a filter step from Python (scripts/bench.sh python-filter; BENCHMARKS.md, "The core in
Python"): netkf.Filter driven step by step from a Python loop (update with the samples that
arrived, then predict) against statsmodels' Kalman filter over the same arrays (one call, NaN for
the lost samples), on the scalar example and the default scenario, 40 % of samples lost.
Prints the rows of the table. Run with Debian's /usr/bin/python3 after scripts/build.sh.
"""
import os
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

import numpy as np  # noqa: E402
from statsmodels.tsa.statespace.kalman_filter import KalmanFilter  # noqa: E402

import netkf  # noqa: E402


def data(s, steps, rng):
    rows = [np.asarray(sensor["C"]).shape[0] for sensor in s.sensors]
    y = rng.normal(size=(steps, sum(rows)))
    arrived = rng.random((steps, len(rows))) > 0.4
    starts = np.cumsum([0] + rows[:-1])
    for i, (start, m) in enumerate(zip(starts, rows)):
        y[~arrived[:, i], start:start + m] = np.nan
    return y, arrived, starts, rows


def best(f, repeat=5):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def main():
    steps = 20000
    print("| scenario | n | sensors | netkf.Filter step from Python [µs] | statsmodels filter, per step [µs] |")
    print("|---|---|---|---|---|")
    for name in ("sinopoli-scalar", "default"):
        s = netkf.load_scenario(os.path.join(REPO, "deploy", "scenarios", name + ".yaml"))
        y, arrived, starts, rows = data(s, steps, np.random.default_rng(1))
        ids = s.sensor_ids
        samples = [{ids[i]: y[k, starts[i]:starts[i] + rows[i]] for i in range(len(ids)) if arrived[k, i]}
                   for k in range(steps)]

        def run_netkf():
            f = netkf.Filter(s)
            for sample in samples:
                f.update(sample)
                f.predict()

        C = np.vstack([sensor["C"] for sensor in s.sensors])
        R = np.zeros((C.shape[0], C.shape[0]))
        for start, m, sensor in zip(starts, rows, s.sensors):
            R[start:start + m, start:start + m] = sensor["R"]
        n = s.state_dim

        def run_statsmodels():
            kf = KalmanFilter(k_endog=C.shape[0], k_states=n, design=C, obs_cov=R, transition=s.A,
                              selection=np.eye(n), state_cov=s.Q)
            kf.initialize_known(np.zeros(n), np.eye(n))
            kf.bind(y)
            kf.filter()

        print("| %s | %d | %d | %.2f | %.2f |" % (name, n, len(ids), best(run_netkf) / steps * 1e6,
                                                  best(run_statsmodels) / steps * 1e6))


if __name__ == "__main__":
    main()
