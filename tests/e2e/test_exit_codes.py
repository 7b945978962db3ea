"""One table of exit codes for every command (README, "Exit codes"): 0 done, 1 the run
failed, 2 bad usage or input (argument errors included, not CLI11's own 101-127), 3 no
network answered, 4 the network refused the request."""
import os

from e2e_common import DATA, check, finish, netkf, require_netns

require_netns()
missing = "/nonexistent/netkf-scenario.yaml"
good = os.path.join(DATA, "tuning.yaml")
cases = [
    (("--help",), 0),
    (("analyze", "--help"), 0),
    (("bogus-command",), 2),
    ((), 2),  # a subcommand is required
    (("launch", missing), 2),
    (("analyze", missing), 2),
    (("simulate", missing, "--runs", "10", "--steps", "10"), 2),
    (("record", missing, "--out", "/tmp/x.csv"), 2),
    (("launch", "--duration", "abc"), 2),
    (("launch", "--duration", "-1"), 2),
    (("launch", "--dashboard", "99999"), 2),
    (("launch", "--sensors-per-process", "0"), 2),
    (("launch", "--check", "nonsense<1"), 2),  # an unknown name: refused before anything starts
    (("launch", "--check", "rms_error"), 2),  # no comparison
    (("launch", "--check", "link.99.late<1"), 2),  # no link 99 in the default scenario
    (("launch", "--summary", "/nonexistent-dir/summary.json"), 2),
    (("analyze", good, "--no-such-flag"), 2),
    (("ctl", "set-link", "2", "--bernoulli", "1.5"), 2),
    (("ctl", "set-link", "2"), 2),
    (("ctl",), 2),
    (("ctl", "status", "--timeout", "-1"), 2),
    (("ctl", "status", "--timeout", "nan"), 2),
    (("ctl", "status", "--timeout", "1e300"), 2),
    (("ctl", "set-link", "2", "--gilbert-elliott", "0", "0"), 2),  # p = r = 0: refused as in a file
    (("simulate", good, "--runs", "10", "--steps", "10", "--seed", "-1"), 2),
    (("ctl", "set-link", "0", "--bernoulli", "0.5", "--timeout", "1"), 3),  # id 0 is valid (as in a file)
    (("analyze", good, "--json"), 0),
    (("ctl", "status", "--timeout", "1"), 3),  # no network on this test's domain
    (("ctl", "set-link", "2", "--bernoulli", "0.5", "--timeout", "1"), 3),
    (("record", "--out", "/tmp/netkf-exit-codes.csv", "--duration", "1"), 3),  # never silently empty
    (("launch", "--only", "plant,sensor"), 2),  # an unknown role
    (("launch", "--only", "sensors=9"), 2),  # no sensor 9 in the default scenario
    (("launch", "--discovery-server", "server.example:11811"), 2),  # not an IPv4 address
    (("launch", "--serve-discovery", "10.0.0.1:0"), 2),
    (("launch", "--run-id", "0"), 2),
]
# Part of a network whose other hosts never come: the plant does not run without them; after
# --ready-timeout the launch fails naming what is missing (it used to wait 10 s, then run
# uncontrolled and exit 0).
r = netkf("launch", "--only", "plant,sensors", "--ready-timeout", "2", "--dashboard", "off", "--status-interval", "0",
          timeout=60)
check(r.returncode == 1 and "still missing the channel emulator, the estimator" in r.stderr,
      "launch --only plant,sensors without the rest exits 1 naming the channel and the estimator (rc=%d)" %
      r.returncode)
# --plot to a path that cannot be written: a clear error before any work, and nothing on
# stdout (gnuplot used to write the figure there, into the --json output).
for command in (("analyze", good, "--json"), ("simulate", good, "--runs", "20", "--steps", "20", "--json")):
    for plot in ("/nonexistent-dir/fig.png", "/nonexistent-dir/fig.svg", "/tmp/fig.pdf"):
        r = netkf(*(command + ("--plot", plot)), timeout=60)
        check(r.returncode == 2 and r.stdout == "" and ("cannot write" in r.stderr or ".png or .svg" in r.stderr),
              "netkf %s --plot %s: exit 2, stdout empty, the reason on stderr (rc=%d, %d bytes on stdout)"
              % (command[0], plot, r.returncode, len(r.stdout)))

# More sensors than a live network runs (1025 > 1024): refused at load, before anything starts
# (1536 ran with their link statuses lost: BENCHMARKS.md, "Sensor count limit").
big = "/tmp/netkf-exit-codes-1025.yaml"
with open(big, "w") as f:
    f.write("name: big\nperiod_ms: 100\nseed: 1\nplant:\n  A: [[0.9]]\n  Q: [[1.0]]\nsensors:\n")
    for i in range(1, 1026):
        f.write("  - { id: %d, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } }\n" % i)
r = netkf("launch", big, "--duration", "5", "--dashboard", "off", timeout=60)
check(r.returncode == 2 and "1025 sensors" in r.stderr and "at most 1024" in r.stderr and "started" not in r.stderr,
      "launch refuses 1025 sensors with exit 2 naming the limit (rc=%d)" % r.returncode)

for args, expected in cases:
    r = netkf(*args, timeout=60)
    check(r.returncode == expected, "netkf %s exits %d (got %d)" % (" ".join(args), expected, r.returncode))
    if expected == 2 and args not in ((),):
        check("error" in r.stderr.lower() or "required" in r.stderr.lower() or "usage" in r.stderr.lower()
              or "run with --help" in r.stderr.lower(),
              "netkf %s says what is wrong on stderr" % " ".join(args))
finish()
