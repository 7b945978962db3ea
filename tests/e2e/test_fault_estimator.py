"""Fault matrix: kill -9 of the estimator mid-run. The launch restarts it; it resumes from the
last estimate it published (the checkpoint the launch writes) and predicts over the periods it
missed with nothing fused. Asserted: the run ends cleanly, an estimate for every period, no
NaN, fusion resumes, the estimates equal an offline replay that treats the missed periods as
"nothing arrived" (netkf_replay, and an independent NumPy filter), and no process or
temporary file is left behind."""
import json
import os
import re
import signal
import subprocess

from e2e_common import (DATA, Launch, all_finite, check, contiguous, finish, last_period, launch_files_dirs,
                        netkf_processes, numpy_filter_worst, read_periods, read_samples, require_netns, wait_for, workdir)

require_netns()
domain = int(os.environ["NETKF_DOMAIN"])
out = workdir("fault-estimator")
scenario = os.path.join(DATA, "exact.yaml")
with Launch(scenario, 14, out, samples=True) as run:
    check(wait_for(lambda: last_period(run.record) >= 150, 60), "the run reaches period 150")
    pid = run.child_pids().get("estimator_node")
    check(pid is not None, "launch wrote the estimator's pid")
    if pid:
        os.kill(pid, signal.SIGKILL)
    rc = run.wait(90)
    log = run.output()
    launch_pid = run.proc.pid
check(rc == 0, "launch exits 0: the estimator was restarted (rc=%s)" % rc)
check("estimator_node (pid %d) killed by signal 9" % pid in log if pid else False, "launch reports the estimator's death")
check("restarting estimator_node" in log, "launch restarts the estimator")
check("estimator restarted (restart 1): resumed from its estimate of period" in log,
      "the status says the estimator resumed from its last estimate")
rows = read_periods(run.record, 2)
samples = read_samples(run.samples)
check(len(rows) >= 400, "at least 400 periods recorded (got %d)" % len(rows))
check(bool(rows) and rows[0]["k"] == 0 and contiguous(rows),
      "an estimate for every period from 0, no gap (%d rows)" % len(rows))
check(all_finite(rows), "no NaN/Inf")
m = re.search(r"resumed from its estimate of period (\d+)", log)
if rows and m:
    # The gap: the periods after the checkpoint, fused with nothing, until the restarted
    # estimator hears the channel again.
    resumed = int(m.group(1))
    after = [r for r in rows if r["k"] > resumed]
    first_fused = next((r["k"] for r in after if r["fused"]), None)
    gap = [r["k"] for r in after if first_fused is not None and r["k"] < first_fused]
    print("resumed after period %d; fused again from period %s; %d periods open-loop" % (resumed, first_fused, len(gap)))
    check(first_fused is not None, "the restarted estimator fuses samples again")
    # A warm spare can take over within the period it died in: then no period is missed. The
    # launch's own count (from the estimates as they came; its last status line) must agree.
    counts = re.findall(r"estimator restarts=1 \((\d+) periods open-loop\)", log)
    check(bool(counts) and int(counts[-1]) == len(gap),
          "the launch counts the same %d periods fused with nothing after the restart (it says %s)" %
          (len(gap), counts[-1] if counts else "nothing"))
    fused_after = sum(1 for r in after if first_fused is not None and r["k"] >= first_fused and r["fused"])
    check(fused_after >= 100, "it keeps fusing after the restart (%d periods with samples)" % fused_after)

# The offline replay over the whole run: the fused sets say what each period used, so the
# missed periods are replayed as "nothing arrived".
r = subprocess.run([os.environ["NETKF_REPLAY"], scenario, run.samples, run.record], capture_output=True, text=True)
print(r.stdout, r.stderr)
check(r.returncode == 0, "netkf_replay compared the run")
if r.returncode == 0:
    res = json.loads(r.stdout)
    check(res["periods_compared"] == len(rows), "every recorded period compared")
    check(res["max_xhat_diff"] <= 1e-9, "x̂ after the restart equals the offline replay to 1e-9 (%.3g)" %
          res["max_xhat_diff"])
    check(res["max_trace_P_diff"] <= 1e-9, "Tr P equals the offline replay to 1e-9 (%.3g)" % res["max_trace_P_diff"])
    check(res["fused_mismatch"] == 0, "fused sets agree")

# An independent NumPy filter over the same fused samples (e2e_common).
worst = numpy_filter_worst(rows, samples)
check(worst <= 1e-8, "an independent NumPy Kalman filter agrees across the restart to 1e-8 (%.3g)" % worst)

check(wait_for(lambda: not netkf_processes(domain), 10), "no netkf process left running on the domain")
check(not launch_files_dirs(launch_pid), "the launch removed its private files")
finish()
