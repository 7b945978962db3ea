"""The actuation link (plant.control.link, link `control`) through the surfaces other than
`netkf ctl` and the CSV: the dashboard's Foxglove parameters, the journal and its replay, and the
MCAP recording (docs/scenario-format.md, "The actuation link"; docs/recording.md).

Two launches of one scenario and seed (data/actuation.yaml's loop at 20 ms, control loss 0.1):
- live: a Foxglove client (@foxglove/ws-protocol, tests/e2e/foxglove_client.mjs) reads
  `link.control.*` with getParameters and sets `link.control.loss` to 0.35 with setParameters;
  later `netkf ctl set-link control --bernoulli 0.2`. Recorded by the launch (--record a.csv, with
  its journal a.csv.events.yaml) and by an attached `netkf record --out a.mcap`.
- replay: `netkf launch --events a.csv.events.yaml`, recorded by the launch to b.mcap and by an
  attached `netkf record --out b.csv`.
Independent expectations:
- the Foxglove reply carries the new value, a later getParameters and `netkf ctl status --json`
  (the link of sensor_id -1) show it, and the journal has it (link: control) with the period it
  applied from;
- the period CSV's `nu` (did u_{k-1} reach the plant) between the changes loses inputs at each
  configured loss, within 4.5 binomial standard deviations;
- the replay reproduces the drop decisions (docs/scenario-format.md, "Recording and replaying live
  changes": with the same scenario and seed every (link, period) gets the same drop decision):
  `nu` is equal period by period, except where the plant logged an input that arrived after its
  step (timing, not a decision; --log-level debug names each);
- the truth's `input_arrived` read from the MCAP files by @mcap/core (tests/e2e/mcap_read.mjs)
  equals the CSV's `nu` of the same run, period by period, for the launch's and the attached
  recorder's MCAP; the Python reader (python/netkf) gives the MCAP and the CSV of one run the same
  `nu` column (and the same truth and inputs).
"""
import json
import math
import os
import re
import sys

import yaml

from e2e_common import (DATA, NETKF, REPO, BackgroundProcess, Launch, check, finish, last_period, netkf, node,
                        read_periods, require_netns, wait_for, workdir)

sys.path.insert(0, os.path.join(REPO, "python"))
from netkf import read_mcap_periods, read_periods as read_period_frame  # noqa: E402  (the Python reader)

require_netns()
out = workdir("actuation-surfaces")
PORT = 8470  # the dashboard's default; the test's network namespace has it to itself
LOSS_0, LOSS_FOX, LOSS_CTL = 0.1, 0.35, 0.2  # all above ν_c = 0.575's loss 0.425: the loop stays stable
SEGMENT = 200  # periods recorded between the changes (and after the last one): 4 s each

scenario = yaml.safe_load(open(os.path.join(DATA, "actuation.yaml")))
scenario["name"] = "e2e-actuation-surfaces"
scenario["plant"]["control"]["link"] = {"model": "bernoulli", "loss": LOSS_0}
scenario_path = os.path.join(out, "scenario.yaml")
with open(scenario_path, "w") as f:
    yaml.safe_dump(scenario, f)

STALE = re.compile(r"control input rejected: input for period (\d+) arrived after the plant moved past it")


def late_rows(log):
    """The rows k whose input u_{k-1} reached the plant after its step (the plant's debug log):
    nu 0 there whatever the link decided."""
    return {int(p) + 1 for p in STALE.findall(log)}


def attach(path):
    """`netkf record --out PATH` of the running network; it ends by itself after the run."""
    cmd = [NETKF, "record", scenario_path, "--out", path, "--duration", "90"]
    return BackgroundProcess(cmd, log=path + ".log", new_session=True)


def detach(rec, name):
    rc = rec.stop(None, 30)  # it ends by itself after the run; SIGKILL after 30 s
    if rec.killed:
        rc = "killed (%s)" % rc
    rec.close()
    print(rec.output()[-1500:], flush=True)
    check(rc == 0, "netkf record --out %s exits 0 by itself after the run (rc=%s)" % (name, rc))


def binomial_ok(lost, n, p, sigmas=4.5):
    return n > 0 and abs(lost / n - p) <= sigmas * math.sqrt(p * (1 - p) / n)


def parameters(fox, name=None):
    """{name: value} of every parameterValues message the client received (later ones win)."""
    values = {}
    for pv in fox.get("parameter_values", []):
        for p in pv.get("parameters", []):
            values[p.get("name")] = p.get("value")
    return values if name is None else values.get(name)


def control_link(status):
    links = [link for link in status.get("links", []) if link.get("sensor_id") == -1]
    return links[0] if len(links) == 1 else {}


def mcap_arrivals(path):
    """{k: input_arrived} of the truths @mcap/core reads from an MCAP file."""
    m = node("mcap_read.mjs", path, timeout=60)
    check(m.get("problems") == [] and m.get("complete") is True,
          "%s: complete, read without problems (%s)" % (os.path.basename(path), m.get("problems")))
    return {t["k"]: t["input_arrived"] for t in m.get("truths", [])}


def compare_nu(what, nu_a, nu_b, exempt, least):
    """nu_a and nu_b ({k: 0/1}) equal at every common period outside `exempt`."""
    common = sorted(set(nu_a) & set(nu_b))
    differ = [(k, nu_a[k], nu_b[k]) for k in common if nu_a[k] != nu_b[k] and k not in exempt]
    check(len(common) >= least and not differ, "%s: nu equal in %d common periods %s..%s (%d differ: %s; %d left out "
          "as late inputs)" % (what, len(common), common[0] if common else None, common[-1] if common else None,
                               len(differ), differ[:8], len(exempt & set(common))))
    return common


# ---- live: the dashboard's Foxglove parameters, then netkf ctl, recorded to CSV and MCAP
live_dir = os.path.join(out, "live")
os.makedirs(live_dir)
a_mcap = os.path.join(live_dir, "a.mcap")
url = "ws://127.0.0.1:%d/" % PORT
with Launch(scenario_path, 90, live_dir, extra=["--log-level", "debug"]) as live:
    check(wait_for(lambda: "dashboard: http://127.0.0.1:%d/" % PORT in live.output(), 30),
          "the launch serves the dashboard")
    check(wait_for(lambda: last_period(live.record) >= 0, 60), "the live run records periods")
    rec_a = attach(a_mcap)
    wait_for(lambda: last_period(live.record) >= SEGMENT - 50, 60)
    before = node("foxglove_client.mjs", "--url", url, "--seconds", 1, "--get")
    got = parameters(before)
    check(got.get("link.control.model") == "bernoulli" and got.get("link.control.loss") == LOSS_0,
          "getParameters: link.control.model bernoulli, link.control.loss %g (%s)"
          % (LOSS_0, {k: v for k, v in got.items() if k.startswith("link.control.")}))
    check(got.get("link.1.loss") == 0.1, "getParameters: the sensor's link.1.loss too (%s)" % got.get("link.1.loss"))
    fox = node("foxglove_client.mjs", "--url", url, "--seconds", 1.5, "--set-after", 0.2,
               "--set", "link.control.loss=%g" % LOSS_FOX)
    set_at = last_period(live.record)
    replies = [p for pv in fox.get("parameter_values", []) for p in pv.get("parameters", [])
               if p.get("name") == "link.control.loss"]
    check(any(p.get("value") == LOSS_FOX for p in replies),
          "setParameters link.control.loss=%g answered with the new value: %s" % (LOSS_FOX, replies))
    check(not [s for s in fox.get("statuses", []) if s.get("level", 0) >= 2],
          "no error status from the server: %s" % fox.get("statuses"))
    st = netkf("ctl", "status", "--json")
    link = control_link(json.loads(st.stdout)) if st.returncode == 0 else {}
    check(link.get("model") == "bernoulli" and link.get("loss") == LOSS_FOX and link.get("stationary_loss") == LOSS_FOX,
          "ctl status --json: the control link (sensor_id -1) is bernoulli loss %g (%s)"
          % (LOSS_FOX, {k: link.get(k) for k in ("sensor_id", "model", "loss", "stationary_loss")}))
    after = node("foxglove_client.mjs", "--url", url, "--seconds", 1, "--get")
    check(parameters(after, "link.control.loss") == LOSS_FOX,
          "a later getParameters: link.control.loss %s" % parameters(after, "link.control.loss"))
    wait_for(lambda: last_period(live.record) >= set_at + SEGMENT, 60)
    r = netkf("ctl", "set-link", "control", "--bernoulli", LOSS_CTL, "--timeout", 10)
    check(r.returncode == 0, "netkf ctl set-link control --bernoulli %g applied (rc=%d)" % (LOSS_CTL, r.returncode))
    ctl_at = last_period(live.record)
    check(wait_for(lambda: last_period(live.record) >= ctl_at + SEGMENT, 60),
          "the live run went on %d periods after the ctl change" % SEGMENT)
    rc = live.interrupt()
    detach(rec_a, "a.mcap")
    log_a = live.output()
check(rc == 0, "the live launch exits 0 after Ctrl-C (rc=%s)" % rc)
rows_a = read_periods(live.record, 1, truth_only=True)
nu_a = {row["k"]: row["nu"] for row in rows_a}
check(rows_a and all(v in (0, 1) for v in nu_a.values()), "a.csv has the nu column (%d rows)" % len(rows_a))
late_a = late_rows(log_a)
print("live: %d periods, inputs late at their step in rows %s" % (len(rows_a), sorted(late_a)), flush=True)

# ---- the journal: both changes of the control link, with the periods they applied from
journal = live.record + ".events.yaml"
events = (yaml.safe_load(open(journal)) or {}).get("events", []) if os.path.exists(journal) else []
check([(e.get("link"), e.get("set", {}).get("model"), e.get("set", {}).get("loss")) for e in events] ==
      [("control", "bernoulli", LOSS_FOX), ("control", "bernoulli", LOSS_CTL)],
      "the journal holds the dashboard's and ctl's changes of link control, in order (%s)" % events)
k_fox, k_ctl = (events[0]["at_period"], events[1]["at_period"]) if len(events) == 2 else (None, None)
if k_fox is not None:
    # The change applies from input u_K: row K + 1's nu is the first it decided.
    check(0 < k_fox < k_ctl and k_fox <= set_at + 100, "the changes applied from periods %d and %d" % (k_fox, k_ctl))
    for lo, hi, p, what in ((1, k_fox, LOSS_0, "before the dashboard's change"),
                            (k_fox + 1, k_ctl, LOSS_FOX, "after the dashboard's change"),
                            (k_ctl + 1, 10 ** 9, LOSS_CTL, "after ctl's change")):
        seg = [v for k, v in nu_a.items() if lo <= k <= hi]
        lost = seg.count(0)
        check(len(seg) >= SEGMENT - 50 and binomial_ok(lost, len(seg), p),
              "%s (rows %d..%d): %d of %d inputs lost (%.3f), loss %g within 4.5 binomial sigma (±%.3f)"
              % (what, lo, min(hi, max(nu_a)), lost, len(seg), lost / max(len(seg), 1), p,
                 4.5 * math.sqrt(p * (1 - p) / max(len(seg), 1))))

# ---- replay: the journal as --events, same scenario and seed; the launch records MCAP
replay_dir = os.path.join(out, "replay")
os.makedirs(replay_dir)
b_mcap = os.path.join(replay_dir, "b.mcap")
b_csv = os.path.join(replay_dir, "b.csv")
last_a = max(nu_a) if nu_a else 0
with Launch(scenario_path, 90, replay_dir, record=False,
            extra=["--record", b_mcap, "--events", journal, "--dashboard", "off", "--log-level", "debug"]) as replay:
    check(wait_for(lambda: re.search(r"^period \d+ ", replay.output(), re.M) is not None, 60), "the replay runs")
    rec_b = attach(b_csv)
    check(wait_for(lambda: last_period(b_csv) >= last_a, 90),
          "the replay reaches the live run's last period %d" % last_a)
    rc = replay.interrupt()
    detach(rec_b, "b.csv")
    log_b = replay.output()
check(rc == 0, "the replay exits 0 after Ctrl-C (rc=%s)" % rc)
rows_b = read_periods(b_csv, 1, truth_only=True)
nu_b = {row["k"]: row["nu"] for row in rows_b}
late_b = late_rows(log_b)
print("replay: %d periods from %s, inputs late at their step in rows %s"
      % (len(rows_b), rows_b[0]["k"] if rows_b else None, sorted(late_b)), flush=True)
exempt = late_a | late_b
common = compare_nu("live a.csv vs replay b.csv", nu_a, nu_b, exempt, last_a - 150)
if k_fox is not None and common:
    check(common[0] < k_fox and common[-1] > k_ctl + SEGMENT - 50,
          "the common periods span both changes (%d, %d)" % (k_fox, k_ctl))

# ---- MCAP: the truth's input_arrived (@mcap/core) is the CSV's nu of the same run
arrived_b = mcap_arrivals(b_mcap)
check(arrived_b and all(isinstance(v, bool) for v in arrived_b.values()),
      "b.mcap (launch --record): every truth carries input_arrived, a boolean")
arrived_b = {k: int(v) for k, v in arrived_b.items() if isinstance(v, bool)}
check(min(arrived_b, default=None) == 0, "b.mcap starts at period 0")
compare_nu("replay b.mcap (launch) vs b.csv (attached)", arrived_b, nu_b, set(), last_a - 150)
# The launch's MCAP holds the replay from period 0: the live CSV over every period.
compare_nu("live a.csv vs replay b.mcap", nu_a, arrived_b, exempt, last_a)
arrived_a = {k: int(v) for k, v in mcap_arrivals(a_mcap).items() if isinstance(v, bool)}
compare_nu("live a.mcap (attached) vs a.csv (launch)", arrived_a, nu_a, set(), last_a - 150)

# The Python reader: the MCAP and the CSV of one run give the same nu, truth and inputs.
for what, mcap_path, csv_path in (("live", a_mcap, live.record), ("replay", b_mcap, b_csv)):
    try:
        fm, fc = read_mcap_periods(mcap_path), read_period_frame(csv_path)
    except ValueError as e:
        check(False, "%s: the Python reader reads both recordings (%s)" % (what, e))
        continue
    check(fm.attrs.get("actuation_link") is True and list(fm.columns) == list(fc.columns) and fc.columns[-1] == "nu",
          "%s: the Python reader's MCAP frame has the CSV's columns, nu last (%s)" % (what, list(fm.columns)))
    if "nu" not in fm.columns:
        continue
    ks = sorted(set(fm["k"]) & set(fc["k"]))
    cols = ["k", "t", "x0", "u0", "nu"]
    a = fm[fm["k"].isin(ks)][cols].reset_index(drop=True)
    b = fc[fc["k"].isin(ks)][cols].reset_index(drop=True)
    check(len(ks) >= last_a - 150 and a.equals(b), "%s: python reader, MCAP vs CSV: k, t, x0, u0 and nu equal in %d "
          "common periods (%d rows differ)" % (what, len(ks), int((a != b).any(axis=1).sum()) if a.shape == b.shape
                                                else -1))
    check(fm["nu"].dtype == bool and fc["nu"].dtype == bool, "%s: nu is bool in both frames" % what)

finish()
