"""Sensor groups: `netkf launch --sensors-per-process 2` hosts two sensors in each
sensor_node process. The reference is the same scenario run with one process per sensor:
sensors and links are seeded per id, so both runs must deliver exactly the same samples
(period, sensor, value, bit for bit) and, where every delivered sample was fused in both,
record the same estimates. The grouped run must also equal the core filter replayed
offline (as in the exactness test). A grouped process sends its samples as one batch per period
(docs/interop.md, "Batches") and the channel decides each on its own link: the channel's log
must show batches in the grouped run and none in the reference."""
import json
import os
import re
import subprocess

from e2e_common import DATA, Launch, check, finish, read_periods, read_samples, require_netns, workdir

require_netns()
scenario = os.path.join(DATA, "groups.yaml")
runs = {}
for per_process in (1, 2):
    out = workdir("groups-%d" % per_process)
    with Launch(scenario, 6, out, samples=True,
                extra=["--sensors-per-process", str(per_process), "--log-level", "info"]) as run:
        rc = run.wait(60)
        pids = run.child_pids()
    check(rc == 0, "launch with %d sensor(s) per process exits 0 (rc=%s)" % (per_process, rc))
    runs[per_process] = (run, pids)

single, grouped = runs[1], runs[2]
sensor_procs = sorted(n for n in grouped[1] if n.startswith("sensor_node"))
check(sensor_procs == ["sensor_node[1,2]", "sensor_node[3,4]"],
      "two sensor processes hold sensors 1,2 and 3,4 (%s)" % sensor_procs)
check(len([n for n in single[1] if n.startswith("sensor_node")]) == 4, "the reference run has four sensor processes")
batches = re.search(r"(\d+) raw samples came in (\d+) batches", grouped[0].output())
check(batches is not None and int(batches.group(2)) >= 2 * 150 and int(batches.group(1)) >= 1.9 * int(batches.group(2)),
      "the grouped run's samples reached the channel in batches of two (%s)" % (batches.group(0) if batches else "none"))
check("raw samples came in" not in single[0].output(), "the reference run sent no batch")

samples = {p: read_samples(runs[p][0].samples) for p in runs}
periods = {p: read_periods(runs[p][0].record, 2) for p in runs}
last = min(max(s["k"] for s in samples[p]) for p in runs) if all(samples.values()) else -1
check(last >= 150, "both runs delivered samples up to period 150 or later (common range ends at %d)" % last)


def delivered(p):
    return sorted((s["k"], s["sensor_id"], tuple(s["y"])) for s in samples[p] if s["k"] <= last)


same = delivered(1) == delivered(2)
check(same, "the same samples were delivered, with the same values (%d samples)" % len(delivered(1)))

# Estimates: identical up to the first period where either run had a late sample (a timing
# accident, counted, that changes the fused set from then on).
rows = {p: {r["k"]: r for r in periods[p]} for p in runs}
compared = 0
for k in range(0, last + 1):
    a, b = rows[1].get(k), rows[2].get(k)
    if a is None or b is None or a["late"] or b["late"] or a["fused"] != b["fused"]:
        break
    if a["xhat"] != b["xhat"] or a["trace_P"] != b["trace_P"]:
        check(False, "period %d: the same estimate in both runs" % k)
        break
    compared += 1
check(compared >= 100, "the two runs' estimates are identical for the first %d periods" % compared)

r = subprocess.run([os.environ["NETKF_REPLAY"], scenario, grouped[0].samples, grouped[0].record],
                   capture_output=True, text=True)
print(r.stdout, r.stderr)
check(r.returncode == 0, "netkf_replay compared the grouped run")
if r.returncode == 0:
    res = json.loads(r.stdout)
    check(res["max_xhat_diff"] <= 1e-9, "grouped run: live x̂ equals the offline core filter (%.3g)" %
          res["max_xhat_diff"])
    check(res["fused_mismatch"] == 0, "grouped run: fused sets agree with the replay")
finish()
