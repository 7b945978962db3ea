"""A timeline (docs/scenario-format.md, "Events"): link 2 drops everything from period 300
(at_period) to period 600 (at_s: 6.0 with a 10 ms period) and delivers every sample outside
that window (loss 0); link 3 ramps its loss from 0 to 0.5 over periods 100..300.

The channel applies an event from the first sample of its period, so the expectation is exact
for what the link does: the channel delivers no sample of sensor 2 for a period in [300, 600)
and every one outside it (the delivered-sample recording), and sensor 2 is fused in no period of
the window. After the window it is fused again: in nearly every period — a sensor process that
the machine holds back for a few periods (seen while compilers shared the 2 cores) makes its
samples late, which is the estimator's business, not the link's. Before the ramp link 3 loses
nothing; after it, it loses about half (binomial tolerance)."""
import os

from e2e_common import (DATA, Launch, check, finish, last_period, read_periods, read_samples, require_netns, wait_for,
                        workdir)

require_netns()
out = workdir("timeline")
with Launch(os.path.join(DATA, "timeline.yaml"), 60, out, samples=True, extra=("--dashboard", "off")) as run:
    check(wait_for(lambda: last_period(run.record) >= 820, 60), "the run reaches period 820")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)
rows = read_periods(run.record, 2)
check(rows and rows[-1]["k"] >= 700, "the run reached period 700 (last %s)" % (rows[-1]["k"] if rows else None))
inside = [r for r in rows if 300 <= r["k"] < 600]
fused_inside = [r["k"] for r in inside if 2 in r["fused"]]
check(len(inside) >= 290 and not fused_inside,
      "sensor 2 fused in no period of [300, 600) (%d periods, fused in %s)" % (len(inside), fused_inside[:5]))
samples = read_samples(run.samples)
delivered2 = {s["k"] for s in samples if s["sensor_id"] == 2}
last = rows[-1]["k"] - 5 if rows else 0
in_window = sorted(k for k in delivered2 if 300 <= k < 600)
check(not in_window, "the channel delivered no sample of sensor 2 for periods 300..599 (%s)" % in_window[:5])
outside_missing = [k for k in range(0, last) if not 300 <= k < 600 and k not in delivered2]
check(last > 700 and not outside_missing,
      "the channel delivered every other sample of sensor 2 (missing %s)" % outside_missing[:5])
after = [r for r in rows if r["k"] >= 600 and r["fused"]]
fused_after = sum(2 in r["fused"] for r in after)
check(len(after) > 200 and fused_after >= 0.95 * len(after),
      "sensor 2 fused again after period 600 (%d of %d periods)" % (fused_after, len(after)))
delivered3 = {s["k"] for s in samples if s["sensor_id"] == 3}
before = [k for k in range(0, 100)]
check(all(k in delivered3 for k in before), "link 3 delivers every sample before its ramp starts")
after = [k for k in range(300, min(800, rows[-1]["k"] - 5))] if rows else []
lost = sum(k not in delivered3 for k in after)
n = len(after)
check(n > 300 and abs(lost / n - 0.5) <= 4 * (0.25 / n) ** 0.5,
      "link 3 loses about half after the ramp (%d of %d)" % (lost, n))
log = run.output()
check("timeline: link 2 from period 300" in log and "timeline: link 2 from period 600" in log,
      "the launch's event log names both timeline events with their periods")
finish()
