"""kill -9 one sensor mid-run: the estimator still publishes every period (the launch
reports the death and restarts the sensor; the run ends cleanly)."""
import os
import signal
import time

from e2e_common import DATA, Launch, all_finite, check, contiguous, finish, read_periods, require_netns, workdir

require_netns()
out = workdir("kill")
# One process per sensor whatever the machine's CPU count (auto grouping could put sensor 2
# with others on a 1-CPU machine): the test kills exactly one sensor.
with Launch(os.path.join(DATA, "kill.yaml"), 12, out, extra=["--sensors-per-process", "1"]) as run:
    time.sleep(4)
    pids = run.child_pids()
    check("sensor_node[2]" in pids, "launch wrote the sensor's pid")
    if "sensor_node[2]" in pids:
        os.kill(pids["sensor_node[2]"], signal.SIGKILL)
        t_kill = time.monotonic() - run.started
    rc = run.wait(60)
    log = run.output()
check(rc == 0, "launch exits 0 with the restart policy (rc=%s)" % rc)
check("killed by signal 9" in log, "launch reports the sensor's death with its signal")
rows = read_periods(run.record, 2)
check(len(rows) >= 400, "at least 400 periods recorded (got %d)" % len(rows))
check(contiguous(rows), "an estimate for every period, no gap (k %d..%d, %d rows)" %
      (rows[0]["k"], rows[-1]["k"], len(rows)) if rows else "rows")
check(all_finite(rows), "no NaN/Inf")
# Periods after the kill where sensor 2 was missing show the estimator went on without it.
missing2 = [r["k"] for r in rows if 2 not in r["fused"]]
check(len(missing2) > 0, "some periods were fused without sensor 2 (%d)" % len(missing2))
finish()
