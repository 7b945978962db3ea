"""`netkf sweep`'s bounds and its stop (docs/experiments.md, "Sweeps"; docs/cli.md): a real
`netkf sweep` process, real signals, each phase recognised from the files the sweep has written
(and confirmed by what it says) before the signal is sent:

- a grid over the limit (two --vary axes of 1000 values: 10^6 runs) is refused at once, exit 2,
  with its count (points x seeds = runs), and writes nothing;
- Ctrl-C (SIGINT) while the points are checked (100 000 points, no DIR yet): exit 1, "nothing
  was run", nothing written;
- SIGTERM during an offline run of 10^8 periods (runs.csv holds its header only): exit 1, the
  run is not done (0 of 2), points.csv and report.html are written, --resume is named;
- Ctrl-C while the report computes each point's theory (runs.csv complete, no points.csv yet):
  exit 1, the theory of the remaining points is left out and said so, the files are written;
- SIGTERM during a live run (its launch has started): exit 1, the launch is ended, no node
  process is left on the test's domain.
Each stop must come within 60 s: the phases take minutes when the signal is not honoured.
"""
import csv
import os
import signal
import time

from e2e_common import (NETKF, REPO, BackgroundProcess, check, finish, netkf_processes, require_netns, wait_for,
                        workdir)

require_netns()
domain = int(os.environ.get("NETKF_DOMAIN", "100"))
scenario = os.path.join(REPO, "deploy", "scenarios", "default.yaml")
out = workdir("sweep-signals")


def start(name, *args):
    """`netkf sweep ...` in the background, its output in NAME.log; returns (process, DIR, log path)."""
    d = os.path.join(out, name)
    log_path = os.path.join(out, name + ".log")
    cmd = [NETKF, "sweep", scenario] + [str(a) for a in args] + ["--out", d]
    # Not in its own session: the live phase checks that the sweep itself ends its launch's nodes.
    return BackgroundProcess(cmd, log=log_path), d, log_path


def stop(p, sig, seconds=60):
    """Send `sig` (None: none, wait for its own end); the exit status, or None (then killed) when
    it did not end in `seconds`."""
    rc = p.stop(sig, seconds)
    p.close()
    return None if p.killed else rc


def said(log_path):
    with open(log_path) as f:
        text = f.read()
    print(text[-2000:], end="", flush=True)
    return text


def lines(path):
    try:
        with open(path) as f:
            return list(csv.reader(f))
    except OSError:
        return []


# ---- the grid's size is bounded before anything is expanded
p, d, log = start("too-big", "--vary", "sensors.2.link.loss=0:0.9:1000", "--vary", "sensors.1.link.loss=0:0.9:1000")
rc = stop(p, None)
text = said(log)
check(rc == 2, "a grid of 1000 x 1000 points is refused, exit 2 (rc=%s)" % rc)
check("1000 x 1000 = 1000000 points x 1 seeds = 1000000 runs" in text and "at most 100000" in text,
      "the refusal gives the count and the limit")
check(not os.path.exists(d), "nothing is written")

# ---- Ctrl-C while the points are checked (the loader on each of 100 000 points)
p, d, log = start("validation", "--vary", "sensors.2.link.loss=0:0.9:100000", "--periods", 1)
time.sleep(1.5)
checking = p.running() and not os.path.exists(d)
rc = stop(p, signal.SIGINT)
text = said(log)
check(checking and "stopped while checking the points" in text and "nothing was run" in text,
      "Ctrl-C came while the points were checked, and the sweep says it stopped there")
check(rc == 1, "Ctrl-C during the check: exit 1 at once (rc=%s)" % rc)
check(not os.path.exists(d), "nothing is written")

# ---- SIGTERM during an offline run of 10^8 periods
p, d, log = start("offline", "--periods", 100000000, "--seeds", 2)
running = wait_for(lambda: len(lines(os.path.join(d, "runs.csv"))) == 1, 60) and p.running()
rc = stop(p, signal.SIGTERM)
text = said(log)
check(running, "the first offline run was under way (runs.csv holds its header)")
check(rc == 1, "SIGTERM during an offline run: exit 1 (rc=%s)" % rc)
check("stopped with 0 of 2 runs done" in text and "--resume" in text, "the sweep says what is done and how to resume")
check(len(lines(os.path.join(d, "runs.csv"))) == 1, "the cut run is not in runs.csv")
check(all(os.path.exists(os.path.join(d, f)) for f in ("points.csv", "report.html", "sweep.yaml")),
      "points.csv, report.html and sweep.yaml are written")

# ---- Ctrl-C while the report computes the theory of 2000 points (Gilbert-Elliott link 3: sampled)
n = 2000
p, d, log = start("report", "--vary", "sensors.2.link.loss=0:0.5:%d" % n, "--periods", 1)
reporting = wait_for(lambda: len(lines(os.path.join(d, "runs.csv"))) == n + 1 and
                     not os.path.exists(os.path.join(d, "points.csv")), 120) and p.running()
rc = stop(p, signal.SIGINT)
text = said(log)
check(reporting, "every run was done and the report was being computed")
check(rc == 1, "Ctrl-C while writing the report: exit 1 (rc=%s)" % rc)
check("stopped while writing the report" in text and "of %d points is left out" % n in text,
      "the sweep says the theory of the remaining points is left out")
points = lines(os.path.join(d, "points.csv"))
header = points[0] if points else []
margin = header.index("theory_critical_margin") if "theory_critical_margin" in header else None
with_theory = sum(1 for row in points[1:] if margin is not None and row[margin] != "")
check(len(points) == n + 1 and with_theory < n, "points.csv has every point, %d of them with theory" % with_theory)
check(os.path.exists(os.path.join(d, "report.html")), "report.html is written")

# ---- SIGTERM during a live run
p, d, log = start("live", "--live", "--duration", 60, "--domain", domain)
run_log = os.path.join(d, "runs", "p0-s1.log")


def launch_started():
    try:
        with open(run_log) as f:
            return "netkf launch: scenario" in f.read()
    except OSError:
        return False


started = wait_for(launch_started, 60) and p.running()
rc = stop(p, signal.SIGTERM)
text = said(log)
check(started, "the live run's launch had started")
check(rc == 1 and "stopped with 0 of 1 runs done" in text, "SIGTERM during a live run: exit 1 (rc=%s)" % rc)
check(wait_for(lambda: not netkf_processes(domain), 20), "no node process is left on domain %d" % domain)
finish()
