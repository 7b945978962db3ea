"""A write error during a run is not a usage error (issue: a full disk mid-run used to throw
exit 2 out of the 50 ms flush, skipping the orderly stop, the summary and the presence end).

The launch records into a 16 KiB tmpfs that the test mounts in its own mount namespace; the
default scenario (10 ms period) fills it within seconds. Expected, from the README's exit
codes: the launch stops in order (children ended, "stopped (failure)" line), writes its
summary elsewhere with the reason as its end, and exits 1 naming the file and ENOSPC."""
import json
import os
import time

from e2e_common import NETKF, check, finish, netkf_processes, require_netns, workdir
import subprocess

require_netns()
out = workdir("disk_full")
full = os.path.join(out, "full")
os.mkdir(full)
summary = os.path.join(out, "summary.json")
domain = int(os.environ["NETKF_DOMAIN"])
launch = [NETKF, "launch", "--duration", "60", "--dashboard", "off", "--status-interval", "0",
          "--record", os.path.join(full, "run.csv"), "--summary", summary, "--check", "periods>0"]
# The tmpfs exists only in the launch's mount namespace (and its children's): nothing is
# mounted on the machine itself.
cmd = ["unshare", "-m", "--propagation", "private", "--", "sh", "-c",
       'mount -t tmpfs -o size=16k netkf-disk-full "$0" && exec "$@"', full] + launch
print("$", " ".join(cmd), flush=True)
started = time.monotonic()
r = subprocess.run(cmd, capture_output=True, text=True, timeout=100)
elapsed = time.monotonic() - started
print(r.stdout, r.stderr, sep="", end="", flush=True)

check(r.returncode == 1, "a full disk mid-run: exit 1, a failed run (got %d)" % r.returncode)
check("No space left on device" in r.stderr and "run.csv" in r.stderr,
      "the error names the file and the reason (ENOSPC)")
check("the run was stopped" in r.stderr, "the error says the run was stopped")
check(elapsed < 50, "the run stopped when the write failed, not at --duration (%.1f s)" % elapsed)
check("netkf launch: stopped (failure)" in r.stderr, "the launch stopped in order (its stop line)")
check("bad usage" not in r.stderr and r.returncode != 2, "not reported as a usage error")
check(netkf_processes(domain) == [], "no node process is left running")
try:
    with open(summary) as f:
        s = json.load(f)
except (OSError, ValueError) as e:
    s = {}
    check(False, "the summary was written outside the full disk (%s)" % e)
end = s.get("end", "")
check(end.startswith("failure: writing") and "No space left on device" in end,
      "the summary's end is the write failure (%r)" % end)
check(s.get("periods", 0) > 0, "the summary counts the periods run before the stop (%s)" % s.get("periods"))
finish()
