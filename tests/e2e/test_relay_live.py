"""A relayed topic's link on netkf's live surfaces (docs/relay.md, "Status and journal"): a
`netkf relay` of rt/chatter from domain 109 to 110 with a Bernoulli link of loss 0.3 publishes the
topic's link as a netkf/link/status (keyed by the topic's own negative link id, with the topic
named) and each change as a netkf/link/change, on its to-domain.

Independent expectations: the relay's recording of each sample's fate (a CSV line per sample), a
Cyclone DDS reader of another vendor (tests/interop/netkf_cyclone_reader.c, its types from
idl/netkf.idl through Cyclone's idlc) and the binomial bounds of the configured loss. Checked:
`netkf ctl status --domain 110 --json` lists the topic's link with samples, delivered and dropped
equal to the recording's; the text table names the topic; the Cyclone reader's last status of
the topic says the same; after `netkf ctl set-link rt/chatter --bernoulli 0` the journal entry
(seen by the Cyclone reader) names the topic, the request and the index of the first sample the
recording shows under the new link, and every sample after it is delivered; the relay's
/metrics (--metrics) counts per topic what the recording shows, and GET / serves the relay's own
page (test_relay_page.py drives it), not the launch's."""
import csv
import json
import os
import re
import signal
import subprocess
import time
import urllib.error
import urllib.request

from e2e_common import (NETKF, REPO, LoggedProcesses, check, cyclone_programs, finish, node, require_netns,
                         stop_process, wait_for, workdir)

require_netns()
FROM, TO = 109, 110
COUNT, LOSS = 400, 0.3
COUNT2 = 100  # after the link is made lossless
COUNT3 = 30   # after a Foxglove client makes it drop everything
CHATTER, READER = cyclone_programs("NETKF_CYCLONE_CHATTER", "NETKF_CYCLONE_READER")
out = workdir("relay_live")
env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml"))
record = os.path.join(out, "fates.csv")


processes = LoggedProcesses(out, env)
start, text = processes.start, processes.text


stop = stop_process


def run(cmd, **kw):
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=90, **kw)
    print(r.stdout[-3000:], r.stderr[-2000:], end="", flush=True)
    return r


def status_of_topic():
    r = run([NETKF, "ctl", "status", "--json", "--domain", str(TO)])
    check(r.returncode == 0, "`netkf ctl status --domain %d --json` finds the relay's link (rc=%d)" % (TO, r.returncode))
    links = [l for l in json.loads(r.stdout)["links"] if l.get("topic") == "rt/chatter"]
    check(len(links) == 1, "ctl status lists one link of rt/chatter (%d)" % len(links))
    return links[0]


listener = start("listener", [CHATTER, "listen", "--domain", str(TO), "--duration", "120", "--count-only"])
reader = start("reader", [READER, "--domain", str(TO), "--duration", "120"])
relay = start("relay", [NETKF, "relay", "--from-domain", str(FROM), "--to-domain", str(TO), "--topic", "rt/chatter",
                        "--bernoulli", str(LOSS), "--seed", "23", "--record", record, "--dashboard", "0"])


def metrics():
    port = re.search(r"http://127\.0\.0\.1:(\d+)/metrics", text("relay", ".out") + text("relay", ".log")).group(1)
    with urllib.request.urlopen("http://127.0.0.1:%s/metrics" % port, timeout=10) as r:
        body = r.read().decode()
    values = {}
    for line in body.splitlines():
        m = re.match(r'^(netkf_\w+)\{link="rt/chatter"\} (\S+)$', line)
        if m:
            values[m.group(1)] = float(m.group(2))
    return port, values


def page_status(port, path="/"):
    try:
        with urllib.request.urlopen("http://127.0.0.1:%s%s" % (port, path), timeout=10) as r:
            return r.status, r.read().decode()
    except urllib.error.HTTPError as e:
        return e.code, ""
try:
    check(wait_for(lambda: "ready" in text("listener", ".log") and "ready" in text("reader", ".log"), 20),
          "the listener and the Cyclone reader are up")
    talker = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT), "--rate-hz", "200"])
    check(talker.returncode == 0, "the talker wrote %d samples through the relay" % COUNT)
    # The relay reports each link once a second: wait for a report with every sample in it.
    check(wait_for(lambda: sum(1 for _ in open(record)) == COUNT + 1, 20), "the recording has a line per sample")
    time.sleep(2.5)
    before = status_of_topic()
    port, served = metrics()
    print("metrics:", served, flush=True)
    root = page_status(port)
    launch_page = page_status(port, "/app.js")
    table = run([NETKF, "ctl", "status", "--domain", str(TO)])
    check(table.returncode == 0 and any(l.startswith("rt/chatter ") for l in table.stdout.splitlines()),
          "the status table names the relayed topic's link")
    lossless = run([NETKF, "ctl", "set-link", "rt/chatter", "--bernoulli", "0", "--domain", str(TO)])
    check(lossless.returncode == 0, "`netkf ctl set-link rt/chatter --bernoulli 0` is applied (rc=%d)" % lossless.returncode)
    check("rt/chatter" in lossless.stdout and "applied" in lossless.stdout,
          "set-link shows the acknowledging status of the topic's link")
    request_id = int(lossless.stdout.split("(request ")[1].split(",")[0].split(")")[0])
    talker2 = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT2), "--first", "1001",
                   "--rate-hz", "200"])
    check(talker2.returncode == 0, "a second talker wrote %d samples" % COUNT2)
    check(wait_for(lambda: sum(1 for _ in open(record)) == COUNT + COUNT2 + 1, 20), "the recording has them too")
    time.sleep(2.5)
    after = status_of_topic()
    _, served_after = metrics()
    # An independent Foxglove client (@foxglove/ws-protocol) on the relay's WebSocket.
    fox = node("foxglove_client.mjs", "--url", "ws://127.0.0.1:%s/" % port, "--seconds", 2.5,
               "--topic", "netkf/link/status")
    # The same client changes the topic's link with a setParameters (as the dashboard's cards do).
    link_id = before["sensor_id"]
    fox_set = node("foxglove_client.mjs", "--url", "ws://127.0.0.1:%s/" % port, "--seconds", 2, "--set-after", 0.3,
                   "--set", "link.%d.loss=1" % link_id)
    talker3 = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT3), "--first", "2001",
                   "--rate-hz", "200"])
    check(talker3.returncode == 0, "a third talker wrote %d samples" % COUNT3)
    check(wait_for(lambda: sum(1 for _ in open(record)) == COUNT + COUNT2 + COUNT3 + 1, 20), "the recording has them")
    time.sleep(2.5)
    last_status = status_of_topic()
finally:
    rc_relay = stop(relay)
    rc_reader = stop(reader)
    rc_listener = stop(listener)
print("---- relay ----\n" + text("relay", ".out") + text("relay", ".log")[-3000:], flush=True)
check(rc_relay == 0 and rc_reader == 0 and rc_listener == 0,
      "relay, reader and listener exit 0 (%s, %s, %s)" % (rc_relay, rc_reader, rc_listener))

with open(record) as f:
    rows = list(csv.DictReader(f))
first, second, third = rows[:COUNT], rows[COUNT:COUNT + COUNT2], rows[COUNT + COUNT2:]
delivered = sum(r["fate"] == "delivered" for r in first)
dropped = sum(r["fate"] == "dropped" for r in first)
print("recording: %d samples, %d delivered, %d dropped; then %d" % (len(first), delivered, dropped, len(second)))
print("ctl status before the change:", json.dumps(before))
check(before["sensor_id"] < -2, "the topic's link has its own negative id (%d)" % before["sensor_id"])
check(before["model"] == "bernoulli" and abs(before["loss"] - LOSS) < 1e-12
      and abs(before["stationary_loss"] - LOSS) < 1e-12, "the status shows the configured link and its theory")
check((before["samples_in"], before["delivered"], before["dropped"]) == (COUNT, delivered, dropped),
      "ctl status: samples, delivered, dropped (%d, %d, %d) equal the recording's (%d, %d, %d)"
      % (before["samples_in"], before["delivered"], before["dropped"], COUNT, delivered, dropped))
check((before["samples_total"], before["delivered_total"], before["dropped_total"]) == (COUNT, delivered, dropped),
      "the lifetime counters equal the recording's too")
check(abs(before["observed_loss"] - dropped / COUNT) < 1e-12, "observed loss = dropped / samples")
mean, sd = COUNT * LOSS, (COUNT * LOSS * (1 - LOSS)) ** 0.5
check(abs(dropped - mean) <= 5 * sd, "dropped %d of %d: within 5 sd (%.1f) of %.0f" % (dropped, COUNT, sd, mean))
fit = before["recent_fit"]
check(fit is not None and fit["samples"] == COUNT and fit["dropped"] == dropped,
      "the recent-window fit covers the %d samples with their %d drops (%s)" % (COUNT, dropped, fit))
# The burst statistic, recomputed from the recording: drops / runs of consecutive drops.
runs = sum(1 for i, r in enumerate(first) if r["fate"] == "dropped" and (i == 0 or first[i - 1]["fate"] != "dropped"))
check(runs > 0 and abs(before["mean_burst_length"] - dropped / runs) < 1e-9,
      "mean burst length %.4f = %d drops / %d runs in the recording" % (before["mean_burst_length"], dropped, runs))

# After the change: since-change counts restart, lifetime ones go on.
check(len(second) == COUNT2 and all(r["fate"] == "delivered" for r in second),
      "the recording delivers every sample after the change (%d rows)" % len(second))
check(after["model"] == "bernoulli" and after["loss"] == 0 and after["last_request_id"] == request_id,
      "the status shows the new link and the request that made it")
check((after["samples_in"], after["delivered"], after["dropped"]) == (COUNT2, COUNT2, 0),
      "since the change: %s samples, %s delivered, %s dropped" % (after["samples_in"], after["delivered"], after["dropped"]))
check((after["samples_total"], after["delivered_total"], after["dropped_total"])
      == (COUNT + COUNT2, delivered + COUNT2, dropped), "lifetime counts go on across the change")

# The Cyclone reader: the same statuses, and the journal.
lines = [json.loads(l) for l in text("reader", ".out").splitlines() if l.startswith("{")]
statuses = [l for l in lines if l.get("topic") == "netkf/link/status" and l.get("link_topic") == "rt/chatter"]
check(statuses and all(s["sensor_id"] == before["sensor_id"] for s in statuses),
      "the Cyclone reader got the topic's status under the same link id (%d statuses)" % len(statuses))
last = statuses[-1] if statuses else {}
check((last.get("samples_total"), last.get("delivered_total"), last.get("dropped_total"))
      == (COUNT + COUNT2 + COUNT3, delivered + COUNT2, dropped + COUNT3),
      "its last status's lifetime counts equal the recording's")
changes = [l for l in lines if l.get("topic") == "netkf/link/change"]
print("journal:", changes)
check(len(changes) == 2 and changes[0]["link_topic"] == "rt/chatter" and changes[0]["origin"] == "request"
      and changes[0]["request_id"] == request_id and changes[0]["model"] == "bernoulli" and changes[0]["loss"] == 0
      and changes[0]["sensor_id"] == before["sensor_id"],
      "the journal has the change of rt/chatter by the ctl request, to bernoulli 0")
check(len(changes) == 2 and changes[1]["link_topic"] == "rt/chatter" and changes[1]["loss"] == 1
      and changes[1]["at_period"] == COUNT + COUNT2 and changes[1]["request_id"] == 0,
      "and the Foxglove client's change to loss 1, from the topic's sample %d on" % (COUNT + COUNT2))
check(changes and changes[0]["at_period"] == int(second[0]["index"]) == COUNT,
      "the change applies from the topic's sample %s, the first the recording shows under it" % (
          changes[0]["at_period"] if changes else None))

# /metrics: the same counters, per topic.
check(served.get("netkf_link_samples_total") == COUNT and served.get("netkf_link_delivered_total") == delivered
      and served.get("netkf_link_dropped_total") == dropped,
      "/metrics counts rt/chatter's samples, delivered, dropped as the recording does (%s)" % served)
check(served.get("netkf_link_configured_loss") == LOSS and served.get("netkf_link_held_samples") == 0,
      "/metrics: the configured loss and nothing held")
check(served_after.get("netkf_link_samples_total") == COUNT + COUNT2
      and served_after.get("netkf_link_delivered_total") == delivered + COUNT2
      and served_after.get("netkf_link_dropped_total") == dropped and served_after.get("netkf_link_configured_loss") == 0,
      "/metrics after the change: counters go on, the configured loss is 0 (%s)" % served_after)
check(root[0] == 200 and "/relay.js" in root[1] and launch_page[0] == 404,
      "GET / serves the relay's page, not the launch's (GET / -> %s, /app.js -> %s)" % (root[0], launch_page[0]))
fox_last = [m for m in fox.get("estimates", []) if m.get("topic") == "rt/chatter"]
check(fox_last and fox_last[-1].get("samples_total") == COUNT + COUNT2
      and fox_last[-1].get("delivered_total") == delivered + COUNT2 and fox_last[-1].get("dropped_total") == dropped
      and fox_last[-1].get("model") == "bernoulli" and fox_last[-1].get("loss") == 0,
      "a Foxglove client of the relay's WebSocket gets rt/chatter's link status with the recording's counts (%s)"
      % (fox_last[-1] if fox_last else fox))
# The change made from the WebSocket.
values = {p["name"]: p["value"] for m in fox_set.get("parameter_values", []) for p in m.get("parameters", [])}
check(values.get("link.%d.loss" % before["sensor_id"]) == 1 and values.get("link.%d.model" % before["sensor_id"])
      == "bernoulli", "the Foxglove client's setParameters is answered with the link's new parameters (%s)" % values)
check(len(third) == COUNT3 and all(r["fate"] == "dropped" for r in third),
      "after it, the recording drops each of the third talker's %d samples" % COUNT3)
check(last_status["model"] == "bernoulli" and last_status["loss"] == 1
      and (last_status["samples_in"], last_status["dropped"]) == (COUNT3, COUNT3)
      and last_status["dropped_total"] == dropped + COUNT3, "ctl status shows the new link and its counts since")
finish()
