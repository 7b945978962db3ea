"""Pass/fail checks and the run summary for users' CI (docs/experiments.md, "Pass/fail checks in your CI"):
`netkf launch --check 'NAME<VALUE' --summary FILE.json`.

- A check that must hold (Bernoulli loss 0.3: link 1's observed loss below 0.6) -> exit 0, the
  table on stdout says PASS, and the summary's numbers equal an independent tally from the
  --record / --record-samples CSVs (periods, rms_error, mean Tr P, fused and late per link,
  ...); the channel's delivered counts agree with the recorded samples up to the few the
  launch cannot record (see below).
- A check that must fail (observed loss below 0.05) -> exit 1, the table says FAIL, the
  summary says so.
- An unknown name, a link id not in the scenario, a malformed check -> exit 2 at once, before
  any process starts.
"""
import json
import math
import os
import time

from e2e_common import DATA, Launch, check, finish, netkf, read_periods, read_samples, require_netns, workdir

require_netns()
scenario = os.path.join(DATA, "bernoulli3.yaml")  # three links, Bernoulli loss 0.3, period 40 ms
out = workdir("check")

# ---- usage errors: exit 2, fast, nothing started, no summary written
for bad, says in (("rms<0.8", "unknown name 'rms'"),
                  ("link.9.observed_loss<0.5", "link 9 is not in the scenario"),
                  ("rms_error==0.8", "unsupported operator"),
                  ("rms_error<abc", "finite number"),
                  ("rms_error<nan", "finite number")):
    pid_file = os.path.join(out, "bad-pids.txt")
    summary = os.path.join(out, "bad-summary.json")
    started = time.monotonic()
    r = netkf("launch", scenario, "--duration", "30", "--dashboard", "off", "--pid-file", pid_file,
              "--summary", summary, "--check", "periods>0", "--check", bad)
    elapsed = time.monotonic() - started
    check(r.returncode == 2, "--check '%s': exit 2 (got %d)" % (bad, r.returncode))
    check(says in r.stderr, "--check '%s': stderr says \"%s\"" % (bad, says))
    check(elapsed < 5.0, "--check '%s': refused at once (%.1f s)" % (bad, elapsed))
    check(not os.path.exists(pid_file) and "netkf launch: scenario" not in r.stderr,
          "--check '%s': no process was started" % bad)
    check(not os.path.exists(summary), "--check '%s': no summary written" % bad)

# ---- a check that holds: exit 0, and the summary against the recordings
pass_dir = os.path.join(out, "pass")
os.mkdir(pass_dir)
summary_path = os.path.join(pass_dir, "summary.json")
passing = ["link.1.observed_loss<0.6", "periods >= 50", "fused_fraction>0.3"]
extra = ["--dashboard", "off", "--summary", summary_path]
for c in passing:
    extra += ["--check", c]
extra.append(scenario)  # after a --check: each --check takes exactly one value
with Launch(None, 8, pass_dir, samples=True, extra=extra, own_stdout=True) as run:
    rc = run.wait(60)
stdout = run.stdout()
check(rc == 0, "passing checks: launch exits 0 (rc=%s)" % rc)
table = stdout.splitlines()
check(len(table) == len(passing) + 2 and table[0].split() == ["check", "value", "verdict"],
      "stdout is the table: a header, one row per check, a count")
for c in passing:
    row = [line for line in table if line.startswith(c + " ")]
    check(len(row) == 1 and row[0].rstrip().endswith("PASS"), "table row for '%s' says PASS" % c)
check(table[-1:] == ["%d checks: %d passed, 0 failed" % (len(passing), len(passing))], "table ends with the count")

with open(summary_path) as f:
    s = json.load(f)
rows = read_periods(run.record, 2)
samples = read_samples(run.samples)
ids = (1, 2, 3)
print("summary:", json.dumps(s, indent=1), flush=True)

for key in ("scenario", "end", "periods", "rms_error", "mean_trace_P", "late_fraction", "fused_fraction",
            "periods_diverging", "pipeline_latency_p50_ms", "pipeline_latency_p99_ms", "cost", "link", "checks", "passed"):
    check(key in s, "summary has '%s'" % key)
check(s["scenario"] == "e2e-bernoulli3" and s["end"] == "duration reached", "summary names the scenario and the end")
check(sorted(s["link"]) == ["1", "2", "3"], "summary has links 1, 2, 3")

# Every period the launch received has its row (truth and estimate both arrived).
n = len(rows)
check(n >= 100, "an 8 s run at 40 ms recorded at least 100 periods (%d)" % n)
check(s["periods"] == n, "periods %s == rows of the recording %d" % (s["periods"], n))
sq = [sum((a - b) ** 2 for a, b in zip(r["x"], r["xhat"])) for r in rows]
rms = math.sqrt(sum(sq) / n)
check(math.isclose(s["rms_error"], rms, rel_tol=1e-9), "rms_error %.12g == %.12g from the recording" % (s["rms_error"], rms))
mean_trace = sum(r["trace_P"] for r in rows) / n
check(math.isclose(s["mean_trace_P"], mean_trace, rel_tol=1e-9),
      "mean_trace_P %.12g == %.12g from the recording" % (s["mean_trace_P"], mean_trace))
fused = {i: sum(1 for r in rows if i in r["fused"]) for i in ids}
check(math.isclose(s["fused_fraction"], sum(fused.values()) / (n * 3), rel_tol=1e-12),
      "fused_fraction %.6f == fused ids / (periods x 3) from the recording" % s["fused_fraction"])
check(s["periods_diverging"] == sum(1 for r in rows if r["state"] == "diverging"), "periods_diverging from the recording")
late_rows = sum(r["late"] for r in rows)
check(sum(s["link"][str(i)]["late"] for i in ids) == late_rows,
      "late per link adds up to the recording's late column (%d)" % late_rows)
delivered_total = sum(s["link"][str(i)]["delivered"] for i in ids)
check(math.isclose(s["late_fraction"], late_rows / delivered_total, rel_tol=1e-12),
      "late_fraction == late / delivered (%s)" % s["late_fraction"])
check(0 < s["pipeline_latency_p50_ms"] <= s["pipeline_latency_p99_ms"] < 1000,
      "pipeline latency p50 %.3f <= p99 %.3f ms" % (s["pipeline_latency_p50_ms"], s["pipeline_latency_p99_ms"]))

last_k = max(r["k"] for r in rows)
for i in ids:
    link = s["link"][str(i)]
    # A sample delivered for a period after the last estimate the launch received (the run
    # stopped in between) was neither fused nor late in this recording: it cannot be judged.
    mine = [x for x in samples if x["sensor_id"] == i and x["k"] <= last_k]
    check(link["fused"] == fused[i], "link %d: fused %d == periods fusing it in the recording %d" % (i, link["fused"], fused[i]))
    check(link["fused"] == sum(1 for x in mine if x["fused"]), "link %d: fused == fused samples in the samples recording" % i)
    check(link["late"] == sum(1 for x in mine if not x["fused"]),
          "link %d: late %d == its delivered samples never fused" % (i, link["late"]))
    check(link["samples"] == link["delivered"] + link["dropped"], "link %d: samples = delivered + dropped" % i)
    check(math.isclose(link["observed_loss"], link["dropped"] / link["samples"], rel_tol=1e-12),
          "link %d: observed_loss = dropped / samples (%.4f)" % (i, link["observed_loss"]))
    # The channel counts every sample it relayed; the launch records the samples of the
    # periods whose estimate it received. At the ends they may differ by a sample: one relayed
    # before the launch's reader matched, or for the period the estimator was still fusing
    # when everything stopped (counted, never recorded); one relayed after the channel's
    # final report while it was stopping (recorded, not counted). Allow one period each way.
    check(abs(link["delivered"] - len(mine)) <= 2,
          "link %d: the channel delivered %d, %d recorded" % (i, link["delivered"], len(mine)))
    tol = 4.5 * math.sqrt(0.3 * 0.7 / link["samples"])
    check(abs(link["observed_loss"] - 0.3) <= tol, "link %d: observed loss %.4f within %.4f of 0.3" % (i, link["observed_loss"], tol))

check([c["check"] for c in s["checks"]] == passing, "summary lists every check in order")
for c in s["checks"]:
    name = c["name"]
    value = s["link"][name.split(".")[1]][name.split(".")[2]] if name.startswith("link.") else s[name]
    check(c["verdict"] == "PASS" and c["value"] == value, "check '%s': PASS with the summary's value %s" % (c["check"], value))
check(s["passed"] is True, "summary: passed")

# ---- a check that fails: exit 1, FAIL in the table and the summary
fail_dir = os.path.join(out, "fail")
os.mkdir(fail_dir)
fail_summary = os.path.join(fail_dir, "summary.json")
failing = "link.1.observed_loss<0.05"
with Launch(scenario, 4, fail_dir, record=False, own_stdout=True,
            extra=["--dashboard", "off", "--summary", fail_summary, "--check", "periods>0", "--check", failing]) as run:
    rc = run.wait(60)
stdout = run.stdout()
check(rc == 1, "a failing check: launch exits 1 (rc=%s)" % rc)
row = [line for line in stdout.splitlines() if line.startswith(failing)]
check(len(row) == 1 and row[0].rstrip().endswith("FAIL"), "table row for '%s' says FAIL" % failing)
check("2 checks: 1 passed, 1 failed" in stdout, "table counts 1 passed, 1 failed")
check("1 of 2 checks failed" in run.output(), "stderr says 1 of 2 checks failed")
with open(fail_summary) as f:
    s = json.load(f)
verdicts = {c["check"]: c["verdict"] for c in s["checks"]}
check(verdicts == {"periods>0": "PASS", failing: "FAIL"}, "summary verdicts %s" % verdicts)
check(s["passed"] is False, "summary: not passed")
finish()
