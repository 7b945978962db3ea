"""The live dashboard of `netkf launch`, seen by real clients (docs/dashboard.md):
- Debian's Chromium, driven by playwright-core, opens the page, sees the plots receive
  points and sets link 2 to loss 1.0 with the page's own control; `netkf ctl status` and
  the recording then show that sensor 2 is no longer fused, and the page's event log
  shows the change; no console errors; the screenshot is kept as an artefact;
- the page then sets link 2's delay to 3 ms (its delay field: only link.2.delay_ms is
  sent) and Gilbert-Elliott link 3 by loss 0.2 and mean burst 4 (its user's form, one key
  per change); `netkf ctl status` and the link status a Foxglove client receives show the
  delay applied with link 2's loss model unchanged, and link 3's chain at the closed form
  r = 1/mean_burst, p = r·loss/(1 − loss), loss_good 0, loss_bad 1;
- @foxglove/ws-protocol's client (an independent implementation of the protocol) receives
  estimates equal to the --record CSV rows of the same periods, and sets a link parameter;
- /metrics passes `promtool check metrics`, and its link counters agree with
  `netkf ctl status --json`;
- the page's observed arrival rates follow their stated definitions (docs/dashboard.md,
  "Observed arrival rates") and agree with `netkf ctl status --json` run while the page is
  read: each card's "λ since change" is its "in time / samples", and those counts are ctl's
  `delivered_in_time` / `samples_in` within one report interval; the window's rate and span
  follow from the same counts; the stability panel's observed rates are the cards'
  since-change rates.
"""
import json
import os
import re
import subprocess
import time
import urllib.request

from e2e_common import (NETKF, Launch, node, check, finish, netkf, read_periods, read_samples, require_netns,
                        wait_for, workdir)

PORT = 8470  # the default; the test's network namespace has it to itself
DELAY_MS = 3.0                  # link 2's delay, set from the page (below the 8 ms deadline)
GE_LOSS, GE_BURST = 0.2, 4.0    # link 3 (Gilbert-Elliott) in the user's form, set from the page
PERIOD_MS = 10                  # the default scenario's period
WINDOW_SAMPLES = 1000           # the observed rate window's least span (cli/live/include/netkf/cli/live/observed_rate.hpp)
# The channel reports each link once a second: a report adds 1000 / PERIOD_MS = 100 samples
# per link. The page and ctl each show the newest report they have, so read within a second of
# each other they are at most one report apart; 10 % more for the timers' jitter.
REPORT_SAMPLES = 1.1 * 1000 / PERIOD_MS
ARTEFACTS = os.environ.get("NETKF_ARTEFACT_DIR", os.path.join(os.environ.get("NETKF_BIN_DIR", "/tmp"), "artefacts"))




def scrape():
    with urllib.request.urlopen("http://127.0.0.1:%d/metrics" % PORT, timeout=10) as r:
        return r.read().decode()


def series(text, name, labels=""):
    m = re.search(r"^%s%s (\S+)$" % (re.escape(name), re.escape(labels)), text, re.M)
    return float(m.group(1)) if m else None


def page_counts(stats):
    """(in time, samples, λ since change) of a card's stats, None when it shows none."""
    m = re.fullmatch(r"(\d+) / (\d+)", stats.get("in time / samples", ""))
    rate = stats.get("λ since change", "")
    if not m or not re.fullmatch(r"\d\.\d{3}", rate):
        return None
    return int(m.group(1)), int(m.group(2)), float(rate)


def window_problem(stats, samples, since_change):
    """Why the card's window rate and span do not follow from its since-change counts
    (observed_rate.hpp), or None."""
    m = re.fullmatch(r"(\d\.\d{3}) over (\d+)", stats.get("λ last ≥%d samples" % WINDOW_SAMPLES, ""))
    if m is None:
        return "no window rate and span shown: %s" % stats
    rate, span = float(m.group(1)), int(m.group(2))
    if samples < WINDOW_SAMPLES:  # not yet full: the window is everything since the change
        if span != samples or rate != since_change:
            return "%s over %d, but %d samples since the change at %.3f" % (rate, span, samples, since_change)
    elif not WINDOW_SAMPLES <= span <= min(samples, WINDOW_SAMPLES + REPORT_SAMPLES):
        # whole reports: at least WINDOW_SAMPLES, at most one report more, never past the change
        return "spans %d samples of %d since the change" % (span, samples)
    return None


def check_against_ctl(link, readings, ctl):
    """One link of `netkf ctl status --json` against the page's readings around the ctl run."""
    lid, n, in_time = str(link["sensor_id"]), link["samples_in"], link["delivered_in_time"]
    check(in_time == link["delivered"] - link["past_deadline"],
          "link %s: ctl's delivered_in_time = delivered − past_deadline" % lid)
    want = in_time / n if n else None
    check(link.get("observed_arrival_rate_since_change") == want,
          "link %s: ctl's observed_arrival_rate_since_change = %s / %s" % (lid, in_time, n))
    # Readings within a second of the ctl run (it reads the channel's newest report while it
    # runs); the one nearest in samples is compared.
    near = [page_counts(r["links"].get(lid, {})) for r in readings
            if ctl["start_ms"] - 1000 <= r["ms"] <= ctl["end_ms"] + 1000]
    near = [c for c in near if c is not None]
    if not check(near and n > 0, "link %s: the page showed counts around the ctl run" % lid):
        return
    x, y, rate = min(near, key=lambda c: abs(c[1] - n))
    bound = REPORT_SAMPLES / min(y, n) + 0.0005  # one report's samples move the ratio this much; 3 decimals shown
    check(abs(y - n) <= REPORT_SAMPLES and abs(x - in_time) <= REPORT_SAMPLES and abs(rate - want) <= bound,
          "link %s: the page's λ since change %.3f (%d / %d) agrees with ctl's %d / %d = %.4f within one report "
          "(%.4f)" % (lid, rate, x, y, in_time, n, want, bound))


def check_observed_rates(page):
    """The page's observed arrival rates against their definitions and `netkf ctl status --json`."""
    readings, ctl = page.get("readings", []), page.get("ctl") or {}
    status = ctl.get("status") or {}
    if not check(len(readings) >= 3 and status.get("links"), "the page was read around a ctl status (%d readings; "
                 "ctl error: %s)" % (len(readings), ctl.get("error"))):
        return
    for link in status["links"]:
        check_against_ctl(link, readings, ctl)
    # Every reading of every card: the rate is its counts' ratio, the window follows from them.
    shown, wrong = 0, []
    for r in readings:
        for lid, stats in r["links"].items():
            counts = page_counts(stats)
            if counts is None:
                continue
            shown += 1
            x, y, rate = counts
            if not (y > 0 and abs(rate - x / y) <= 0.0005 + 1e-12):
                wrong.append("link %s: %.3f ≠ %d / %d" % (lid, rate, x, y))
            problem = window_problem(stats, y, rate)
            if problem:
                wrong.append("link %s window: %s" % (lid, problem))
    check(shown > 0 and not wrong, "in %d card readings, λ since change = in time / samples and the window follows "
          "from the same counts: %s" % (shown, wrong[:5]))
    # The stability panel's observed column names its rates and shows the cards' since-change
    # rates. The theory is requested once a second from the rates then reported and shown when
    # computed, so it may lag the cards by a refresh, the computation and a redraw: three reports.
    panel = [r for r in readings if re.fullmatch(r"\d\.\d{3}(, \d\.\d{3})*", r["theory"]["rates"])]
    check(panel and all("since change" in r["theory"]["header"] for r in panel),
          "the stability panel's observed column says 'since change': %s" % (panel[-1]["theory"] if panel else None))
    compared, apart = 0, []
    for r in panel:
        for lid, th in zip(sorted(r["links"], key=int), (float(v) for v in r["theory"]["rates"].split(", "))):
            counts = page_counts(r["links"][lid])
            if counts is None:
                continue
            compared += 1
            bound = 3 * REPORT_SAMPLES / counts[1] + 0.001
            if abs(th - counts[2]) > bound:
                apart.append("link %s: %.3f vs %.3f (bound %.4f)" % (lid, th, counts[2], bound))
    check(compared > 0 and not apart, "in %d panel readings, the panel's observed rates are the cards' since-change "
          "rates within three reports: %s" % (compared, apart[:5]))


require_netns()
out = workdir("dashboard")
os.makedirs(ARTEFACTS, exist_ok=True)
# The built-in default scenario, as the demo. Link 2 is set to loss 1.0 (below critical): the
# loop may diverge before the end, which this test of the page allows.
with Launch(None, 120, out, samples=True, extra=["--allow-divergence"]) as run:
    check(wait_for(lambda: "dashboard: http://127.0.0.1:%d/" % PORT in run.output(), 20),
          "launch prints the dashboard's URL")
    # A status line of a fused period (not the launch line's "period 10 ms").
    check(wait_for(lambda: re.search(r"^period \d+ ", run.output(), re.M) is not None, 20), "the network runs")
    listening = subprocess.run(["ss", "-ltnH"], capture_output=True, text=True).stdout
    check("127.0.0.1:%d" % PORT in listening and "0.0.0.0:%d" % PORT not in listening,
          "the dashboard listens on 127.0.0.1 only:\n" + listening)

    # ---- metrics: promtool accepts them; the counters agree with ctl status
    before = scrape()
    st = netkf("ctl", "status", "--json")
    after = scrape()
    metrics_file = os.path.join(out, "metrics.txt")
    with open(metrics_file, "w") as f:
        f.write(after)
    lint = subprocess.run(["promtool", "check", "metrics"], input=after, capture_output=True, text=True)
    print(lint.stdout, lint.stderr, flush=True)
    check(lint.returncode == 0, "promtool check metrics accepts /metrics")
    for name in ("netkf_link_samples_total", "netkf_link_delivered_total", "netkf_link_dropped_total",
                 "netkf_link_configured_loss", "netkf_link_observed_loss", "netkf_link_observed_arrival_rate",
                 "netkf_link_observed_window_samples", "netkf_estimator_period",
                 "netkf_estimator_trace_p", "netkf_estimator_diverging", "netkf_estimator_fused_sensors",
                 "netkf_samples_late_total", "netkf_samples_rejected_total", "netkf_pipeline_latency_seconds_bucket",
                 "netkf_process_restarts_total"):
        check(re.search(r"^%s[ {]" % name, after, re.M) is not None, "/metrics has %s" % name)
    if st.returncode == 0:
        for link in json.loads(st.stdout)["links"]:
            lab = '{link="%d"}' % link["sensor_id"]
            for key, metric in (("samples_total", "netkf_link_samples_total"),
                                ("delivered_total", "netkf_link_delivered_total"),
                                ("dropped_total", "netkf_link_dropped_total")):
                lo, hi = series(before, metric, lab), series(after, metric, lab)
                check(lo is not None and hi is not None and lo <= link[key] <= hi,
                      "link %d: ctl's %s %s lies between the scrapes before and after (%s, %s)"
                      % (link["sensor_id"], key, link[key], lo, hi))
            check(abs(series(after, "netkf_link_configured_loss", lab) - link["stationary_loss"]) < 1e-12,
                  "link %d: configured loss agrees" % link["sensor_id"])
            for window in ("since_change", "last_%d_samples" % WINDOW_SAMPLES):
                rate = series(after, "netkf_link_observed_arrival_rate", '{link="%d",window="%s"}' % (link["sensor_id"], window))
                check(rate is not None and 0.0 <= rate <= 1.0,
                      "link %d: /metrics has its observed arrival rate, window=%s (%s)" % (link["sensor_id"], window, rate))
    else:
        check(False, "ctl status works")
    check(series(after, "netkf_pipeline_latency_seconds_count") > 0, "pipeline latency observed")

    # ---- an independent client: @foxglove/ws-protocol, no Origin (like a desktop app)
    fox = node("foxglove_client.mjs", "--url", "ws://127.0.0.1:%d/" % PORT, "--seconds", 3,
               "--set", "link.1.loss=0.25")
    topics = sorted(c.get("topic") for c in fox.get("channels", []))
    check("netkf/estimate" in topics and "netkf/theory" in topics, "advertised channels: %s" % topics)
    fox_estimates = fox.get("estimates", [])
    check(len(fox_estimates) > 50, "the Foxglove client received estimates (%d)" % len(fox_estimates))
    applied = [p for pv in fox.get("parameter_values", []) for p in pv.get("parameters", [])
               if p.get("name") == "link.1.loss"]
    check(any(abs(p.get("value", -1) - 0.25) < 1e-15 for p in applied),
          "setParameters link.1.loss=0.25 answered with the new value: %s" % applied)
    st = netkf("ctl", "status", "--json")
    l1 = [l for l in json.loads(st.stdout)["links"] if l["sensor_id"] == 1] if st.returncode == 0 else []
    check(l1 and l1[0]["model"] == "bernoulli" and l1[0]["loss"] == 0.25, "ctl status shows link 1 at loss 0.25")

    # ---- a foreign web page's Origin is refused
    evil = node("foxglove_client.mjs", "--url", "ws://127.0.0.1:%d/" % PORT, "--seconds", 1,
                "--origin", "http://evil.example")
    check(evil.get("refused") is True and evil.get("http_status") == 403,
          "a WebSocket from origin http://evil.example is refused with 403: %s" % {k: evil.get(k) for k in
                                                                                   ("refused", "http_status")})

    # ---- a real browser
    shot = os.path.join(ARTEFACTS, "dashboard.png")
    page = node("dashboard_browser.mjs", "--url", "http://127.0.0.1:%d/" % PORT, "--screenshot", shot,
                "--link", 2, "--loss", "1.0", "--delay", "2=%g" % DELAY_MS,
                "--gilbert", "3=%g,%g" % (GE_LOSS, GE_BURST), "--compare-ctl", NETKF, "--timeout", 100, timeout=150)
    t_applied = time.monotonic()
    check(page.get("estimates_received", 0) > 50, "the page received estimates (%s)" % page.get("estimates_received"))
    check(page.get("points_plotted", 0) > 50, "the page's plots hold points (%s)" % page.get("points_plotted"))
    check(not page.get("console_errors") and not page.get("page_errors"),
          "no console or page errors: %s %s" % (page.get("console_errors"), page.get("page_errors")))
    log = page.get("event_log", [])
    check(any("link 2" in e and "loss=1" in e and "dashboard" in e for e in log),
          "the page's event log shows the change from the dashboard: %s" % log[-5:])
    # In the default scenario link 2 is critical (deploy/scenarios/default.yaml): its loss
    # at 1.0 moves the network below the boundary, and the page says so.
    check(any("below the critical arrival rate" in e for e in log),
          "the page's event log shows the boundary warning: %s" % log[-5:])
    check(page.get("verdict", {}).get("configured") == "no",
          "the page's verdict for the configured links is 'no': %s" % page.get("verdict"))
    check(os.path.getsize(shot) > 10000 if os.path.exists(shot) else False, "screenshot saved: %s" % shot)
    # ---- the page's delay and Gilbert-Elliott controls: each change sends only its key
    steps = page.get("steps", [])

    def step(link, param):
        return next((s for s in steps if s.get("link") == link and s.get("param") == param), {})

    def sent_parameters(s):
        return [p for frame in s.get("sent", []) if isinstance(frame, dict) for p in frame.get("parameters", [])]

    for link, param, value in ((2, "delay_ms", DELAY_MS), (3, "loss", GE_LOSS), (3, "mean_burst", GE_BURST)):
        s = step(link, param)
        check(s.get("applied") is True, "the page set link %d's %s to %g; the event log shows it applied: %s (error %s)"
              % (link, param, value, s.get("applied_entry"), s.get("error")))
        sent = sent_parameters(s)
        check([(p.get("name"), p.get("value")) for p in sent] == [("link.%d.%s" % (link, param), value)],
              "changing link %d's %s on the page sent link.%d.%s only: %s" % (link, param, link, param, sent))
    check(not [s for s in steps if s.get("error")], "no page step failed: %s" % [s for s in steps if s.get("error")])
    stats2 = page.get("link_stats", {}).get("2", {})
    check(stats2.get("delay") == "%g ms" % DELAY_MS and stats2.get("P(in time)") == "1.000" and
          re.fullmatch(r"\d+", stats2.get("held", "")) is not None,
          "link 2's card shows the delay, P(in time) and held samples: %s" % stats2)

    check_observed_rates(page)

    # Independent paths: the channel's own link status, through netkf ctl and a Foxglove client.
    r_expected = 1.0 / GE_BURST
    p_expected = r_expected * GE_LOSS / (1.0 - GE_LOSS)
    st = netkf("ctl", "status", "--json")
    links = {l["sensor_id"]: l for l in json.loads(st.stdout)["links"]} if st.returncode == 0 else {}
    l2, l3 = links.get(2, {}), links.get(3, {})
    check(l2.get("model") == "bernoulli" and l2.get("loss") == 1.0, "ctl status shows link 2 at loss 1.0: %s" % l2)
    check(l2.get("delay_ms") == DELAY_MS and l2.get("jitter_ms") == 0.0 and l2.get("delay_distribution") == "uniform",
          "ctl status shows link 2's delay set from the page, its loss model kept: %s" % l2)
    check(l3.get("model") == "gilbert_elliott" and abs(l3.get("r", -1) - r_expected) < 1e-12 and
          abs(l3.get("p", -1) - p_expected) < 1e-12 and l3.get("loss_good") == 0.0 and l3.get("loss_bad") == 1.0,
          "ctl status shows link 3 at r = 1/%g = %g, p = r·%g/(1 − %g) = %g, loss_good 0, loss_bad 1: %s"
          % (GE_BURST, r_expected, GE_LOSS, GE_LOSS, p_expected, l3))
    check(abs(l3.get("stationary_loss", -1) - GE_LOSS) < 1e-12 and abs(l3.get("mean_burst", -1) - GE_BURST) < 1e-9,
          "ctl status shows link 3's stationary loss %g and mean burst %g: %s" % (GE_LOSS, GE_BURST, l3))
    fox_links = node("foxglove_client.mjs", "--url", "ws://127.0.0.1:%d/" % PORT, "--seconds", 2,
                     "--topic", "netkf/link/status")
    last = {}
    for m in fox_links.get("estimates", []):  # the payloads of --topic
        last[m.get("sensor_id")] = m
    s2, s3 = last.get(2, {}), last.get(3, {})
    check(s2.get("model") == "bernoulli" and s2.get("loss") == 1.0 and s2.get("delay_ms") == DELAY_MS and
          s2.get("jitter_ms") == 0.0 and s2.get("delay_distribution") == "uniform" and s2.get("in_time") == 1.0 and
          isinstance(s2.get("held"), int) and s2.get("configured_arrival_rate") == 0.0,
          "the Foxglove client's link status of link 2 shows the delay, the kept loss 1.0, in_time 1, held: %s" % s2)
    check(s3.get("model") == "gilbert_elliott" and abs(s3.get("p", -1) - p_expected) < 1e-12 and
          abs(s3.get("r", -1) - r_expected) < 1e-12 and abs(s3.get("loss", -1) - GE_LOSS) < 1e-12 and
          abs(s3.get("mean_burst", -1) - GE_BURST) < 1e-9 and
          abs(s3.get("configured_arrival_rate", -1) - (1 - GE_LOSS) * s3.get("in_time", -1)) < 1e-12,
          "the Foxglove client's link status of link 3 shows both forms and the effective rate: %s" % s3)
    time.sleep(3)
    rc = run.interrupt()
check(rc == 0, "launch exits 0 on Ctrl-C (rc=%s)" % rc)

rows = read_periods(run.record, 2)
by_k = {r["k"]: r for r in rows}
# Foxglove's estimates are the recording's rows, value for value (JSON and the CSV's 17
# significant digits both carry doubles exactly).
matched = [e for e in fox_estimates if e["k"] in by_k]
check(len(matched) > 50, "the Foxglove estimates' periods are in the recording (%d)" % len(matched))
mismatch = [e["k"] for e in matched if e["x_hat"] != by_k[e["k"]]["xhat"] or e["trace_P"] != by_k[e["k"]]["trace_P"]
            or e["fused"] != by_k[e["k"]]["fused"] or e["state"] != by_k[e["k"]]["state"]]
check(not mismatch, "every Foxglove estimate equals its CSV row (mismatches at k=%s)" % mismatch[:5])

# The browser's change: from the first period published after it was applied, sensor 2 is
# never fused again (times joined through the steady clock the sensors stamp samples with).
samples = read_samples(run.samples)
stamp_of_k = {}
for s in samples:
    stamp_of_k[s["k"]] = min(stamp_of_k.get(s["k"], 1e300), s["stamp"])
k_applied = min((k for k, t in stamp_of_k.items() if t >= t_applied), default=None)
check(k_applied is not None, "periods were recorded after the change")
if k_applied is not None:
    after_change = [r for r in rows if r["k"] >= k_applied + 2]
    check(len(after_change) > 50 and not any(2 in r["fused"] for r in after_change),
          "sensor 2 fused in no period after the page's change (%d periods)" % len(after_change))
    before_change = [r for r in rows if r["k"] < k_applied - 200]
    check(any(2 in r["fused"] for r in before_change), "sensor 2 was fused before the change")
finish()
