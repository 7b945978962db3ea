"""A rogue participant (tests/e2e/netkf_rogue --hostile, no run id, no security) publishes on
both measurement topics, every period: a NaN sample, a wrong-size one, an unknown sensor id,
the same sample twice, one far in the past and one far in the future; and malformed
link-control requests (unknown sensor, NaN loss, unknown key, Gilbert-Elliott p = r = 0).
Asserted: the run ends cleanly with an estimate for every period and no NaN, every kind of bad
sample is counted under its own reason by the estimator (and unknown ids by the channel),
every malformed request is refused with a reason, and the links are unchanged."""
import json
import os
import re
import subprocess

from e2e_common import (DATA, Launch, all_finite, check, contiguous, finish, last_period, netkf, read_periods,
                        require_netns, wait_for, workdir)

require_netns()
domain = os.environ["NETKF_DOMAIN"]
out = workdir("rogue")
with Launch(os.path.join(DATA, "kill.yaml"), 10, out, extra=["--log-level", "info"]) as run:
    check(wait_for(lambda: last_period(run.record) >= 20, 60), "the run is going")
    cmd = [os.environ["NETKF_ROGUE"], "--domain", domain, "--seconds", "4", "--sensor", "1", "--hostile",
           "--raw", "--delivered", "--link-control", "--after-truth"]
    print("$", " ".join(cmd), flush=True)
    rogue = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    print(rogue.stdout, rogue.stderr[-2000:], flush=True)
    status = netkf("ctl", "status", "--json", "--domain", domain, timeout=30)
    rc = run.wait(60)
    log = run.output()
report = json.loads(rogue.stdout) if rogue.stdout.strip() else {}
written = report.get("written", {})
check(written.get("raw", 0) > 100 and written.get("delivered", 0) > 100 and written.get("link_control", 0) >= 8,
      "the rogue wrote its bad samples and requests (%s)" % written)
check(rc == 0, "the launch ends normally (rc=%s)" % rc)
rows = read_periods(run.record, 2)
check(len(rows) >= 300 and rows[0]["k"] == 0 and contiguous(rows), "an estimate for every period (%d)" % len(rows))
check(all_finite(rows), "no NaN/Inf in any estimate")
summary = re.findall(r"rejected \d+ \(([^)]*)\)", log)
check(bool(summary), "the estimator's summary lists its rejections by reason")
reasons = dict((k, int(v)) for k, v in re.findall(r"(\w+) (\d+)", summary[-1])) if summary else {}
print("estimator rejections by reason:", reasons)
for reason in ("non_finite", "wrong_size", "unknown_sensor", "duplicate", "buffer_full"):
    check(reasons.get(reason, 0) > 0, "estimator counted %s samples (%d)" % (reason, reasons.get(reason, 0)))
late = re.findall(r"late samples (\d+)", log)
check(bool(late) and int(late[-1]) > 0, "the far-past samples were counted as late (%s)" % (late[-1:] or "none"))
check("sample from unknown sensor id 99" in log, "the channel refused the unknown sensor id")
refused = re.findall(r"request \d+: link \d+ change rejected: (.*)", log)
print("refused requests (first of each):", sorted(set(r[:60] for r in refused))[:6])
check(any("unknown sensor id 99" in r for r in refused), "the request for an unknown link was refused")
check(any("bogus" in r for r in refused), "the request with an unknown key was refused, naming it")
check(any("loss" in r for r in refused), "the request with a NaN loss was refused, naming the key")
check(any(re.search(r"\bp\b|\br\b", r) for r in refused), "Gilbert-Elliott p = r = 0 was refused")
if status.returncode == 0:
    links = {l["sensor_id"]: l for l in json.loads(status.stdout).get("links", [])}
    check(all(abs(links[i]["loss"] - 0.1) < 1e-12 for i in (1, 2, 3) if i in links) and len(links) == 3,
          "every link still has its loss of 0.1")
else:
    check(False, "ctl status answered (rc=%d)" % status.returncode)
finish()
