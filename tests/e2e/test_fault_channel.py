"""Fault matrix: the channel emulator stopped (SIGSTOP) for 2 s then continued, and later
killed with kill -9. Asserted: an estimate for every period (open-loop while nothing arrives),
no NaN, the samples the channel held while stopped arrive late and are counted as late, fusion
resumes after each fault, the run ends cleanly, and no process, launch file or stale Fast DDS
shared-memory segment is left behind."""
import os
import signal
import time

from e2e_common import (DATA, Launch, all_finite, check, contiguous, finish, last_period, launch_files_dirs,
                        netkf_processes, read_periods, require_netns, stale_participant_markers, wait_for, workdir,
                        zombie_shm_segments)

require_netns()
domain = int(os.environ["NETKF_DOMAIN"])
out = workdir("fault-channel")
with Launch(os.path.join(DATA, "kill.yaml"), 16, out, extra=["--sensors-per-process", "1"]) as run:
    check(wait_for(lambda: last_period(run.record) >= 100, 60), "the run reaches period 100")
    pid = run.child_pids().get("channel_emulator")
    check(pid is not None, "launch wrote the channel's pid")
    stopped_at = stopped_until = killed_at = None
    if pid:
        stopped_at = last_period(run.record)
        os.kill(pid, signal.SIGSTOP)
        time.sleep(2.0)
        os.kill(pid, signal.SIGCONT)
        stopped_until = last_period(run.record)
        check(wait_for(lambda: last_period(run.record) >= stopped_until + 100, 30), "the run goes on after SIGCONT")
        killed_at = last_period(run.record)
        os.kill(pid, signal.SIGKILL)
    rc = run.wait(90)
    log = run.output()
    launch_pid = run.proc.pid
check(rc == 0, "launch exits 0: the channel was restarted (rc=%s)" % rc)
check("channel_emulator (pid %d) killed by signal 9" % pid in log if pid else False, "launch reports the channel's death")
check("restarting channel_emulator" in log, "launch restarts the channel")
rows = read_periods(os.path.join(out, "periods.csv"), 2)
check(len(rows) >= 400, "at least 400 periods recorded (got %d)" % len(rows))
check(bool(rows) and rows[0]["k"] == 0 and contiguous(rows), "an estimate for every period, no gap (%d rows)" % len(rows))
check(all_finite(rows), "no NaN/Inf")
# Each fault leaves periods fused with nothing (open-loop); fusion resumes after each.
# With three links of loss 0.1, three empty periods in a row happen by chance with probability
# 1e-9, so a run of >= 3 is an outage. The record lags the estimator by a few periods: an
# outage belongs to a fault when it starts at most 10 periods before the period recorded when
# the fault was made. Recovery: every outage of a fault has ended within RECOVERY periods of
# the fault's end (SIGCONT; the kill), and none starts later. A restarted channel may stall
# once more shortly after it first delivers, which the bound allows; a restart that takes the
# killed channel's shared-memory port (what participant slots prevent) does not
# (BENCHMARKS.md, "A restarted process and shared memory").
RECOVERY = 100  # periods (2 s at 20 ms)
runs, current, start = [], 0, None
for r in rows:
    if r["fused"]:
        if current >= 3:
            runs.append((start, current))  # ended: a fused period follows
        current = 0
    else:
        if current == 0:
            start = r["k"]
        current += 1
print("outages (first period, periods without samples):", runs)
print("SIGSTOP at period ~%s, SIGCONT at ~%s, kill -9 at period ~%s" % (stopped_at, stopped_until, killed_at))
if stopped_at is not None and killed_at is not None:
    stop_outages = [o for o in runs if stopped_at - 10 <= o[0] < killed_at - 10]
    kill_outages = [o for o in runs if killed_at - 10 <= o[0]]
    check(bool(stop_outages) and all(o[0] + o[1] <= stopped_until + RECOVERY for o in stop_outages),
          "SIGSTOP: an outage, fusion again within %d periods of SIGCONT (%s)" % (RECOVERY, stop_outages))
    # The warm spare takes over at once: the kill's outage may be too short to show (< 3 periods).
    check(all(o[0] + o[1] <= killed_at + RECOVERY for o in kill_outages),
          "kill -9: fusion again within %d periods once the channel is restarted from its spare (%s)"
          % (RECOVERY, kill_outages))
late = sum(r["late"] for r in rows)
check(late > 0, "the samples held while the channel was stopped arrived late and were counted (%d)" % late)
check(rows and rows[-1]["fused"] or any(r["fused"] for r in rows[-20:]), "fusing at the end of the run")
check(wait_for(lambda: not netkf_processes(domain), 10), "no netkf process left running on the domain")
check(not launch_files_dirs(launch_pid), "the launch removed its private files")
# The killed channel's shared-memory segment is cleaned by the launch at its end.
zombies = zombie_shm_segments()
check(not zombies, "no stale Fast DDS shared-memory segment left (%s)" % zombies[:4])
check(not stale_participant_markers(domain), "no stale participant marker left (the launch removed the killed channel's)")
finish()
