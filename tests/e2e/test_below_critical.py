"""Below the critical arrival rate (λ = 0.15 < λ_c = 0.36, Sinopoli Sec. IV): the run
completes, the estimator reports `diverging`, and no NaN appears anywhere. The run is started to
show an unstable loop (--allow-divergence): when the plant leaves its bound it ends with exit 0
(without the flag a diverged closed loop is a failed run: test_stall_closed_loop.py)."""
import os

from e2e_common import DATA, Launch, all_finite, check, finish, read_periods, read_samples, require_netns, workdir

require_netns()
out = workdir("below")
with Launch(os.path.join(DATA, "below_critical.yaml"), 10, out, samples=True, extra=["--allow-divergence"]) as run:
    rc = run.wait(60)
    log = run.output()
check(rc == 0, "launch ends cleanly (rc=%s)" % rc)
rows = read_periods(run.record, 1)
check(len(rows) >= 50, "periods recorded (%d)" % len(rows))
check(all_finite(rows), "no NaN/Inf in the recording")
check(any(r["state"] == "diverging" for r in rows), "the estimator reports diverging")
check("nan" not in open(run.samples).read().lower(), "no NaN in the delivered samples")
check("nan" not in log.lower().replace("nanosec", ""), "no NaN in the launch status output")
finish()
