"""`netkf relay --dashboard`'s page (docs/relay.md, "The page") in a real browser: a Cyclone DDS
talker writes rt/chatter on domain 117; `netkf relay` passes it to 118 through a Bernoulli link of
loss 0.3, recording each sample's fate, and serves its page. Debian's Chromium, driven by
playwright-core (relay_page_browser.mjs), opens the page as a user does.

Independent expectations: the relay's recording (a CSV line per sample), `netkf ctl status`
(DDS, not the page's WebSocket) and a Cyclone DDS listener of another vendor. Checked: the page
shows a card for rt/chatter whose samples, delivered and dropped equal the recording's, with the
model and its stationary loss, the type the talker registered and a plot of the loss; a loss of
1.5 typed into its form is refused and the card shows the reason; a loss of 0 and a delay of 5 ms
typed and submitted are applied: ctl status shows loss 0 and delay 5 ms for rt/chatter, a second
talker's samples are all delivered 5 ms late per the recording and all reach the listener, and
the plot's loss over the last interval with samples is then 0."""
import csv
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time

from e2e_common import (NETKF, REPO, LoggedProcesses, check, cyclone_programs, finish, node, require_netns,
                         stop_process, wait_for, workdir)

require_netns()
FROM, TO = 117, 118
COUNT, LOSS = 300, 0.3
COUNT2 = 100  # after the page made the link lossless
DELAY_MS = 5  # and set this delay
TYPE = "std_msgs::msg::dds_::String_"  # the type name the Cyclone talker registers
CHATTER = cyclone_programs("NETKF_CYCLONE_CHATTER")
if not os.access("/usr/bin/chromium", os.X_OK):
    print("Debian's chromium is not installed (scripts/deps.sh)", flush=True)
    sys.exit(1 if os.environ.get("CI") == "true" else 77)
out = workdir("relay_page")
env = dict(os.environ, CYCLONEDDS_URI="file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml"))
record = os.path.join(out, "fates.csv")


processes = LoggedProcesses(out, env)
start, text = processes.start, processes.text


stop = stop_process


def run(cmd):
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=90)
    print(r.stdout[-3000:], r.stderr[-2000:], end="", flush=True)
    return r


def rows():
    with open(record) as f:
        return list(csv.DictReader(f))


def port_of_relay():
    m = re.search(r"http://127\.0\.0\.1:(\d+)/metrics", text("relay", ".out") + text("relay", ".log"))
    return m.group(1) if m else None


def browse(port, *args):
    return node("relay_page_browser.mjs", "--url", "http://127.0.0.1:%s/" % port, "--topic", "rt/chatter",
                "--timeout", 60, *args, timeout=90)


listener = start("listener", [CHATTER, "listen", "--domain", str(TO), "--duration", "150"])
relay = start("relay", [NETKF, "relay", "--from-domain", str(FROM), "--to-domain", str(TO), "--topic", "rt/chatter",
                        "--bernoulli", str(LOSS), "--seed", "31", "--record", record, "--dashboard", "0"])
try:
    check(wait_for(lambda: "ready" in text("listener", ".log") and port_of_relay(), 20),
          "the listener is up and the relay logged its dashboard's port")
    port = port_of_relay()
    talker = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT), "--rate-hz", "200"])
    check(talker.returncode == 0, "the talker wrote %d samples through the relay" % COUNT)
    check(wait_for(lambda: len(rows()) == COUNT, 20), "the recording has a line per sample")
    # The page, as a user opens it: the card, then a refused change.
    refused = browse(port, "--samples", COUNT, "--loss", "1.5")
    # Then a change to a lossless link, typed into the card's form.
    # Then a lossless link with a delay, typed into the card's form; the page stays open while a
    # second talker writes (its plot then has the intervals of those samples).
    applied = {}
    applying = threading.Thread(target=lambda: applied.update(browse(
        port, "--samples", COUNT, "--loss", "0", "--delay-ms", DELAY_MS, "--then-samples", COUNT2,
        "--screenshot", os.path.join(out, "relay_page.png"))))
    applying.start()
    status = None
    for _ in range(60):  # the change applied, as DDS (not the page) says
        status = run([NETKF, "ctl", "status", "--json", "--domain", str(TO)])
        if any(l.get("topic") == "rt/chatter" and l.get("loss") == 0 for l in json.loads(status.stdout or "{}").get("links", [])):
            break
        time.sleep(0.5)
    talker2 = run([CHATTER, "talk", "--domain", str(FROM), "--count", str(COUNT2), "--first", "1001",
                   "--rate-hz", "200"])
    check(talker2.returncode == 0, "a second talker wrote %d samples" % COUNT2)
    check(wait_for(lambda: len(rows()) == COUNT + COUNT2, 20), "the recording has them too")
    applying.join(timeout=100)
    time.sleep(1.0)  # the listener's last samples
finally:
    rc_relay = stop(relay)
    rc_listener = stop(listener)
print("---- relay ----\n" + text("relay", ".out") + text("relay", ".log")[-3000:], flush=True)
check(rc_relay == 0 and rc_listener == 0, "relay and listener exit 0 (%s, %s)" % (rc_relay, rc_listener))

fates = rows()
first, second = fates[:COUNT], fates[COUNT:]
delivered = sum(r["fate"] == "delivered" for r in first)
dropped = sum(r["fate"] == "dropped" for r in first)
print("recording: %d samples, %d delivered, %d dropped; then %d" % (len(first), delivered, dropped, len(second)))
print("page (refused):", json.dumps(refused), flush=True)
print("page (applied):", json.dumps(applied), flush=True)
card = refused.get("card_before") or {}
check(refused.get("error") is None and refused.get("cards") == ["rt/chatter"],
      "the page shows one card, rt/chatter's (%s, %s)" % (refused.get("cards"), refused.get("error")))
check((card.get("samples_in"), card.get("delivered"), card.get("dropped")) == (str(COUNT), str(delivered), str(dropped)),
      "the card's samples, delivered, dropped (%s, %s, %s) equal the recording's (%d, %d, %d)"
      % (card.get("samples_in"), card.get("delivered"), card.get("dropped"), COUNT, delivered, dropped))
check(card.get("model") == "bernoulli loss=0.3" and card.get("stationary_loss") == "0.3"
      and abs(float(card.get("observed_loss", "nan")) - dropped / COUNT) < 1e-4,
      "the card shows the model, its stationary loss and the observed loss %.4f (%s)" % (dropped / COUNT, card))
check(int(card.get("link_id", "0")) < -2, "the card is the topic's link id (%s)" % card.get("link_id"))
check(card.get("type") == TYPE and card.get("delay") == "none",
      "the card shows the type the talker registered and no delay (%s, %s)" % (card.get("type"), card.get("delay")))
plotted = refused.get("card_after") or {}  # the page open a few statuses long
check(plotted.get("plot_canvas") and int(plotted.get("plot_points") or 0) >= 2,
      "the card plots its loss (%s points)" % plotted.get("plot_points"))
check(refused.get("answer_state") == "refused" and "loss" in (refused.get("answer") or ""),
      "a loss of 1.5 is refused and the card shows why (%r)" % refused.get("answer"))
sent = [p for m in applied.get("set_requests_sent", []) for p in m.get("parameters", [])]
check({p["name"]: p["value"] for p in sent} == {"link.%s.model" % card.get("link_id"): "bernoulli",
                                                "link.%s.loss" % card.get("link_id"): 0,
                                                "link.%s.delay_ms" % card.get("link_id"): DELAY_MS},
      "the page sent setParameters link.ID.model/loss/delay_ms of rt/chatter's link id (%s)" % sent)
check(applied.get("error") is None and applied.get("answer_state") == "applied",
      "a loss of 0 typed into the card's form is applied (%r, %s)" % (applied.get("answer"), applied.get("error")))
check((applied.get("card_after") or {}).get("model") == "bernoulli loss=0"
      and (applied.get("card_after") or {}).get("delay") == "%d ms" % DELAY_MS,
      "the card shows the new model and delay then (%s)" % applied.get("card_after"))
check(status.returncode == 0, "`netkf ctl status --json --domain %d` answers" % TO)
links = [l for l in json.loads(status.stdout or "{}").get("links", []) if l.get("topic") == "rt/chatter"]
check(len(links) == 1 and links[0]["model"] == "bernoulli" and links[0]["loss"] == 0
      and links[0]["delay_ms"] == DELAY_MS,
      "ctl status shows rt/chatter's link at loss 0, delay %d ms (%s)" % (DELAY_MS, links))
check(len(second) == COUNT2 and all(r["fate"] == "delivered" and float(r["delay_ms"]) == DELAY_MS for r in second),
      "the recording delivers each of the second talker's %d samples %d ms late (%d rows)"
      % (COUNT2, DELAY_MS, len(second)))
card3 = applied.get("card_after") or {}
check(card3.get("samples_in") == str(COUNT2) and card3.get("plot_last_interval_loss") == "0",
      "the open page's plot: loss 0 over its last interval with samples, once the lossless link had the second "
      "talker's %d samples (%s, %s points)" % (COUNT2, card3.get("plot_last_interval_loss"), card3.get("plot_points")))
got = [l.strip() for l in text("listener", ".out").splitlines() if l.startswith("hello ")]
numbers = [int(l.split()[1]) for l in got]
print("listener: %d samples, last %s" % (len(got), got[-3:]), flush=True)
check(sum(1 for n in numbers if n <= COUNT) == delivered,
      "the listener got as many of the first talker's samples as the recording delivered (%d)" % delivered)
check(sorted(n for n in numbers if n > 1000) == list(range(1001, 1001 + COUNT2)),
      "and every one of the second talker's %d samples, once" % COUNT2)
check(applied.get("page_errors") == [] and applied.get("console_errors") == [] and applied.get("request_failures") == [],
      "the page ran without errors (%s %s %s)" % (applied.get("page_errors"), applied.get("console_errors"),
                                                  applied.get("request_failures")))
finish()
