"""`netkf fit` on the shipped example trace (deploy/traces/example-gilbert-elliott.csv,
docs/cli.md "netkf fit"), against expectations computed here from the file itself:

- --json: the sample and drop counts; the bernoulli candidate is the drop fraction with the
  binomial standard error; the simple Gilbert candidate's p and r are the transition
  frequencies; the chosen (auto) fit is bursty and its 95% intervals hold the generating
  parameters stated in the trace's comment line; its `link` object is a scenario link.
- --plot: an SVG naming the fitted model.
- --scenario/--link/-o: the copy loads (`netkf analyze` on it) and carries the fitted link.
- A malformed trace: exit 2 and FILE:LINE:COL on stderr.
- -o (docs/cli.md, "Files"): checked before the fit (an unknown --link prints no fit); only a
  regular file is written, replaced whole: a device (copies of /dev/null and /dev/full), a FIFO
  or the trace itself is refused with exit 2 and left in place; a full disk (a 4 KiB tmpfs in
  a mount namespace of the command's own) is "cannot write X: No space left on device", exit
  2, and the file that was there is kept.
- `netkf analyze S.yaml --link 1=TRACE`: on Sinopoli's scalar plant with a simple Gilbert
  trace made here (seeded), the criterion is α²(1 − r̂) with r̂ the trace's recovery
  frequency and the critical mean burst 1/(1 − 1/α²) (Rohr-Marelli-Fu Thm 3.1; the
  scenario's comment); a bad --link is exit 2.
No DDS is started (the harness's network namespace is kept for uniformity).
"""
import json
import math
import os
import re
import shutil
import stat
import subprocess

from e2e_common import NETKF, REPO, check, finish, netkf, require_netns, workdir

require_netns()
trace = os.path.join(REPO, "deploy", "traces", "example-gilbert-elliott.csv")
scenario = os.path.join(REPO, "deploy", "scenarios", "markov-gilbert-scalar.yaml")
out = workdir("fit")

# ---- the trace, read here
delivered, truth = [], {}
with open(trace) as f:
    for line in f:
        line = line.strip()
        if line.startswith("#"):
            for key, value in re.findall(r"\b(p|r|loss_good|loss_bad)=([0-9.]+)", line):
                truth[key] = float(value)
            continue
        if not line or line.startswith("k,"):
            continue
        delivered.append(int(line.split(",")[1]))
n = len(delivered)
dropped = n - sum(delivered)
check(set(truth) == {"p", "r", "loss_good", "loss_bad"}, "the trace states its generating parameters: %s" % truth)

# ---- auto, --json
r = netkf("fit", trace, "--json")
check(r.returncode == 0, "fit --json exits 0 (rc=%d)" % r.returncode)
j = json.loads(r.stdout) if r.returncode == 0 else {}
for key in ("model", "loss", "mean_burst", "stderr", "log_likelihood", "aic", "gof", "link", "family", "why"):
    check(key in j, "--json has '%s'" % key)
check(j.get("samples") == n and j.get("dropped") == dropped, "counts: %d samples, %d dropped" % (n, dropped))
cands = {c["family"]: c for c in j.get("candidates", [])}
check(set(cands) == {"bernoulli", "simple_gilbert", "gilbert", "gilbert_elliott"}, "auto fits every family")

loss = dropped / n
b = cands.get("bernoulli", {})
check(abs(b.get("loss", -1) - loss) < 1e-12, "bernoulli loss = drop fraction %.6g" % loss)
se = math.sqrt(loss * (1 - loss) / n)
check(abs(b.get("stderr", {}).get("loss", -1) - se) < 1e-3 * se, "bernoulli stderr = sqrt(l(1-l)/n) = %.6g" % se)
check(abs(b.get("log_likelihood", 0) - (dropped * math.log(loss) + (n - dropped) * math.log(1 - loss))) < 1e-6,
      "bernoulli log-likelihood = m ln l + (n-m) ln(1-l)")

from_good = sum(1 for t in range(1, n) if delivered[t - 1] == 1)
good_to_bad = sum(1 for t in range(1, n) if delivered[t - 1] == 1 and delivered[t] == 0)
from_bad = (n - 1) - from_good
bad_to_good = sum(1 for t in range(1, n) if delivered[t - 1] == 0 and delivered[t] == 1)
sg = cands.get("simple_gilbert", {}).get("link", {})
check(abs(sg.get("p", -1) - good_to_bad / from_good) < 1e-12 and abs(sg.get("r", -1) - bad_to_good / from_bad) < 1e-12,
      "simple_gilbert p, r = transition frequencies %.6g, %.6g" % (good_to_bad / from_good, bad_to_good / from_bad))

check(j.get("family") != "bernoulli" and "Bursty" in j.get("why", ""), "auto calls the trace bursty: %s" % j.get("why"))
check(j.get("model") == "gilbert_elliott" and j.get("link", {}).get("model") == "gilbert_elliott",
      "the fitted link is a scenario's gilbert_elliott link")
for key, value in truth.items():
    ci = j.get("ci95", {}).get(key)
    if j.get("family") == "gilbert_elliott" or key in ("p", "r"):
        check(ci is not None and ci[0] <= value <= ci[1], "95%% interval of %s %s holds the generating %g" % (key, ci, value))
check(j.get("aic") == min(c["aic"] for c in cands.values()) or "within 2" in j.get("why", ""),
      "the chosen family has the least AIC, or a simpler one within 2")
delay = j.get("delay") or {}
check(delay.get("samples") == sum(delivered) and abs(delay.get("mean_ms", 0) - 5.0) < 0.1,
      "delay: every delivered sample has one, mean near the generating 5 ms")

# ---- the fitted link into a scenario copy
copy = os.path.join(out, "fitted.yaml")
r = netkf("fit", trace, "--scenario", scenario, "--link", "1", "-o", copy)
check(r.returncode == 0 and os.path.exists(copy), "--scenario --link 1 -o writes the copy")
r = netkf("analyze", copy, "--json", "--no-lmi")
check(r.returncode == 0, "the copy is a valid scenario (analyze exits %d)" % r.returncode)
if r.returncode == 0:
    links = json.loads(r.stdout).get("links", [])
    check(len(links) == 1 and abs(links[0]["loss"] - j.get("loss", -1)) < 1e-4,
          "analyze reads the fitted link's loss %.6g" % j.get("loss", -1))

# ---- --plot: the burst histogram as a figure (gnuplot)
plot = os.path.join(out, "bursts.svg")
r = netkf("fit", trace, "--plot", plot)
svg = open(plot).read() if os.path.exists(plot) else ""
check(r.returncode == 0 and "<svg" in svg and "fitted gilbert_elliott" in svg, "--plot writes the SVG with the fitted model")
r = netkf("fit", trace, "--plot", os.path.join(out, "bursts.txt"))
check(r.returncode == 2, "--plot with another extension: exit 2")

# ---- bad input
bad = os.path.join(out, "bad.csv")
with open(bad, "w") as f:
    f.write("k,delivered\n0,1\n1,2\n")
r = netkf("fit", bad)
check(r.returncode == 2 and (bad + ":3:3: delivered must be 0 or 1") in r.stderr, "a value 2 is refused at FILE:3:3")
r = netkf("fit", trace, "--scenario", scenario, "--link", "9", "-o", os.path.join(out, "x.yaml"))
check(r.returncode == 2 and "no such link" in r.stderr and not os.path.exists(os.path.join(out, "x.yaml")),
      "an unknown --link is refused, nothing written")
check(r.stdout == "", "... before the fit: no fit was printed")

# ---- -o: a regular file only, written whole; nothing else is touched
copy_args = ("fit", trace, "--scenario", scenario, "--link", "1", "-o")
fifo = os.path.join(out, "fifo.yaml")
os.mkfifo(fifo)
targets = [(fifo, "is a FIFO")]
try:
    for name, minor in (("null", 3), ("full", 7)):
        os.mknod(os.path.join(out, name), 0o666 | stat.S_IFCHR, os.makedev(1, minor))
        targets.append((os.path.join(out, name), "is a character device"))
except PermissionError:
    print("(mknod not allowed: no device copies)", flush=True)
for target, says in targets:
    try:
        r = netkf(*(copy_args + (target,)), timeout=30)
    except subprocess.TimeoutExpired:
        r = None
    kind = os.lstat(target).st_mode if os.path.lexists(target) else 0  # removed: the defect this checks
    check(r is not None and r.returncode == 2 and says in r.stderr and r.stdout == "" and
          (stat.S_ISFIFO(kind) or stat.S_ISCHR(kind)),
          "-o %s: exit 2 before the fit ('%s'), left in place" % (target, says))
own_trace = os.path.join(out, "trace.csv")  # a copy: a regression must not write over the shipped trace
shutil.copyfile(trace, own_trace)
r = netkf("fit", own_trace, "--scenario", scenario, "--link", "1", "-o", own_trace)
check(r.returncode == 2 and "an output may not overwrite an input" in r.stderr and
      open(own_trace).read() == open(trace).read(), "-o TRACE: exit 2, the trace untouched")
# An existing copy is replaced whole, its mode kept.
with open(copy, "a") as f:
    f.write("# an old line\n")
os.chmod(copy, 0o640)
r = netkf(*(copy_args + (copy,)))
check(r.returncode == 0 and "an old line" not in open(copy).read() and stat.S_IMODE(os.stat(copy).st_mode) == 0o640,
      "-o EXISTING: replaced whole, mode 0640 kept")
# A full disk: the write error said, the old file kept, no temporary file left.
disk = os.path.join(out, "disk")
os.mkdir(disk)
script = ('mount -t tmpfs -o size=4k netkf-fit-full "$0" && printf old > "$0/fitted.yaml" && '
          'head -c 4096 /dev/zero > "$0/filler"; "$@"; rc=$?; cat "$0/fitted.yaml"; echo; ls -a "$0"; exit $rc')
cmd = ["unshare", "-m", "--propagation", "private", "--", "sh", "-c", script, disk, NETKF] + \
    list(copy_args + (os.path.join(disk, "fitted.yaml"),))
print("$", " ".join(cmd), flush=True)
full = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
print(full.stdout, full.stderr, sep="", end="", flush=True)
check(full.returncode == 2 and "cannot write %s (-o): No space left on device" % os.path.join(disk, "fitted.yaml")
      in full.stderr, "-o on a full disk: exit 2, 'cannot write X: No space left on device'")
check("\nold\n" in full.stdout and ".netkf-" not in full.stdout,
      "... the old file kept as it was, no temporary file left")

# ---- analyze --link: the verdict for a measured link
import random
rng = random.Random(5)
bad_state, rows = False, ["# simple Gilbert p=0.2 r=0.5 (seed 5)", "k,delivered"]
for k in range(20000):
    bad_state = (rng.random() < 0.2) if not bad_state else not (rng.random() < 0.5)
    rows.append("%d,%d" % (k, 0 if bad_state else 1))
sg_trace = os.path.join(out, "sg.csv")
with open(sg_trace, "w") as f:
    f.write("\n".join(rows) + "\n")
d = [int(x.split(",")[1]) for x in rows[2:]]
lost_then = sum(1 for t in range(1, len(d)) if d[t - 1] == 0)
recovered = sum(1 for t in range(1, len(d)) if d[t - 1] == 0 and d[t] == 1)
alpha2 = 1.25 ** 2
r = netkf("analyze", scenario, "--link", "1=" + sg_trace, "--json", "--no-lmi")
check(r.returncode == 0, "analyze --link exits 0 (rc=%d)" % r.returncode)
a = json.loads(r.stdout) if r.returncode == 0 else {}
m = (a.get("measured_links") or [{}])[0]
check(m.get("family") == "simple_gilbert", "the simple Gilbert trace is fitted as simple_gilbert (%s)" % m.get("family"))
expected = alpha2 * (1 - recovered / lost_then)
check(abs((m.get("markov_criterion") or 0) - expected) < 1e-6 and abs((a.get("markov_criterion") or 0) - expected) < 1e-6,
      "criterion = alpha^2 (1 - r_hat) = %.6g, in the report and for the link" % expected)
check(m.get("stable") == "yes" and a.get("stable") == "yes", "stable with the measured link")
crit = (m.get("mean_burst_margin") or {}).get("critical")
check(crit is not None and abs(crit - 1 / (1 - 1 / alpha2)) < 1e-5,
      "critical mean burst %s = 1/(1 - 1/alpha^2) = %.6g" % (crit, 1 / (1 - 1 / alpha2)))
check(m.get("across_interval", "").startswith("stable across"), "stable across the fit's intervals: %s" % m.get("across_interval"))
for bad_link, says in (("9=" + sg_trace, "no such link"), ("one=" + sg_trace, "expected ID=TRACE.csv"),
                       ("1=" + bad, "delivered must be 0 or 1")):
    r = netkf("analyze", scenario, "--link", bad_link)
    check(r.returncode == 2 and says in r.stderr, "analyze --link %s: exit 2, says '%s'" % (bad_link, says))
finish()
