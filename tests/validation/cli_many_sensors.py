#!/usr/bin/python3
"""`netkf analyze` on 512 sensors answers (label: validation).

Before, the verdict refused more than 16 sensors (2^d arrival patterns). Here 512 sensors,
each its own C = [c1, c2] with c1 != 0, all Bernoulli with one loss, A = [[1.2, 0.1], [0, 0.9]]:
every sensor sees the mode 1.2 alone, so (multi-sensor paper Thm 7, rank-deficient set =
every sensor lost) the criterion is 1.2^2 * loss^512, computed here in plain Python, and the
verdict is stable iff it is < 1. The upper bound cannot be summed over 2^512 patterns nor
grouped (every C differs): it must be labelled sampled, with a standard error.
Timing is not asserted here (BENCHMARKS.md, "Theory beyond 16 sensors").
Usage: cli_many_sensors.py NETKF_BINARY
"""
import json
import random
import subprocess
import sys
import tempfile
from pathlib import Path

netkf = sys.argv[1]
failures = []


def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def scenario(path, loss, seed):
    rng = random.Random(seed)
    lines = ["name: many-%s\nperiod_ms: 100\nseed: %d\nplant:\n  A: [[1.2, 0.1], [0.0, 0.9]]\n" % (loss, seed),
             "  Q: [[1.0, 0.0], [0.0, 1.0]]\n  x0: [0.0, 0.0]\nsensors:\n"]
    for i in range(1, 513):
        lines.append("  - { id: %d, C: [[%.6f, %.6f]], R: [[1.0]], link: { model: bernoulli, loss: %s } }\n"
                     % (i, 1.0 + rng.random(), rng.gauss(0, 1), loss))
    lines.append("estimator:\n  deadline_ms: 80\n")
    Path(path).write_text("".join(lines))


with tempfile.TemporaryDirectory() as d:
    for loss in (0.99, 0.9997):
        path = Path(d) / ("many-%s.yaml" % loss)
        scenario(path, loss, 11)
        run = subprocess.run([netkf, "analyze", str(path), "--json"], capture_output=True, text=True, timeout=120)
        check(run.returncode == 0, "analyze exits 0 for 512 sensors, loss %s (rc %d: %s)" % (loss, run.returncode, run.stderr[-300:]))
        if run.returncode != 0:
            continue
        r = json.loads(run.stdout)
        closed = 1.2 ** 2 * loss ** 512
        check(r["stable"] == ("yes" if closed < 1 else "no"),
              "loss %s: stable = %s, closed form 1.44 * loss^512 = %.6f" % (loss, r["stable"], closed))
        m = r["markov_criterion"]
        check(m is not None and abs(m - closed) <= 1e-9 * closed, "loss %s: markov_criterion %s = closed form" % (loss, m))
        ec = r["expected_covariance"]
        check(ec["upper_method"] == "sampled", "loss %s: upper bound labelled sampled (%s)" % (loss, ec["upper_method"]))
        if closed < 1:
            se = ec["upper_trace_standard_error"]
            check(ec["upper_trace"] is not None and se is not None and se > 0,
                  "loss %s: sampled Tr V-bar %s with standard error %s" % (loss, ec["upper_trace"], se))
            text = subprocess.run([netkf, "analyze", str(path)], capture_output=True, text=True, timeout=120).stdout
            check("SAMPLED" in text, "loss %s: the readable report says the upper value is sampled" % loss)

print("%d failure(s)" % len(failures))
sys.exit(1 if failures else 0)
