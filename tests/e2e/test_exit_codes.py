"""One table of exit codes for every command (README, "Exit codes"): 0 done, 1 the run
failed, 2 bad usage or input (argument errors included, not CLI11's own 101-127), 3 no
network answered, 4 the network refused the request. Then the files a command is given
(docs/cli.md, "Files"): outputs that are one file, that are not regular files or that hold an
earlier recording, inputs that are devices or empty, a malformed recording, DDS Security files
that are missing or readable by others: each refused with exit 2 before anything starts."""
import os
import stat
import subprocess

from e2e_common import DATA, NETKF, check, finish, netkf, require_netns, workdir

require_netns()
missing = "/nonexistent/netkf-scenario.yaml"
good = os.path.join(DATA, "tuning.yaml")
out = workdir("exit-codes")
cases = [
    (("--help",), 0),
    (("analyze", "--help"), 0),
    (("bogus-command",), 2),
    ((), 2),  # a subcommand is required
    (("launch", missing), 2),
    (("analyze", missing), 2),
    (("simulate", missing, "--runs", "10", "--steps", "10"), 2),
    (("record", missing, "--out", os.path.join(out, "x.csv")), 2),
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
    (("record", "--out", os.path.join(out, "nothing.csv"), "--duration", "1"), 3),  # never silently empty
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

# More sensors than a live network runs (4097 > 4096): refused at load, before anything starts
# (BENCHMARKS.md, "Sensor count limit").
big = "/tmp/netkf-exit-codes-4097.yaml"
with open(big, "w") as f:
    f.write("name: big\nperiod_ms: 100\nseed: 1\nplant:\n  A: [[0.9]]\n  Q: [[1.0]]\nsensors:\n")
    for i in range(1, 4098):
        f.write("  - { id: %d, C: [[1.0]], R: [[1.0]], link: { model: bernoulli, loss: 0.1 } }\n" % i)
r = netkf("launch", big, "--duration", "5", "--dashboard", "off", timeout=60)
check(r.returncode == 2 and "4097 sensors" in r.stderr and "at most 4096" in r.stderr and "started" not in r.stderr,
      "launch refuses 4097 sensors with exit 2 naming the limit (rc=%d)" % r.returncode)

for args, expected in cases:
    r = netkf(*args, timeout=60)
    check(r.returncode == expected, "netkf %s exits %d (got %d)" % (" ".join(args), expected, r.returncode))
    if expected == 2 and args not in ((),):
        check("error" in r.stderr.lower() or "required" in r.stderr.lower() or "usage" in r.stderr.lower()
              or "run with --help" in r.stderr.lower(),
              "netkf %s says what is wrong on stderr" % " ".join(args))


def run(*args, timeout=60):
    """netkf ARGS; None when it did not end within `timeout` (a hang is a failed expectation)."""
    try:
        return netkf(*args, timeout=timeout)
    except subprocess.TimeoutExpired:
        print("(did not end within %d s)" % timeout, flush=True)
        return None


def refused(r, says):
    """Exit 2, `says` on stderr, and nothing started."""
    return r is not None and r.returncode == 2 and says in r.stderr and "started" not in r.stderr


# ---- time-like flags: one validator (finite, in range) for every one of them
sweep_out = os.path.join(out, "sweep")
quick = ("--dashboard", "off", "--status-interval", "0")
for args in (("launch", "--duration", "nan"), ("launch", "--duration", "1e300"), ("launch", "--duration", "inf"),
             ("launch", "--ready-timeout", "nan"), ("launch", "--status-interval", "nan"),
             ("launch", "--status-interval", "1e300"), ("launch", "--domain-check", "nan"),
             ("record", "--out", os.path.join(out, "r.csv"), "--duration", "nan"),
             ("sweep", good, "--vary", "sensors.1.link.loss=0.1", "--out", sweep_out, "--duration", "nan"),
             ("sweep", good, "--vary", "sensors.1.link.loss=0.1", "--out", sweep_out, "--duration", "1e300"),
             ("sweep", good, "--vary", "sensors.1.link.loss=0.1", "--out", sweep_out, "--duration", "-1")):
    r = run(*(args + (quick if args[0] == "launch" else ())), timeout=30)
    check(refused(r, "must be a number of seconds"), "netkf %s: exit 2, the flag's range said" % " ".join(args))
check(not os.path.exists(sweep_out), "no refused sweep wrote its directory")

# ---- two outputs on one file: refused before any file is opened, however the path is spelled
same = os.path.join(out, "same.csv")
for second in (same, os.path.join(out, ".", "same.csv"), os.path.join(out, "sub", "..", "same.csv")):
    os.makedirs(os.path.join(out, "sub"), exist_ok=True)
    r = run("launch", "--duration", "2", "--record", same, "--record-samples", second, *quick)
    check(refused(r, "are one file") and not os.path.exists(same),
          "launch --record %s --record-samples %s: exit 2 before anything is written" % (same, second))
target = os.path.join(out, "target.json")
with open(target, "w") as f:
    f.write("kept\n")
os.symlink(target, os.path.join(out, "alias.json"))
r = run("launch", "--duration", "2", "--summary", target, "--pid-file", os.path.join(out, "alias.json"), *quick)
check(refused(r, "are one file") and open(target).read() == "kept\n",
      "launch --summary X --pid-file (a symbolic link to X): exit 2, X untouched")
r = run("launch", "--duration", "2", "--record", os.path.join(out, "a.csv"), "--summary", os.path.join(out, "a.csv"),
        *quick)
check(refused(r, "are one file"), "launch --record X --summary X: exit 2")
r = run("record", "--out", os.path.join(out, "b.csv"), "--samples", os.path.join(out, "b.csv"), "--duration", "1")
check(refused(r, "are one file"), "record --out X --samples X: exit 2")
with open(os.path.join(out, "hard.csv"), "w") as f:
    f.write("x\n")
os.link(os.path.join(out, "hard.csv"), os.path.join(out, "hard-link.csv"))
r = run("launch", "--duration", "2", "--summary", os.path.join(out, "hard.csv"), "--pid-file",
        os.path.join(out, "hard-link.csv"), *quick)
check(refused(r, "are one file") and open(os.path.join(out, "hard.csv")).read() == "x\n",
      "launch --summary X --pid-file (a hard link of X): exit 2, X untouched")

# ---- an earlier recording is not replaced without --force; a FIFO or a device is never written
earlier = os.path.join(out, "earlier.csv")
with open(earlier, "w") as f:
    f.write("an earlier run\n")
r = run("launch", "--duration", "2", "--record", earlier, *quick)
check(refused(r, "give --force") and open(earlier).read() == "an earlier run\n",
      "launch --record EXISTING: exit 2, the file kept as it was")
r = run("record", "--out", earlier, "--duration", "1")
check(refused(r, "give --force") and open(earlier).read() == "an earlier run\n",
      "record --out EXISTING: exit 2, the file kept as it was")
r = run("record", "--out", earlier, "--duration", "1", "--force")  # no network on this domain: exit 3
check(r is not None and r.returncode == 3 and open(earlier).read().startswith("k,t,"),
      "record --out EXISTING --force: replaced (a new header), the run goes on")
fifo = os.path.join(out, "fifo.csv")
os.mkfifo(fifo)
r = run("launch", "--duration", "2", "--record", fifo, *quick, timeout=30)
check(refused(r, "is a FIFO") and stat.S_ISFIFO(os.lstat(fifo).st_mode), "launch --record FIFO: exit 2, no wait")
fifo_svg = os.path.join(out, "fifo.svg")
os.mkfifo(fifo_svg)
r = run("analyze", good, "--plot", fifo_svg, timeout=30)
check(refused(r, "is a FIFO"), "analyze --plot FIFO: exit 2, no wait")
devices = []
try:
    null_copy = os.path.join(out, "null")
    os.mknod(null_copy, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    devices.append(null_copy)
except PermissionError:
    print("(mknod not allowed: no device copies)", flush=True)
for device in devices:
    for args in (("launch", "--duration", "2", "--record", device) + quick,
                 ("launch", "--duration", "2", "--summary", device) + quick,
                 ("trace", "extract", good, "--link", "1", "-o", device)):
        r = run(*args)
        check(refused(r, "is a character device") and stat.S_ISCHR(os.lstat(device).st_mode),
              "netkf %s: exit 2, the device left in place" % " ".join(args))

# ---- inputs: a device is refused unread; an empty events file is not "no changes"
for args in (("analyze", "/dev/zero"), ("launch", "/dev/urandom") + quick, ("fit", "/dev/zero")):
    r = run(*args, timeout=30)
    check(refused(r, "is a character device"), "netkf %s: exit 2 at once, the device not read" % " ".join(args))
empty = os.path.join(out, "empty.events.yaml")
open(empty, "w").close()
r = run("launch", "--events", empty, "--duration", "2", *quick)
check(refused(r, "the events file is empty"), "launch --events EMPTY: exit 2")

# ---- trace extract: a malformed recording is exit 2 at FILE:LINE
samples = os.path.join(out, "samples.csv")
with open(samples, "w") as f:
    f.write("k,sensor_id,stamp,fused,y0\n4,1,0.04,1,0.5\n5,1,abc,1,zz\n")
r = run("trace", "extract", samples, "--link", "1", "-o", os.path.join(out, "link1.csv"))
check(refused(r, samples + ":3: stamp must be a number") and not os.path.exists(os.path.join(out, "link1.csv")),
      "trace extract of a malformed row: exit 2 at FILE:LINE, no trace written")
with open(samples, "w") as f:
    f.write("k,sensor_id,stamp,fused,y0\n4,1,0.04,1,0.5\n5,1,0.0")
r = run("trace", "extract", samples, "--link", "1", "-o", os.path.join(out, "link1.csv"))
check(refused(r, samples + ":3: the last row is cut"), "trace extract of a file cut mid-row: exit 2")
r = run("trace", "extract", samples, "--link", "1", "-o", samples)
check(refused(r, "an output may not overwrite an input"), "trace extract -o THE_RECORDING: exit 2")

# ---- DDS Security: every identity the launch's processes use is checked before the start
secure = os.path.join(out, "sec")
r = run("security", "init", secure, "--days", "2", timeout=120)
check(r is not None and r.returncode == 0, "security init makes the directory")
if r is not None and r.returncode == 0:
    for role in ("plant", "sensor", "channel", "estimator", "observer", "ctl"):
        key = os.path.join(secure, "identities", role, "key.pem")
        check(stat.S_IMODE(os.stat(key).st_mode) == 0o600, "security init writes %s's key 0600" % role)
    plant_key = os.path.join(secure, "identities", "plant", "key.pem")
    os.chmod(plant_key, 0o644)
    r = run("launch", "--secure", secure, "--duration", "2", *quick)
    check(refused(r, "chmod 600 " + plant_key), "launch with a world-readable key: exit 2 naming the key and chmod 600")
    os.chmod(plant_key, 0o640)
    r = run("launch", "--secure", secure, "--duration", "2", *quick)
    check(refused(r, "readable by others (mode 0640)"), "launch with a group-readable key: exit 2")
    os.chmod(plant_key, 0o600)
    os.remove(os.path.join(secure, "identities", "estimator", "cert.pem"))
    r = run("launch", "--secure", secure, "--duration", "2", *quick)
    check(refused(r, "identities/estimator/cert.pem is missing"),
          "launch with a missing identity certificate: exit 2 before anything starts")
for target, says in (("", "empty path"), ("/proc/netkf-x", "cannot make"), (os.path.join(out, "dangling"), "symbolic link")):
    if target.endswith("dangling"):
        os.symlink(os.path.join(out, "nowhere"), target)
    r = run("security", "init", target)
    check(r is not None and r.returncode == 2 and says in r.stderr and "filesystem error" not in r.stderr,
          "security init '%s': exit 2, a clear message" % target)
finish()
