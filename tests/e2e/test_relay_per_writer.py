"""`netkf relay --per-writer` (docs/relay.md, "Per-writer links"): two Cyclone DDS talkers
(tests/interop/netkf_cyclone_chatter.c) write rt/chatter at once on domain 123, their
participants named robot1 and robot2 in discovery (`--name`); the relay gives each writer its
own link, rt/chatter@robot1 and rt/chatter@robot2, copies of the topic's Bernoulli 0.1, and
passes the samples to a Cyclone listener on domain 124 through the relay's one writer there.

Before they write (each waits for SIGUSR1 once the relay's reader matched it), `netkf ctl
set-link rt/chatter@robot2 --bernoulli 0.6` retunes robot2's link alone. Independent
expectations: the talkers' own numbering ("hello i" is robot1's i-th write, "hello 1000+i"
robot2's; RTPS sequence number i), the listener's decoding, binomial bounds of 0.1 and 0.6. The
recording has 400 lines per writer's link; each link's loss is within 5 binomial standard
deviations of its own model (the two are > 15 sd apart); `ctl status --json` shows both links
with the recording's counts and models, and the request on robot2's only; the listener gets
exactly the samples the recording says were delivered, each once; /metrics labels each
writer's link. Then `ctl set-link rt/chatter --bernoulli 0` (the topic) retunes both writers'
links, and a third talker whose participant announces no name (Cyclone's default) gets a link
named by its GUID prefix, a copy of the topic's new link: all its samples arrive. Once the relay
says robot1's writer is gone (its participant left or its lease expired), a new talker named
robot1 continues rt/chatter@robot1: its samples are that link's 400th to 449th."""
import csv
import json
import os
import re
import signal
import subprocess
import time
import urllib.request

from e2e_common import (NETKF, REPO, LoggedProcesses, check, cyclone_programs, finish, require_netns, stop_process,
                         wait_for, workdir)

require_netns()
FROM, TO = 123, 124
COUNT, LOSS1, LOSS2 = 400, 0.1, 0.6
COUNT3 = 100  # the unnamed third talker, after the topic's link is made lossless
COUNT4 = 50   # robot1 again, once its first writer is gone
CHATTER = cyclone_programs("NETKF_CYCLONE_CHATTER")
out = workdir("relay_per_writer")
env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml"))
record = os.path.join(out, "fates.csv")
ROBOT1, ROBOT2 = "rt/chatter@robot1", "rt/chatter@robot2"
processes = LoggedProcesses(out, env)
start, text = processes.start, processes.text


def run(cmd):
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=90)
    print(r.stdout[-3000:], r.stderr[-2000:], end="", flush=True)
    return r


def links():
    """The relay's links in `ctl status --json`, by their `topic` ({} when none answered)."""
    r = subprocess.run([NETKF, "ctl", "status", "--json", "--domain", str(TO), "--timeout", "3"],
                       capture_output=True, text=True, timeout=60)
    if r.returncode != 0:
        return {}
    return {l["topic"]: l for l in json.loads(r.stdout)["links"] if l.get("topic")}


def metrics():
    port = re.search(r"http://127\.0\.0\.1:(\d+)/metrics", text("relay", ".out") + text("relay", ".log")).group(1)
    with urllib.request.urlopen("http://127.0.0.1:%s/metrics" % port, timeout=10) as r:
        body = r.read().decode()
    return {(m.group(1), m.group(2)): float(m.group(3))
            for m in re.finditer(r'^(netkf_\w+)\{link="([^"]+)"\} (\S+)$', body, re.M)}


listener = start("listener", [CHATTER, "listen", "--domain", str(TO), "--duration", "150"])
relay = start("relay", [NETKF, "relay", "--from-domain", str(FROM), "--to-domain", str(TO), "--topic", "rt/chatter",
                        "--per-writer", "--bernoulli", str(LOSS1), "--seed", "13", "--record", record,
                        "--dashboard", "0"])
talkers = {}
status, final, metric = {}, {}, {}
try:
    check(wait_for(lambda: "ready" in text("listener", ".log"), 20), "the listener is up")
    for name, first in (("robot1", 1), ("robot2", 1001)):
        talkers[name] = start(name, [CHATTER, "talk", "--domain", str(FROM), "--name", name, "--count", str(COUNT),
                                     "--first", str(first), "--rate-hz", "200", "--wait-usr1"])
    # Each writer's link exists from its discovery on, before its first sample.
    check(wait_for(lambda: {ROBOT1, ROBOT2} <= set(links()), 40),
          "ctl status lists a link per writer, named by its participant: %s" % sorted(links()))
    set2 = run([NETKF, "ctl", "set-link", ROBOT2, "--bernoulli", str(LOSS2), "--domain", str(TO)])
    check(set2.returncode == 0, "`ctl set-link %s --bernoulli %g` is applied (rc=%d)" % (ROBOT2, LOSS2, set2.returncode))
    check(wait_for(lambda: all("matched" in text(n, ".log") for n in talkers), 30), "the relay's reader matched both")
    for p in talkers.values():
        p.send_signal(signal.SIGUSR1)
    for name, p in talkers.items():
        check(p.wait(timeout=60) == 0, "%s wrote its %d samples (%s)" % (name, COUNT, text(name, ".log").strip()))
    # The links report once a second: wait for a report with every sample in it.
    check(wait_for(lambda: all(l.get("samples_total") == COUNT for n, l in links().items() if n in (ROBOT1, ROBOT2)),
                   30), "ctl status counts every sample of both writers")
    status = links()
    metric = metrics()
    # The topic's own name: every writer's link, and the model of those to come.
    lossless = run([NETKF, "ctl", "set-link", "rt/chatter", "--bernoulli", "0", "--domain", str(TO)])
    check(lossless.returncode == 0, "`ctl set-link rt/chatter --bernoulli 0` is applied (rc=%d)" % lossless.returncode)
    third = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT3), "--first", "2001", "--rate-hz", "200"])
    check(third.returncode == 0, "an unnamed third talker wrote %d samples" % COUNT3)
    check(wait_for(lambda: sum(1 for _ in open(record)) == 2 * COUNT + COUNT3 + 1, 20), "its samples are recorded")
    time.sleep(2.5)  # a status after the last sample; the last ones reach the listener
    final = links()
    gone = "the writer of %s is gone" % ROBOT1
    check(wait_for(lambda: gone in text("relay", ".out") + text("relay", ".log"), 40),
          "the relay sees robot1's first writer gone")
    again = run([CHATTER, "talk", "--domain", str(FROM), "--name", "robot1", "--count", str(COUNT4), "--first", "3001",
                 "--rate-hz", "200"])
    check(again.returncode == 0, "a new talker named robot1 wrote %d samples" % COUNT4)
    check(wait_for(lambda: sum(1 for _ in open(record)) == 2 * COUNT + COUNT3 + COUNT4 + 1, 20), "they are recorded")
    time.sleep(1.0)  # the last ones reach the listener
finally:
    for p in talkers.values():
        stop_process(p)
    rc_relay = stop_process(relay)
    rc_listener = stop_process(listener)
log = text("relay", ".out") + text("relay", ".log")
print("---- relay ----\n" + log[-4000:], flush=True)
check(rc_relay == 0 and rc_listener == 0, "relay and listener exit 0 (%s, %s)" % (rc_relay, rc_listener))

with open(record) as f:
    rows = list(csv.DictReader(f))
by_link = {}
for r in rows:
    by_link.setdefault(r["topic"], []).append(r)
unnamed = [n for n in by_link if n not in (ROBOT1, ROBOT2)]
check(len(by_link) == 3 and len(unnamed) == 1 and re.fullmatch(r"rt/chatter@[0-9a-f]{24}", unnamed[0]),
      "the recording names three links: the two robots' and the unnamed writer's by its GUID prefix (%s)"
      % sorted(by_link))
delivered, dropped = {}, {}
for name, loss, first in ((ROBOT1, LOSS1, 1), (ROBOT2, LOSS2, 1001)):
    lines = by_link.get(name, [])[:COUNT]
    check([int(r["sequence"]) for r in lines] == list(range(1, COUNT + 1))
          and [int(r["index"]) for r in lines] == list(range(COUNT)),
          "%s: a line per sample of its writer (sequence 1..%d), numbered from 0 on its link (%d lines)"
          % (name, COUNT, len(lines)))
    delivered[name] = {int(r["sequence"]) + first - 1 for r in lines if r["fate"] == "delivered"}
    dropped[name] = {int(r["sequence"]) + first - 1 for r in lines if r["fate"] == "dropped"}
    mean, sd = COUNT * loss, (COUNT * loss * (1 - loss)) ** 0.5
    check(abs(len(dropped[name]) - mean) <= 5 * sd, "%s dropped %d of %d: within 5 sd (%.1f) of %.0f (loss %g)"
          % (name, len(dropped[name]), COUNT, sd, mean, loss))
    s = status.get(name, {})
    print("ctl status of %s:" % name, json.dumps(s))
    check((s.get("samples_in"), s.get("delivered"), s.get("dropped")) == (COUNT, len(delivered[name]), len(dropped[name]))
          and s.get("samples_total") == COUNT,
          "ctl status of %s: samples, delivered, dropped equal the recording's (%d, %d, %d)"
          % (name, COUNT, len(delivered[name]), len(dropped[name])))
    check(s.get("model") == "bernoulli" and abs(s.get("loss", -1) - loss) < 1e-12, "%s's model: Bernoulli %g" % (name, loss))
    check(metric.get(("netkf_link_samples_total", name)) == COUNT
          and metric.get(("netkf_link_dropped_total", name)) == len(dropped[name]),
          "/metrics labels %s's link with its counts" % name)
check(status.get(ROBOT1, {}).get("last_request_id") == 0 and status.get(ROBOT2, {}).get("last_request_id", 0) != 0,
      "the request is on robot2's link only")
check(status.get(ROBOT1, {}).get("sensor_id") != status.get(ROBOT2, {}).get("sensor_id"), "each link has its own id")

got = [line for line in text("listener", ".out").splitlines() if line]
numbers = [int(l.split(" ")[1]) for l in got if re.fullmatch(r"hello \d+", l)]
check(len(numbers) == len(got) and len(numbers) == len(set(numbers)),
      "the listener decoded every sample intact, none twice (%d lines)" % len(got))
for name, lo, hi in ((ROBOT1, 1, COUNT), (ROBOT2, 1001, 1000 + COUNT)):
    seen = {n for n in numbers if lo <= n <= hi}
    check(seen == delivered[name], "the listener got exactly %s's %d delivered samples (missing %s, extra %s)"
          % (name, len(delivered[name]), sorted(delivered[name] - seen)[:10], sorted(seen - delivered[name])[:10]))
third_rows = by_link.get(unnamed[0], []) if unnamed else []
check(len(third_rows) == COUNT3 and all(r["fate"] == "delivered" for r in third_rows)
      and sorted(n for n in numbers if 2000 < n <= 3000) == list(range(2001, 2001 + COUNT3)),
      "the unnamed writer's link is a copy of the topic's new lossless link: all %d recorded delivered and received"
      % COUNT3)
for name in (ROBOT1, ROBOT2):
    s = final.get(name, {})
    check(s.get("loss") == 0 and s.get("samples_in") == 0 and s.get("samples_total") == COUNT,
          "after `set-link rt/chatter`, %s is lossless with its statistics restarted (%s)" % (name, s.get("loss")))
later = by_link.get(ROBOT1, [])[COUNT:]
check([int(r["index"]) for r in later] == list(range(COUNT, COUNT + COUNT4))
      and [int(r["sequence"]) for r in later] == list(range(1, COUNT4 + 1)) and all(r["fate"] == "delivered" for r in later)
      and sorted(n for n in numbers if n > 3000) == list(range(3001, 3001 + COUNT4)),
      "the new robot1 continues rt/chatter@robot1 (indices %d.., lossless since the topic's change): all %d received"
      % (COUNT, COUNT4))
summary = {l.split()[0]: l.split()[2:5] for l in text("relay", ".out").splitlines() if l.startswith("rt/chatter")}
total_dropped = len(dropped[ROBOT1]) + len(dropped[ROBOT2])
check(summary.get(ROBOT1) == [str(COUNT + COUNT4), str(len(delivered[ROBOT1]) + COUNT4), str(len(dropped[ROBOT1]))]
      and summary.get("rt/chatter") == [str(len(rows)), str(len(rows) - total_dropped), str(total_dropped)],
      "the printed counts: a line per writer's link, the topic's line their sum (%s)" % summary)
finish()
