"""Exactness: the live estimates equal the core filter fed offline with the samples the
live estimator fused (to 1e-9), and an independent NumPy Kalman filter agrees too.
(Issue #3, item 4; the live system implements the recursion, not an approximation.)"""
import json
import os
import subprocess

from e2e_common import (DATA, Launch, all_finite, check, finish, numpy_filter_worst, read_periods, read_samples,
                        require_netns, workdir)

require_netns()
out = workdir("exact")
scenario = os.path.join(DATA, "exact.yaml")
with Launch(scenario, 8, out, samples=True) as run:
    rc = run.wait(60)
check(rc == 0, "launch exits 0 after --duration (rc=%s)" % rc)
rows = read_periods(run.record, 2)
samples = read_samples(run.samples)
check(len(rows) >= 200, "at least 200 periods recorded (got %d)" % len(rows))
check(bool(rows) and rows[0]["k"] == 0, "the recording starts at period 0")
check(all_finite(rows), "no NaN/Inf in the recording")

# 1) The core filter offline (netkf_replay).
r = subprocess.run([os.environ["NETKF_REPLAY"], scenario, run.samples, run.record], capture_output=True, text=True)
print(r.stdout, r.stderr)
check(r.returncode == 0, "netkf_replay compared the run")
if r.returncode == 0:
    res = json.loads(r.stdout)
    check(res["periods_compared"] == len(rows), "every recorded period compared")
    check(res["max_xhat_diff"] <= 1e-9, "live x̂ equals the offline core filter to 1e-9 (%.3g)" % res["max_xhat_diff"])
    check(res["max_trace_P_diff"] <= 1e-9, "live Tr P equals the offline core filter to 1e-9 (%.3g)" %
          res["max_trace_P_diff"])
    check(res["fused_mismatch"] == 0, "fused sets agree")

# 2) An independent NumPy Kalman filter on the same fused samples (e2e_common).
worst = numpy_filter_worst(rows, samples)
check(worst <= 1e-8, "an independent NumPy Kalman filter agrees to 1e-8 (%.3g)" % worst)
finish()
