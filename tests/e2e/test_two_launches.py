"""Two launches on one DDS domain (issue: they corrupted each other undetected). The second
launch finds the first network's writers before it starts anything and refuses with exit 2,
naming the domain and --domain; the first run is untouched: no sample of another run, nothing
rejected, every period estimated."""
import os
import re
import subprocess

from e2e_common import (DATA, NETKF, Launch, all_finite, check, contiguous, finish, last_period, read_periods,
                        require_netns, wait_for, workdir)

require_netns()
domain = os.environ["NETKF_DOMAIN"]
scenario = os.path.join(DATA, "kill.yaml")
out = workdir("two-launches")
with Launch(scenario, 8, out) as first:
    check(wait_for(lambda: last_period(first.record) >= 20, 60), "the first launch runs")
    cmd = [NETKF, "launch", scenario, "--duration", "5", "--dashboard", "off", "--status-interval", "0"]
    print("$", " ".join(cmd), flush=True)
    second = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    print(second.stderr[-2000:], flush=True)
    rc = first.wait(60)
    log = first.output()
check(second.returncode == 2, "the second launch refuses with exit 2 (rc=%d)" % second.returncode)
check("DDS domain %s already carries a netkf network" % domain in second.stderr, "its error names the domain")
check("--domain" in second.stderr, "its error says how to choose another domain")
check("started" not in second.stderr, "it started no process")
check(rc == 0, "the first launch ends normally (rc=%s)" % rc)
check("samples of another run" not in log, "the first launch saw no sample of another run")
rejected = [int(n) for n in re.findall(r"rejected=(\d+)", log)]
check(bool(rejected) and max(rejected) == 0, "its estimator rejected nothing (%s)" % sorted(set(rejected)))
rows = read_periods(first.record, 2)
check(len(rows) >= 200 and rows[0]["k"] == 0 and contiguous(rows), "every period of the first run estimated (%d)" % len(rows))
check(all_finite(rows), "no NaN/Inf")
finish()
