"""A relay's timeline, its journal and the journal's replay, and its checks (docs/relay.md,
"A timeline of changes", "The journal and its replay", "Checks and the summary"): `netkf relay`
of rt/chatter from domain 119 to 120 with a relay file whose `events:` sets the loss to 1 at the
topic's sample 200.

Independent expectations: the closed form of the timeline (every sample from index 200 on is
dropped until the live change), the index the live change must apply at (the samples the
recording shows before it), the recording's own counts for the summary, and a second run: the
replay of the first run's journal over a talker writing the same number of samples (in another
split: the fates depend on the sample indices only) must record the same fate for every index.

1. relay.yaml --record r1.csv --check (passes) --summary s1.json --dashboard 0; a talker writes
   300 samples; `netkf ctl set-link rt/chatter --bernoulli 0.5` (applies at sample 300,
   journaled); a second talker writes 200 more; a Foxglove client (@foxglove/ws-protocol) sets
   the topic's loss to 0 (applies at sample 500, journaled); a third talker writes 100 more;
   Ctrl-C: exit 0, r1.csv.events.yaml holds the timeline's set at 200 and the live changes at
   300 and 500, s1.json the recording's counts and the checks passed.
2. relay.yaml --events r1.csv.events.yaml --record r2.csv --check (fails): one talker of 600
   samples; Ctrl-C: exit 1, the fate column equals r1's, its journal equals r1's.
3. A check on a topic not relayed, an events file naming one: exit 2 before anything starts, the
   events file's mistake at its line and column."""
import csv
import json
import os
import re
import subprocess

import yaml

from e2e_common import (NETKF, REPO, LoggedProcesses, check, cyclone_programs, finish, node, require_netns,
                         stop_process, wait_for, workdir)

require_netns()
FROM, TO = 119, 120
FIRST, SECOND, THIRD = 300, 200, 100  # the first run's three talkers
TOTAL = FIRST + SECOND + THIRD
AT = 200                  # the timeline's event: loss 1 from this sample on
CHATTER = cyclone_programs("NETKF_CYCLONE_CHATTER")
out = workdir("relay_events")
env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml"))
processes = LoggedProcesses(out, env)
start, text = processes.start, processes.text

relay_file = os.path.join(out, "relay.yaml")
with open(relay_file, "w") as f:
    f.write("""relay:
  from_domain: %d
  to_domain: %d
  seed: 31
  topics:
    - name: rt/chatter
      link: { model: bernoulli, loss: 0.3 }
events:
  - { at_sample: %d, topic: rt/chatter, set: { loss: 1.0 } }
""" % (FROM, TO, AT))


def run(cmd):
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=90)
    print(r.stdout[-3000:], r.stderr[-2000:], end="", flush=True)
    return r


def lines(path):
    try:
        with open(path) as f:
            return sum(1 for _ in f)
    except FileNotFoundError:
        return 0


def talk(count, first):
    r = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(count), "--first", str(first), "--rate-hz", "300"])
    check(r.returncode == 0, "a talker wrote %d samples through the relay" % count)


def fnv1a(text):
    h = 14695981039346656037
    for c in text.encode():
        h = ((h ^ c) * 1099511628211) % 2 ** 64
    return h


def link_id(topic):
    """relay_topic_link_id (docs/relay.md): -1000 - FNV-1a(topic) mod 2^30."""
    return -1000 - fnv1a(topic) % 2 ** 30


def journal(path):
    with open(path) as f:
        return yaml.safe_load(f)["events"]


def fates(path):
    with open(path) as f:
        rows = [r for r in csv.DictReader(f) if r["topic"] == "rt/chatter"]
    return {int(r["index"]): r["fate"] for r in rows}, len(rows)


# ---- 1: the timeline, a live change, the journal, a check that passes ----
r1, s1 = os.path.join(out, "r1.csv"), os.path.join(out, "s1.json")
j1 = r1 + ".events.yaml"
relay = start("relay1", [NETKF, "relay", relay_file, "--record", r1, "--summary", s1,
                         "--check", "link.rt/chatter.samples>=%d" % TOTAL, "--check", "link.rt/chatter.observed_loss<0.9",
                         "--dashboard", "0"])
try:
    check(wait_for(lambda: os.path.exists(j1), 20), "the relay writes its journal from the start")
    check(journal(j1) == [], "an empty journal before any change")
    talk(FIRST, 1)
    check(wait_for(lambda: lines(r1) == FIRST + 1, 20), "the recording has a line per sample")
    check(wait_for(lambda: len(journal(j1)) == 1, 10), "the timeline's change is journaled as it happens")
    live = run([NETKF, "ctl", "set-link", "rt/chatter", "--bernoulli", "0.5", "--domain", str(TO)])
    check(live.returncode == 0, "`netkf ctl set-link rt/chatter --bernoulli 0.5` is applied (rc=%d)" % live.returncode)
    check(wait_for(lambda: len(journal(j1)) == 2, 10), "the live change is journaled as it happens")
    talk(SECOND, 1001)
    check(wait_for(lambda: lines(r1) == FIRST + SECOND + 1, 20), "the recording has the second talker's samples")
    port = re.search(r"ws://127\.0\.0\.1:(\d+)/", text("relay1", ".out") + text("relay1", ".log")).group(1)
    fox = node("foxglove_client.mjs", "--url", "ws://127.0.0.1:%s/" % port, "--seconds", 2, "--set-after", 0.3,
               "--set", "link.%d.loss=0" % link_id("rt/chatter"))
    check(fox.get("connected"), "a Foxglove client set the topic's loss to 0")
    check(wait_for(lambda: len(journal(j1)) == 3, 10), "the WebSocket's change is journaled as it happens")
    talk(THIRD, 2001)
    check(wait_for(lambda: lines(r1) == TOTAL + 1, 20), "the recording has the third talker's samples")
finally:
    rc1 = stop_process(relay)
print("---- relay 1 ----\n" + text("relay1", ".out") + text("relay1", ".log")[-3000:], flush=True)
check(rc1 == 0, "the first relay exits 0: its checks passed (rc=%s)" % rc1)

first, n1 = fates(r1)
check(n1 == TOTAL and sorted(first) == list(range(TOTAL)), "the recording has indices 0..%d once each" % (TOTAL - 1))
before = [first[i] for i in range(AT)]
check("delivered" in before and "dropped" in before, "before sample %d the link drops some samples (loss 0.3)" % AT)
check(all(first[i] == "dropped" for i in range(AT, FIRST)),
      "every sample from %d to %d is dropped (the timeline's loss 1)" % (AT, FIRST - 1))
after = [first[i] for i in range(FIRST, FIRST + SECOND)]
check(after.count("delivered") > 0 and after.count("dropped") > 0,
      "from sample %d on the live change's loss 0.5 delivers again (%d of %d)" % (FIRST, after.count("delivered"),
                                                                                  SECOND))
entries = journal(j1)
print("journal:", json.dumps(entries), flush=True)
check(all(first[i] == "delivered" for i in range(FIRST + SECOND, TOTAL)),
      "every sample from %d on is delivered (the WebSocket's loss 0)" % (FIRST + SECOND))
check(len(entries) == 3, "the journal holds the timeline's change and the two live ones (%d)" % len(entries))
if len(entries) == 3:
    check(entries[0]["at_sample"] == AT and entries[0]["topic"] == "rt/chatter"
          and entries[0]["set"]["model"] == "bernoulli" and entries[0]["set"]["loss"] == 1.0,
          "the timeline's change: rt/chatter set to loss 1 at sample %d" % AT)
    check(entries[1]["at_sample"] == FIRST and entries[1]["set"]["loss"] == 0.5,
          "the live change: loss 0.5 from sample %d, the first after the %d the recording had" % (FIRST, FIRST))
    check(entries[2]["at_sample"] == FIRST + SECOND and entries[2]["set"]["loss"] == 0,
          "the WebSocket's change: loss 0 from sample %d" % (FIRST + SECOND))
with open(s1) as f:
    summary = json.load(f)
dropped = sum(f == "dropped" for f in first.values())
link = summary["link"]["rt/chatter"]
check(link["samples"] == TOTAL and link["dropped"] == dropped and link["delivered"] == TOTAL - dropped,
      "the summary counts what the recording shows (%d samples, %d dropped)" % (TOTAL, dropped))
check(abs(link["observed_loss"] - dropped / TOTAL) < 1e-12, "the summary's observed loss is the recording's")
check(summary["end"] == "signal", "the summary says the relay ended on a signal (Ctrl-C)")
check(summary["passed"] is True and [c["verdict"] for c in summary["checks"]] == ["PASS", "PASS"],
      "both checks passed in the summary")
check("2 checks: 2 passed, 0 failed" in text("relay1", ".out"), "the relay prints the checks' table")

# ---- 2: the replay of the journal, a check that fails ----
r2, s2 = os.path.join(out, "r2.csv"), os.path.join(out, "s2.json")
relay = start("relay2", [NETKF, "relay", relay_file, "--events", j1, "--record", r2, "--summary", s2,
                         "--check", "link.rt/chatter.observed_loss<0.2"])
try:
    check(wait_for(lambda: os.path.exists(r2 + ".events.yaml"), 20), "the replaying relay is up")
    talk(TOTAL, 1)  # one talker: the split of the samples does not matter
    check(wait_for(lambda: lines(r2) == TOTAL + 1, 20), "the replay's recording has a line per sample")
finally:
    rc2 = stop_process(relay)
print("---- relay 2 ----\n" + text("relay2", ".out") + text("relay2", ".log")[-3000:], flush=True)
check(rc2 == 1, "the replaying relay exits 1: its check failed (rc=%s)" % rc2)
second, n2 = fates(r2)
same = n2 == TOTAL and all(second.get(i) == first[i] for i in range(TOTAL))
check(same, "the replay records the same fate for every one of the %d samples" % TOTAL)
check(journal(r2 + ".events.yaml") == entries, "the replay's journal is the original's")
with open(s2) as f:
    summary2 = json.load(f)
check(summary2["passed"] is False and summary2["checks"][0]["verdict"] == "FAIL"
      and abs(summary2["checks"][0]["value"] - dropped / TOTAL) < 1e-12,
      "the summary says the check failed, with the observed loss %.4f" % (dropped / TOTAL))
check("FAIL" in text("relay2", ".out"), "the table shows the failed check")

# ---- 3: mistakes refused before anything starts ----
bad_check = run([NETKF, "relay", relay_file, "--check", "link.rt/scan.samples>1", "--duration", "1"])
check(bad_check.returncode == 2 and "topic rt/scan is not relayed" in bad_check.stderr,
      "a check on a topic the relay does not relay: exit 2, said (rc=%d)" % bad_check.returncode)
bad_events = os.path.join(out, "bad.events.yaml")
with open(bad_events, "w") as f:
    f.write("events:\n  - { at_sample: 5, topic: rt/scan, set: { loss: 1 } }\n")
refused = run([NETKF, "relay", relay_file, "--events", bad_events, "--duration", "1"])
check(refused.returncode == 2 and bad_events + ":2:" in refused.stderr and "rt/scan is not relayed" in refused.stderr,
      "an events file naming another topic: exit 2 at its line (rc=%d)" % refused.returncode)
again = run([NETKF, "relay", relay_file, "--record", r1, "--duration", "1"])
check(again.returncode == 2 and "exists" in again.stderr, "an existing recording is not overwritten (exit 2)")
finish()
