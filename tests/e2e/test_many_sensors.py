"""Many sensors: 512 sensors (an eighth of the limit of a live network, 4096) in the launch's
automatic grouping, four sensor_node processes of 128. Before the fix, a grouped process was named after
all its sensors one by one; above 255 characters Fast DDS cut the participant's name and the
others never discovered it, so the plant waited for sensors 129-256 in vain and the run
failed. Asserted: the run ends normally (exit 0: a sensor that never sent a sample would make it
exit 1), every one of the 512 sensors is fused in some period, and the status and summary are
not errors; a `netkf ctl status` started mid-run lists all 512 links (the link status is keyed by
link: unkeyed with a history of 256, a late reader could get at most 256 statuses). The share
fused per period against the links' 0.9 is printed for BENCHMARKS.md."""
import json
import os

from e2e_common import Launch, check, finish, last_period, netkf, read_periods, require_netns, wait_for, workdir

require_netns()
out = workdir("many-sensors")
n = 512
scenario = os.path.join(out, "many.yaml")
with open(scenario, "w") as f:
    f.write("name: many-sensors\nperiod_ms: 100\nseed: 5\nplant:\n  A: [[0.95, 0.1], [0.0, 0.9]]\n"
            "  Q: [[0.1, 0.0], [0.0, 0.1]]\n  x0: [0.0, 0.0]\nsensors:\n")
    for i in range(1, n + 1):
        f.write("  - { id: %d, C: [[1.0, 0.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } }\n" % i)
    f.write("estimator:\n  deadline_ms: 80\n")
summary_path = os.path.join(out, "summary.json")
with Launch(scenario, 12, out, extra=["--dashboard", "off", "--summary", summary_path]) as run:
    # mid-run, after a few periods (every link has reported at least once: once a second)
    check(wait_for(lambda: last_period(os.path.join(out, "periods.csv")) >= 30, 90), "the run reached period 30")
    st = netkf("ctl", "status", "--json", "--timeout", "20", timeout=60)
    listed = sorted(l["sensor_id"] for l in json.loads(st.stdout)["links"]) if st.returncode == 0 else []
    check(listed == list(range(1, n + 1)), "a late ctl status lists all %d links (got %d; rc=%d)"
          % (n, len(listed), st.returncode))
    rc = run.wait(120)
    log = run.output()
check(rc == 0, "launch with %d sensors exits 0 (rc=%s)" % (n, rc))
check("%d sensors in 4 processes (128 per process" % n in log, "four sensor processes of 128")
check("still missing" not in log and "never sent" not in log, "no sensor missing at the start, none silent")
rows = read_periods(os.path.join(out, "periods.csv"), 2)
check(len(rows) >= 50, "at least 50 periods recorded (got %d)" % len(rows))
fused_ever = set()
for r in rows:
    fused_ever.update(r["fused"])
missing = sorted(set(range(1, n + 1)) - fused_ever)
check(not missing, "every sensor fused in some period (%d never: %s)" % (len(missing), missing[:10]))
if rows:
    counts = [len(r["fused"]) for r in rows]
    print("fused per period: min %d, mean %.1f, max %d (links deliver %d x 0.9 = %.1f on average); late %d"
          % (min(counts), sum(counts) / len(counts), max(counts), n, 0.9 * n, sum(r["late"] for r in rows)))
with open(summary_path) as f:
    summary = json.load(f)
check(not str(summary.get("end", "")).startswith("failure"), "the summary's end is not a failure (%s)" % summary.get("end"))
finish()
