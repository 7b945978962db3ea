"""The dashboard's safety rules from the outside (docs/dashboard.md, "Safety"):
- `--dashboard off` opens no port at all;
- a taken port is a clear error naming the flag, before any process starts (exit 2);
- `--dashboard-bind ADDR` listens there and requires the token printed at start.
Only addresses of the test's own network namespace are used (127.0.0.0/8 on its lo).
"""
import re
import socket
import subprocess
import urllib.error
import urllib.request

from e2e_common import NETKF, Launch, check, finish, require_netns, wait_for, workdir


def listening():
    return subprocess.run(["ss", "-ltnH"], capture_output=True, text=True).stdout


def status_of(url):
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status
    except urllib.error.HTTPError as e:
        return e.code


require_netns()

# --dashboard off: nothing listens on TCP in this namespace while the network runs.
out = workdir("dashboard-off")
with Launch(None, 60, out, record=False, extra=["--dashboard", "off"]) as run:
    # A status line of a fused period (not the launch line's "period 10 ms").
    check(wait_for(lambda: re.search(r"^period \d+ ", run.output(), re.M) is not None, 20),
          "the network runs without a dashboard")
    check(listening().strip() == "", "no TCP port is open: %r" % listening())
    check("dashboard:" not in run.output(), "no dashboard URL is printed")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)

# A taken port: exit 2 with the flag named, and no node was started.
blocker = socket.socket()
blocker.bind(("127.0.0.1", 8470))
blocker.listen(1)
r = subprocess.run([NETKF, "launch", "--duration", "5"], capture_output=True, text=True, timeout=60)
print(r.stderr, flush=True)
check(r.returncode == 2, "a taken dashboard port ends the launch with exit 2 (rc=%d)" % r.returncode)
check("--dashboard PORT" in r.stderr and "8470" in r.stderr, "the error names the port and the flag")
check("started" not in r.stderr, "no process was started")
blocker.close()

# --dashboard-bind: the token is required on every request.
out = workdir("dashboard-bind")
with Launch(None, 60, out, record=False, extra=["--dashboard-bind", "127.0.0.2", "--dashboard", "8471"]) as run:
    check(wait_for(lambda: "dashboard: http://127.0.0.2:8471/?token=" in run.output(), 20),
          "the URL with its token is printed")
    m = re.search(r"dashboard: (http://127\.0\.0\.2:8471/\?token=([0-9a-f]+))", run.output())
    if m:
        url, token = m.group(1), m.group(2)
        check(len(token) == 32, "the token has 128 bits")
        check(status_of("http://127.0.0.2:8471/") == 401, "the page without the token: 401")
        check(status_of("http://127.0.0.2:8471/metrics") == 401, "/metrics without the token: 401")
        check(status_of("http://127.0.0.2:8471/?token=" + "0" * 32) == 401, "a wrong token: 401")
        check(status_of(url) == 200, "the page with the token: 200")
        check(status_of("http://127.0.0.2:8471/metrics?token=" + token) == 200, "/metrics with the token: 200")
    check("127.0.0.2:8471" in listening() and "127.0.0.1:8471" not in listening(), "listens on the given address only")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)
finish()
