"""Trace links (docs/scenario-format.md, "Trace links"): link 1 replays
tests/data/traces/e2e-gilbert.csv (600 rows, loop). The expectation is the trace file itself,
read here: the channel delivers sensor 1's sample of period k exactly when row k mod 600 says
delivered (the samples recording, period for period, over more than one pass of the trace).

Mid-run `netkf ctl set-link` switches link 1 to bernoulli 0.5 and then back to the trace with
offset 100 and loop false; the journal (RUN.events.yaml) holds both changes with the period
each took effect at, and from the second one on, the delivered set is row 100 + (k - a2) up to
the trace's end and nothing after it. A ctl switch to a file that does not exist is refused
with a clear error. `netkf trace extract` of the recording reproduces the trace rows (round
trip), and `netkf fit` and a `model: trace` scenario read the extracted file. `netkf analyze`
gives the link the trace's own loss (its empirical model).
"""
import json
import os

import yaml

from e2e_common import DATA, REPO, Launch, check, finish, last_period, netkf, read_samples, require_netns, wait_for, workdir

require_netns()
out = workdir("trace_link")
trace_path = os.path.join(REPO, "tests", "data", "traces", "e2e-gilbert.csv")
rows = []
with open(trace_path) as f:
    for line in f:
        line = line.strip()
        if line and not line.startswith("#") and not line.startswith("k,"):
            rows.append(int(line.split(",")[1]))
n = len(rows)
check(n == 600 and 0 < sum(rows) < n, "the trace has 600 rows, some lost (%d delivered)" % sum(rows))
scenario = os.path.join(DATA, "trace-link.yaml")

# ---- theory: the link is the trace's empirical model
r = netkf("analyze", scenario, "--json", "--no-lmi")
check(r.returncode == 0, "analyze reads a trace link (rc=%d)" % r.returncode)
if r.returncode == 0:
    link1 = [l for l in json.loads(r.stdout).get("links", []) if l.get("sensor_id", l.get("id")) == 1]
    loss = 1 - sum(rows) / n
    check(link1 and abs(link1[0]["loss"] - loss) < 1e-9, "analyze: link 1's loss is the trace's %.6g (%s)"
          % (loss, link1[0].get("loss") if link1 else None))

# ---- live: replay, switch to a model and back
with Launch(scenario, 90, out, samples=True, extra=("--dashboard", "off")) as run:
    check(wait_for(lambda: last_period(run.record) >= 700, 60), "the run passes period 700 (one loop of the trace)")
    gone = netkf("ctl", "set-link", "1", "--trace", os.path.join(out, "no-such-trace.csv"))
    check(gone.returncode == 2 and "no-such-trace.csv" in gone.stderr and "cannot open" in gone.stderr,
          "a trace that does not exist is refused with its name (rc=%d)" % gone.returncode)
    to_model = netkf("ctl", "set-link", "1", "--bernoulli", "0.5")
    check(to_model.returncode == 0, "ctl set-link 1 --bernoulli 0.5 (rc=%d)" % to_model.returncode)
    now = last_period(run.record)
    check(wait_for(lambda: last_period(run.record) >= now + 100, 30), "100 periods on bernoulli")
    back = netkf("ctl", "set-link", "1", "--trace", trace_path, "--set", "offset=100", "--set", "loop=false")
    check(back.returncode == 0, "ctl set-link 1 --trace FILE offset 100 loop false (rc=%d)" % back.returncode)
    st = netkf("ctl", "status", "--json")
    if st.returncode == 0:
        l1 = [l for l in json.loads(st.stdout)["links"] if l["sensor_id"] == 1]
        check(l1 and l1[0].get("model") == "trace" and l1[0].get("offset") == 100, "ctl status shows the trace link")
    now = last_period(run.record)
    check(wait_for(lambda: last_period(run.record) >= now + 600, 40), "600 periods after the switch back")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)

journal = run.record + ".events.yaml"
events = (yaml.safe_load(open(journal)) or {}).get("events", []) if os.path.exists(journal) else []
check(len(events) == 2 and [e["link"] for e in events] == [1, 1], "the journal holds the two changes (%s)" % events)
a1 = events[0]["at_period"] if len(events) == 2 else 10 ** 9
a2 = events[1]["at_period"] if len(events) == 2 else 10 ** 9
if len(events) == 2:
    check(events[0]["set"].get("model") == "bernoulli", "first: bernoulli")
    check(events[1]["set"].get("model") == "trace" and os.path.normpath(str(events[1]["set"].get("trace"))) == os.path.normpath(trace_path)
          and events[1]["set"].get("offset") == 100 and events[1]["set"].get("loop") in (False, "false"),
          "second: the trace, offset 100, no loop (%s)" % events[1]["set"])

samples = read_samples(run.samples)
delivered1 = {s["k"] for s in samples if s["sensor_id"] == 1}
periods = {s["k"] for s in samples if s["sensor_id"] == 2}
last = max(periods) - 5 if periods else 0  # the last periods: Ctrl-C may stop a sensor first
check(a1 > n and last > a2 + 550, "the run spans a loop of the trace before the switch and 550 periods after")
expected = {k for k in range(0, a1) if rows[k % n]}
got = {k for k in delivered1 if k < a1}
check(got == expected, "periods 0..%d: delivered = trace rows k mod %d (%d expected, %d delivered, differ at %s)"
      % (a1 - 1, n, len(expected), len(got), sorted(got ^ expected)[:5]))
expected2 = {k for k in range(a2, last) if 100 + (k - a2) < n and rows[100 + (k - a2)]}
got2 = {k for k in delivered1 if a2 <= k < last}
check(got2 == expected2, "from period %d: delivered = row 100 + (k - %d), none past the end (differ at %s)"
      % (a2, a2, sorted(got2 ^ expected2)[:5]))
between = [k for k in range(a1, a2) if k in delivered1]
check(0 < len(between) < a2 - a1, "bernoulli 0.5 between the switches delivers some, not all (%d of %d)"
      % (len(between), a2 - a1))

# ---- trace extract: the recording gives the trace back
extracted = os.path.join(out, "link1.csv")
r = netkf("trace", "extract", run.samples, "--link", "1", "-o", extracted, "--first", "0", "--last", str(n - 1))
check(r.returncode == 0, "trace extract exits 0 (rc=%d)" % r.returncode)
back_rows = []
if os.path.exists(extracted):
    with open(extracted) as f:
        lines = [l.strip() for l in f if l.strip() and not l.startswith("#")]
    check(lines[0] == "k,delivered", "the extracted trace's header is k,delivered")
    back_rows = [int(l.split(",")[1]) for l in lines[1:]]
    ks = [int(l.split(",")[0]) for l in lines[1:]]
    check(ks == list(range(n)), "k counts the periods 0..%d" % (n - 1))
check(back_rows == rows, "the extracted trace equals the replayed one, row for row")
r = netkf("fit", extracted, "--json")
check(r.returncode == 0, "netkf fit reads the extracted trace (rc=%d)" % r.returncode)
replay = os.path.join(out, "replay.yaml")
with open(scenario) as f:
    text = f.read().replace("../../data/traces/e2e-gilbert.csv", "link1.csv")
with open(replay, "w") as f:
    f.write(text)
r = netkf("analyze", replay, "--json", "--no-lmi")
check(r.returncode == 0, "a model: trace scenario reads the extracted trace (rc=%d)" % r.returncode)
r = netkf("trace", "extract", run.samples, "--link", "7", "-o", os.path.join(out, "x.csv"))
check(r.returncode == 2 and "link 7" in r.stderr, "an unknown link: exit 2 naming it")
finish()
