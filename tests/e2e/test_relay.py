"""`netkf relay` between two DDS domains for a topic netkf knows nothing of (docs/relay.md): a
Cyclone DDS talker (tests/interop/netkf_cyclone_chatter.c) writes the ROS-2-named topic
rt/chatter with the ROS-2-named type std_msgs::msg::dds_::String_ on domain 107; the relay, with
a Bernoulli link of loss 0.3, passes it to domain 108, where a Cyclone listener reads it with its
own type (compiled by Cyclone's idlc from tests/interop/ros2_chatter.idl; the relay has no IDL).

Independent expectations: the talker's own numbering ("hello i" is its i-th write, RTPS sequence
number i) and the listener's decoding. The listener receives exactly the samples the relay's
recording says it delivered (by sequence number), each once and intact, none it says it dropped;
about 70 % of 500 (5 binomial standard deviations); the relay's printed counts equal its
recording; the type it discovered is the talker's; `netkf ctl set-link` retunes the topic live;
a relay file gives each topic its own link and may ask for a type. The domains are adjacent on purpose: Fast DDS
2.9's localhost profile lets a participant of one domain discover the next one's, so the relay
sees its own writer come back, and must not relay its samples again (the listener would receive
duplicates)."""
import csv
import os
import signal
import subprocess
import time

from e2e_common import (NETKF, REPO, LoggedProcesses, check, cyclone_programs, finish, require_netns, stop_process,
                         wait_for, workdir)

require_netns()
FROM, TO = 107, 108
COUNT, LOSS = 500, 0.3
COUNT2 = 200  # after the link is made lossless
CHATTER = cyclone_programs("NETKF_CYCLONE_CHATTER")
out = workdir("relay")
env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml"))
record = os.path.join(out, "fates.csv")
record2 = os.path.join(out, "fates-file.csv")
relay_file = os.path.join(out, "relay.yaml")
relay2, rc_relay2 = None, None


processes = LoggedProcesses(out, env)
start, text = processes.start, processes.text


stop = stop_process


listener = start("listener", [CHATTER, "listen", "--domain", str(TO), "--duration", "120"])
relay = start("relay", [NETKF, "relay", "--from-domain", str(FROM), "--to-domain", str(TO), "--topic", "rt/chatter",
                        "--bernoulli", str(LOSS), "--seed", "11", "--record", record])
try:
    check(wait_for(lambda: "ready" in text("listener", ".log"), 20), "the listener is up")
    talker = subprocess.run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT), "--rate-hz", "200"],
                            capture_output=True, text=True, env=env, timeout=90)
    print(talker.stderr, end="", flush=True)
    check(talker.returncode == 0, "the talker found a reader (the relay's) and wrote %d samples" % COUNT)
    time.sleep(1.0)  # the last relayed samples reach the listener
    # Live: the topic's link becomes lossless; a second talker (a new writer: its sequence
    # numbers start at 1 again) writes "hello 1001" .. "hello 1200".
    lossless = subprocess.run([NETKF, "ctl", "set-link", "rt/chatter", "--bernoulli", "0", "--domain", str(TO)],
                              capture_output=True, text=True, timeout=30)
    print(lossless.stdout, lossless.stderr, end="", flush=True)
    check(lossless.returncode == 0, "`netkf ctl set-link rt/chatter --bernoulli 0` is applied by the relay (rc=%d)"
          % lossless.returncode)
    unknown = subprocess.run([NETKF, "ctl", "set-link", "rt/unknown", "--bernoulli", "0", "--domain", str(TO),
                              "--timeout", "2"], capture_output=True, text=True, timeout=30)
    check(unknown.returncode == 3, "a topic the relay does not relay gets no answer: exit 3 (rc=%d)" % unknown.returncode)
    # A trace's row offset on a Bernoulli link: only the link's owner can tell it does not apply.
    invalid = subprocess.run([NETKF, "ctl", "set-link", "rt/chatter", "--set", "offset=3", "--domain", str(TO)],
                             capture_output=True, text=True, timeout=30)
    print(invalid.stdout, invalid.stderr, end="", flush=True)
    check(invalid.returncode == 4, "the relay refuses a change that does not apply to the link: exit 4 (rc=%d)"
          % invalid.returncode)
    talker2 = subprocess.run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT2), "--first", "1001",
                              "--rate-hz", "200"], capture_output=True, text=True, env=env, timeout=90)
    check(talker2.returncode == 0, "the second talker wrote %d samples" % COUNT2)
    time.sleep(1.0)
    rc_relay = stop(relay)
    # A relay file: rt/chatter now drops everything; rt/other is relayed only from writers of the
    # type the file names, and the talker's is another.
    with open(relay_file, "w") as f:
        f.write("relay:\n  from_domain: %d\n  to_domain: %d\n  seed: 3\n  topics:\n"
                "    - name: rt/chatter\n      link: {model: bernoulli, loss: 1.0}\n"
                "    - name: rt/other\n      type: other_msgs::msg::dds_::Other_\n"
                "      link: {model: bernoulli, loss: 0}\n" % (FROM, TO))
    relay2 = start("relay2", [NETKF, "relay", relay_file, "--record", record2])
    talker3 = subprocess.run([CHATTER, "talk", "--domain", str(FROM), "--count", "50", "--first", "2001",
                              "--rate-hz", "200"], capture_output=True, text=True, env=env, timeout=90)
    check(talker3.returncode == 0, "a third talker wrote 50 samples to the relay of the file")
    other = start("other", [CHATTER, "talk", "--domain", str(FROM), "--topic", "rt/other", "--count", "5"])
    check(wait_for(lambda: "is not relayed" in text("relay2", ".out") + text("relay2", ".log"), 20),
          "the relay of the file refuses rt/other's writer of another type")
    stop(other)
    time.sleep(1.0)
    rc_relay2 = stop(relay2)
finally:
    rc_relay = stop(relay)
    if relay2 is not None:
        rc_relay2 = stop(relay2)
    rc_listener = stop(listener)
print("---- relay ----\n" + text("relay", ".out") + text("relay", ".log")[-3000:], flush=True)
check(rc_relay == 0 and rc_listener == 0, "relay and listener exit 0 (%s, %s)" % (rc_relay, rc_listener))
check("relaying rt/chatter (type std_msgs::msg::dds_::String_, reliable, volatile) from domain %d to domain %d"
      % (FROM, TO) in text("relay", ".out") + text("relay", ".log"), "the relay took the type name and QoS from discovery")

with open(record) as f:
    all_rows = list(csv.DictReader(f))
rows, after = all_rows[:COUNT], all_rows[COUNT:]
check(rows and list(rows[0].keys()) == ["topic", "index", "sequence", "bytes", "fate", "delay_ms"], "the recording's columns")
sequences = [int(r["sequence"]) for r in rows]
check(sorted(sequences) == list(range(1, COUNT + 1)),
      "the relay saw each of the talker's %d samples once (sequence numbers 1..%d; got %d rows)" % (COUNT, COUNT, len(rows)))
check([int(r["index"]) for r in rows] == list(range(len(rows))), "the recording numbers the topic's samples 0, 1, ...")
delivered = {int(r["sequence"]) for r in rows if r["fate"] == "delivered"}
dropped = {int(r["sequence"]) for r in rows if r["fate"] == "dropped"}
check(len(delivered) + len(dropped) == len(rows), "every sample is delivered or dropped")

got_all = [line for line in text("listener", ".out").splitlines() if line]


def number_of(line):
    word, _, number = line.partition(" ")
    return int(number) if word == "hello" and number.isdigit() else None


got = [line for line in got_all if (number_of(line) or 0) <= 1000]  # the first talker's (and anything malformed)
check(len(got) == len(set(got)), "no sample reached the listener twice (%d lines, %d distinct)" % (len(got), len(set(got))))
got_seq = set()
for line in got:
    word, _, number = line.partition(" ")
    if word == "hello" and number.isdigit():
        got_seq.add(int(number))
    else:
        check(False, "the listener decoded an intact sample (got %r)" % line)
check(got_seq == delivered, "the listener got exactly the samples the relay delivered (%d; missing %s, extra %s)"
      % (len(delivered), sorted(delivered - got_seq)[:10], sorted(got_seq - delivered)[:10]))
check(not (got_seq & dropped), "no dropped sample reached the listener")
mean, sd = COUNT * (1 - LOSS), (COUNT * LOSS * (1 - LOSS)) ** 0.5
check(abs(len(delivered) - mean) <= 5 * sd, "delivered %d of %d: within 5 sd (%.1f) of %.0f" % (len(delivered), COUNT, sd, mean))
check(len(after) == COUNT2 and all(r["fate"] == "delivered" for r in after)
      and [int(r["sequence"]) for r in after] == list(range(1, COUNT2 + 1)),
      "after the change every one of the second talker's %d samples is delivered (recording: %d rows, %d delivered)"
      % (COUNT2, len(after), sum(r["fate"] == "delivered" for r in after)))
second = sorted(n for n in map(number_of, got_all) if n and n > 1000)
check(second == list(range(1001, 1001 + COUNT2)), "the listener got all of them, once each (%d)" % len(second))
third = [n for n in map(number_of, got_all) if n and n > 2000]
check(third == [], "nothing of the third talker reached the listener (loss 1.0 from the file): %s" % third[:5])
with open(record2) as f:
    rows2 = list(csv.DictReader(f))
check(len(rows2) == 50 and all(r["fate"] == "dropped" and r["topic"] == "rt/chatter" for r in rows2),
      "the file's relay recorded the 50 samples of rt/chatter, all dropped, and none of rt/other (%d rows)" % len(rows2))
print("---- relay of the file ----\n" + text("relay2", ".out") + text("relay2", ".log")[-2000:], flush=True)
check(rc_relay2 == 0, "the file's relay exits 0 (%s)" % rc_relay2)
check(any(l.startswith("rt/other") and "(no writer seen)" in l for l in text("relay2", ".out").splitlines()),
      "its summary shows rt/other without a relayed writer")
summary = [l.split() for l in text("relay", ".out").splitlines() if l.startswith("rt/chatter")]
total_delivered = len(delivered) + len(after)
check(summary and summary[0][2:5] == [str(len(all_rows)), str(total_delivered), str(len(dropped))],
      "the relay's printed counts (samples, delivered, dropped) equal its recording: %s" % (summary[0][2:5] if summary else None))
finish()
