"""Closed loop (LQG): an unstable plant (A = 1.2) with control stays bounded for the whole
run with links above the critical rate, and the mean squared estimation error matches
the offline Monte Carlo of the same scenario. The offline expectation is an independent
NumPy Monte Carlo of the error dynamics (the error does not depend on u); when
`netkf simulate --json` is available it is checked against it as well."""
import json
import os

import numpy as np

from e2e_common import DATA, Launch, all_finite, check, finish, netkf, read_periods, require_netns, workdir

require_netns()
out = workdir("closed")
scenario = os.path.join(DATA, "closed_loop.yaml")
with Launch(scenario, 15, out) as run:
    rc = run.wait(60)
check(rc == 0, "launch exits 0 (rc=%s)" % rc)
rows = read_periods(run.record, 1)
check(len(rows) >= 800, "periods recorded (%d)" % len(rows))
check(all_finite(rows), "no NaN/Inf")
xmax = max(abs(r["x"][0]) for r in rows)
check(xmax < 100.0, "the plant stays bounded: max |x| = %.3g" % xmax)
check(all(r["state"] == "ok" for r in rows), "the filter stays ok")
steady = rows[100:]
live = np.array([(r["x"][0] - r["xhat"][0]) ** 2 for r in steady])
live_mse = float(live.mean())

# Offline Monte Carlo of the same scalar system (A = 1.2, Q = 1, two sensors with R = 1, 2,
# each received with probability 0.8): for the MMSE filter the mean squared error of
# x̂_{k|k} equals E[P_{k|k}] (P depends only on the arrivals), so we average the
# filtered covariance over random arrival sequences (Sinopoli eqs. 14-16 per sensor).
rng = np.random.default_rng(12345)
runs, steps = 20000, 200
A, Q, Rs, lam = 1.2, 1.0, np.array([1.0, 2.0]), 0.8
P = np.ones(runs)
for k in range(steps):
    for i in range(2):
        got = rng.random(runs) < lam
        P = np.where(got, P * Rs[i] / (P + Rs[i]), P)
    if k == steps - 1:
        pf = P.copy()
    P = A * P * A + Q
mc_mse, mc_se = float(pf.mean()), float(pf.std() / np.sqrt(runs))
# The live time average is over ~1400 correlated periods of a heavy-tailed error; allow
# 25 % plus 4 standard errors of the Monte Carlo.
tol = 0.25 * mc_mse + 4 * mc_se
check(abs(live_mse - mc_mse) <= tol, "live mean squared error %.4f within %.4f of Monte Carlo %.4f"
      % (live_mse, tol, mc_mse))
sim = netkf("simulate", scenario, "--runs", "2000", "--steps", "200", "--json", timeout=120)
if sim.returncode == 0:
    try:
        s = json.loads(sim.stdout)
        ref = s["mean_sq_error_filt"]
        check(abs(live_mse - ref) <= 0.25 * ref + 4 * s["mean_sq_error_filt_se"],
              "live mean squared error within tolerance of netkf simulate (%.4f)" % ref)
    except (ValueError, KeyError) as e:
        print("netkf simulate output not usable (%s); NumPy Monte Carlo only" % e)
else:
    print("netkf simulate not available; NumPy Monte Carlo only")
finish()
