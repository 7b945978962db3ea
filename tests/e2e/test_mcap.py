"""MCAP recordings (docs/recording.md): `netkf launch --record run.mcap` and
`netkf record --out x.mcap`, read back with an independent reader (@mcap/core's
McapStreamReader, tests/e2e/mcap_read.mjs).

One launch records run.mcap (with --record-samples, so delivered samples are in it too)
and is stopped by SIGTERM; `netkf record --out same.csv` records the same network, attached
(two launches would not be comparable), and `netkf record --out attached.mcap` too. Checks:
- the file is complete (Footer and closing magic) after a SIGTERM stop;
- the channels are the DDS topics, JSON messages, jsonschema schemas; link status and the
  link change made with `netkf ctl set-link` are in it, delivered samples too;
- netkf/events holds the run's events as Foxglove's foxglove.Log: the ctl change once, at
  INFO, on the run's clock from the period before the one the channel applied it from;
- every period of same.csv is in run.mcap with the same x̂ (the exact double) and Tr P;
- the attached MCAP recorder's estimates equal the launch's for the periods both have;
- a file cut mid-record (what kill -9 leaves) is still read up to its last whole record.
"""
import json
import os
import signal
import time

from e2e_common import (DATA, BackgroundProcess, Launch, NETKF, check, node, finish, netkf, read_periods, require_netns,
                        workdir)

require_netns()
scenario = os.path.join(DATA, "bernoulli3.yaml")  # three links, Bernoulli loss 0.3, period 40 ms, n = 2
N = 2
PERIOD_MS = 40  # bernoulli3.yaml's period
out = workdir("mcap")


def mcap_read(path):
    return node("mcap_read.mjs", path, timeout=60)


def recorder(path, seconds):
    cmd = [NETKF, "record", scenario, "--out", path, "--duration", str(seconds)]
    return BackgroundProcess(cmd, log=path + ".log")


run_mcap = os.path.join(out, "run.mcap")
same_csv = os.path.join(out, "same.csv")
attached_mcap = os.path.join(out, "attached.mcap")
samples_csv = os.path.join(out, "samples.csv")
with Launch(scenario, 60, out, record=False,
            extra=["--record", run_mcap, "--record-samples", samples_csv, "--dashboard", "off"]) as run:
    time.sleep(2.0)  # the network runs
    rec_csv = recorder(same_csv, 5)
    rec_mcap = recorder(attached_mcap, 5)
    time.sleep(2.0)
    r = netkf("ctl", "set-link", "1", "--loss", "0.2", "--timeout", "10")
    check(r.returncode == 0, "ctl set-link 1 --loss 0.2 applied (rc=%d)" % r.returncode)
    for name, p in (("same.csv", rec_csv), ("attached.mcap", rec_mcap)):
        rc = p.stop(None, 30)  # it ends by itself after --duration; SIGKILL after 30 s
        p.close()
        print(p.output(), flush=True)
        check(rc == 0, "netkf record --out %s exits 0 (rc=%s)" % (name, rc))
    time.sleep(1.0)
    run.proc.send_signal(signal.SIGTERM)  # the launch stops its children and completes the file
    rc = run.wait(40)
    check(rc is not None, "the launch ended after SIGTERM (rc=%s)" % rc)
    run.stop()  # whatever is left
    log = run.output()
print(log[-2000:], flush=True)
check("stopped (signal)" in log, "the launch was stopped by the signal")
check(" periods in " + run_mcap in log, "launch reports the periods it wrote to the MCAP file")

m = mcap_read(run_mcap)
check(m.get("problems") == [], "run.mcap: the reader reports no problem (%s)" % m.get("problems"))
check(m.get("complete") is True, "run.mcap: complete after SIGTERM (Footer and closing magic)")
check(m.get("header") == {"profile": "", "library": "netkf"}, "run.mcap: header profile '' library 'netkf'")
topics = [c["topic"] for c in m.get("channels", [])]
check(topics == ["netkf/truth", "netkf/estimate", "netkf/measurement/delivered", "netkf/link/status",
                 "netkf/link/change", "netkf/events"], "run.mcap: channels are the DDS topics and the events (%s)" % topics)
for c in m.get("channels", []):
    check(c["messageEncoding"] == "json" and c["schemaEncoding"] == "jsonschema" and c["schemaIsJson"]
          and c["schemaName"], "%s: JSON messages, a jsonschema schema (%s)" % (c["topic"], c["schemaName"]))
counts = m.get("counts", {})
print("message counts:", counts, flush=True)
check(counts.get("netkf/estimate", 0) >= 100, "run.mcap: at least 100 estimates (%d)" % counts.get("netkf/estimate", 0))
check(counts.get("netkf/truth", 0) >= 100, "run.mcap: at least 100 truths (%d)" % counts.get("netkf/truth", 0))
check(counts.get("netkf/measurement/delivered", 0) >= 100, "run.mcap: delivered samples (--record-samples)")
check(counts.get("netkf/link/status", 0) >= 3, "run.mcap: link status messages (%d)" % counts.get("netkf/link/status", 0))
check({s.get("sensor_id") for s in m.get("link_status", [])} >= {1}, "link status messages name their sensor")
changes = [c for c in m.get("link_change", []) if c.get("origin") == "request" and c.get("sensor_id") == 1]
check(len(changes) == 1 and abs(changes[0].get("loss", -1) - 0.2) < 1e-12,
      "run.mcap: the ctl change of link 1 is in netkf/link/change (%s)" % m.get("link_change"))
# The events as Foxglove's well-known foxglove.Log: the change, announced when the channel's
# status answered it. The channel answers a request at once and applies it from the next
# period's first sample, so the event lies on the run's clock no earlier than the period
# before the one the change applied from, and within the recording.
event_channel = [c for c in m.get("channels", []) if c["topic"] == "netkf/events"]
check(bool(event_channel) and event_channel[0]["schemaName"] == "foxglove.Log",
      "run.mcap: netkf/events has Foxglove's foxglove.Log schema (%s)" % event_channel)
link_events = [e for e in m.get("events", []) if "link 1" in e.get("message", "") and "loss=0.2" in e["message"]]
check(len(link_events) == 1 and link_events[0].get("level") == 2,
      "run.mcap: one INFO event announces link 1's change (%s)" % m.get("events"))
if link_events and changes and m.get("estimates"):
    ev = link_events[0]
    ev_ns = ev["timestamp"]["sec"] * 1000000000 + ev["timestamp"]["nsec"]
    last_ns = max(int(e["log_time"]) for e in m["estimates"])
    check(ev_ns == int(ev["log_time"]) and (changes[0]["at_period"] - 1) * PERIOD_MS * 1000000 <= ev_ns <= last_ns,
          "the event's timestamp is its log time, from the period before the change's (%d) on (%d ns)"
          % (changes[0]["at_period"], ev_ns))

est = {}
for e in m.get("estimates", []):
    est[e["k"]] = e
    if int(e["log_time"]) != round(e["t"] * 1e9):
        check(False, "estimate %d: log_time is t in ns" % e["k"])
        break
rows = read_periods(same_csv, N)
check(len(rows) >= 50, "same.csv (attached netkf record): at least 50 periods (%d)" % len(rows))
missing = [r["k"] for r in rows if r["k"] not in est]
check(not missing, "every period of same.csv is in run.mcap (missing %s)" % missing[:10])
diff = [r["k"] for r in rows if r["k"] in est and (est[r["k"]]["x_hat"] != r["xhat"] or est[r["k"]]["trace_P"] != r["trace_P"])]
check(not diff, "x̂ and Tr P are the same doubles in run.mcap and same.csv (differ at %s)" % diff[:10])

a = mcap_read(attached_mcap)
check(a.get("complete") is True and a.get("problems") == [], "attached.mcap (netkf record --out): complete, no problem")
check([c["topic"] for c in a.get("channels", [])] == ["netkf/truth", "netkf/estimate", "netkf/link/status",
                                                      "netkf/link/change", "netkf/events"],
      "attached.mcap: no delivered channel without --samples")
a_est = {e["k"]: e for e in a.get("estimates", [])}
check(len(a_est) >= 50, "attached.mcap: at least 50 estimates (%d)" % len(a_est))
check(all(k in est and est[k]["x_hat"] == e["x_hat"] and est[k]["trace_P"] == e["trace_P"] for k, e in a_est.items()),
      "attached.mcap: every estimate equals run.mcap's")

# What kill -9 leaves: no footer, possibly a record cut short. The stream reader returns
# every whole record before the cut.
with open(run_mcap, "rb") as f:
    data = f.read()
cut = os.path.join(out, "cut.mcap")
with open(cut, "wb") as f:
    f.write(data[:len(data) * 2 // 3 + 5])
c = mcap_read(cut)
check(c.get("complete") is False and c.get("problems") == [], "a cut file: not complete, no error")
check(c.get("counts", {}).get("netkf/estimate", 0) > counts.get("netkf/estimate", 0) // 2,
      "a cut file: its whole records are read (%s estimates)" % c.get("counts", {}).get("netkf/estimate"))

finish()
