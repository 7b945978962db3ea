"""The actuation link (plant.control.link): the estimator's inputs reach the plant through the
channel emulator, which loses them on the link's seeded stream. Independent expectations:
- the scalar closed form of the zeroing loop's mean-square stability (Schenato et al. 2007):
  ν̄ (a - bℓ)² + (1 - ν̄) a² < 1, i.e. ν_c = (a² - 1) / (a² - (a - bℓ)²), against `netkf analyze`;
- per period, the plant's applied input against what the actuator must do: the estimator's
  u = -ℓ x̂ of the period before when it arrived (ν = 1), zero or the previous input when not;
- the loss the channel drew: binomial tolerance around the configured loss, before and after a
  live `netkf ctl set-link control` (journaled with its period), and the same decisions on the
  same seed whatever the actuator does (zero vs hold, period by period);
- below ν_c the loop diverges and the launch exits 1; above it stays bounded;
- the long-run cost x² + u² of acknowledged (TCP-like) and unacknowledged (UDP-like) inputs with
  hold against a NumPy Monte Carlo of the same loop (plant, Kalman filter, link) written here."""
import json
import math
import os

import numpy as np
import yaml

from e2e_common import (DATA, Launch, check, finish, last_period, netkf, node, read_periods, require_netns, wait_for,
                        workdir)

require_netns()
out = workdir("actuation")
base = yaml.safe_load(open(os.path.join(DATA, "actuation.yaml")))
a, b, ell, q, r = 1.3, 1.0, 0.6, 0.5, 0.2
sensor_arrival = 0.9


def variant(name, loss, on_loss="zero", acknowledged=True, state_bound=None):
    s = json.loads(json.dumps(base))
    if state_bound:
        s["plant"]["state_bound"] = state_bound
    s["name"] = "e2e-actuation-" + name
    s["plant"]["control"]["link"] = {"model": "bernoulli", "loss": loss}
    s["plant"]["control"]["on_loss"] = on_loss
    s["plant"]["control"]["acknowledged"] = acknowledged
    path = os.path.join(out, name + ".yaml")
    with open(path, "w") as f:
        yaml.safe_dump(s, f)
    return path


def run(name, scenario, duration, extra=(), during=None):
    d = os.path.join(out, name)
    os.makedirs(d)
    summary = os.path.join(d, "summary.json")
    with Launch(scenario, duration, d, extra=["--summary", summary, "--allow-divergence"] + list(extra)
                if name != "below" else ["--summary", summary] + list(extra)) as launch:
        if during:
            during(launch)
        rc = launch.wait(duration + 60)
    rows = read_periods(launch.record, 1, truth_only=True)
    with open(summary) as f:
        s = json.load(f)
    return rc, rows, s, launch


def binomial_ok(lost, n, p, sigmas=4.0):
    return n > 0 and abs(lost / n - p) <= sigmas * math.sqrt(p * (1 - p) / n) + 1.0 / n


# ---- theory: netkf analyze against the closed form
critical = (a * a - 1) / (a * a - (a - b * ell) ** 2)
for loss, expect in ((0.15, "yes"), (0.7, "no")):
    res = netkf("analyze", variant("analyze-%g" % loss, loss), "--json", timeout=120)
    check(res.returncode == 0, "netkf analyze runs (rc=%s): %s" % (res.returncode, res.stderr[-300:]))
    if res.returncode == 0:
        act = json.loads(res.stdout).get("actuation") or {}
        nu = 1 - loss
        radius = nu * (a - b * ell) ** 2 + (1 - nu) * a * a
        check(abs(act.get("mss_radius", -1) - radius) < 1e-9,
              "loss %g: mss_radius %s is the closed form %.6f" % (loss, act.get("mss_radius"), radius))
        check(act.get("critical_rate") is not None and abs(act["critical_rate"] - critical) < 1e-6,
              "loss %g: critical rate %s is the closed form %.6f" % (loss, act.get("critical_rate"), critical))
        check(act.get("stable") == expect, "loss %g: the actuation side is stable=%s (%s)" % (loss, expect, act.get("stable")))

# ---- A: zero on loss, acknowledged; a live change of the control link at about period 150
change_at = {}


def change(launch):
    if wait_for(lambda: last_period(launch.record) >= 150, 60):
        res = netkf("ctl", "set-link", "control", "--bernoulli", "0.5", timeout=30)
        check(res.returncode == 0, "netkf ctl set-link control applies (rc=%s): %s" % (res.returncode,
                                                                                     (res.stdout + res.stderr)[-300:]))


rc_a, rows_a, sum_a, launch_a = run("zero", variant("zero", 0.15), 12, during=change)
check(rc_a == 0, "zero on loss, ν̄ = 0.85 > ν_c: the launch exits 0 (rc=%s)" % rc_a)
check(len(rows_a) >= 300, "periods recorded (%d)" % len(rows_a))
check(all(row["nu"] is not None for row in rows_a), "the recording has the nu column")
events = (yaml.safe_load(open(launch_a.record + ".events.yaml")) or {}).get("events", [])
control_events = [e for e in events if e.get("link") == "control"]
check(len(control_events) == 1 and control_events[0]["set"].get("loss") == 0.5,
      "the journal has the control link's change (%s)" % events)
k_change = control_events[0]["at_period"] if control_events else None
by_k = {row["k"]: row for row in rows_a}
bad = []
for row in rows_a:
    prev = by_k.get(row["k"] - 1)
    if row["k"] == 0 or prev is None or prev["xhat"] is None:
        continue
    sent = -ell * prev["xhat"][0]
    want = sent if row["nu"] == 1 else 0.0
    if row["u"][0] != want:
        bad.append((row["k"], row["nu"], row["u"][0], want))
check(not bad, "zero: every applied input is -0.6 x̂ of the period before when it arrived, else 0 (%d off: %s)"
      % (len(bad), bad[:5]))
if k_change is not None:
    before = [row["nu"] for row in rows_a if 1 <= row["k"] < k_change]
    after = [row["nu"] for row in rows_a if row["k"] > k_change + 1]
    check(binomial_ok(before.count(0), len(before), 0.15),
          "before the change %d of %d inputs lost: loss 0.15 within binomial tolerance" % (before.count(0), len(before)))
    check(binomial_ok(after.count(0), len(after), 0.5),
          "after the change %d of %d inputs lost: loss 0.5 within binomial tolerance" % (after.count(0), len(after)))
control = sum_a.get("link", {}).get("control", {})
arrived = sum(1 for row in rows_a if row["k"] >= 1 and row["nu"] == 1)
check(control.get("delivered") is not None and arrived <= control["delivered"] <= arrived + 5,
      "the channel's count of delivered inputs (%s) is what reached the plant (%d)" % (control.get("delivered"), arrived))

cost_csv = float(np.mean([row["x"][0] ** 2 + row["u"][0] ** 2 for row in rows_a]))
check(sum_a.get("cost") is not None and abs(sum_a["cost"] - cost_csv) <= 1e-9 * cost_csv,
      "the summary's cost %s is the recording's mean x² + u² %.6f (identity weights for a given gain)"
      % (sum_a.get("cost"), cost_csv))

# `netkf trace extract --link control`: the trace of the inputs' fates, input k in row k + 1's nu
trace_path = os.path.join(out, "control-trace.csv")
res = netkf("trace", "extract", launch_a.record, "--link", "control", "-o", trace_path)
check(res.returncode == 0, "netkf trace extract --link control runs (rc=%s): %s" % (res.returncode, res.stderr[-300:]))
if res.returncode == 0:
    trace_rows = [line.split(",") for line in open(trace_path) if line.strip() and not line.startswith(("#", "k"))]
    trace = {int(c[0]): int(c[1]) for c in trace_rows}
    expected = {row["k"] - 1: row["nu"] for row in rows_a if row["k"] >= 1}
    check(trace == expected, "the control link's trace is the recording's nu shifted by one period (%d periods, %d "
          "differ)" % (len(expected), sum(1 for k in expected if trace.get(k) != expected[k])))

# ---- B: hold on loss, same seed: the same decisions, the previous input applied on a loss
rc_b, rows_b, sum_b, _ = run("hold", variant("hold", 0.15, "hold"), 8)
check(rc_b == 0, "hold on loss: the launch exits 0 (rc=%s)" % rc_b)
by_kb = {row["k"]: row for row in rows_b}
bad = []
for row in rows_b:
    prev = by_kb.get(row["k"] - 1)
    if row["k"] <= 1 or prev is None or prev["xhat"] is None:
        continue
    want = -ell * prev["xhat"][0] if row["nu"] == 1 else prev["u"][0]
    if row["u"][0] != want:
        bad.append((row["k"], row["nu"], row["u"][0], want))
check(not bad, "hold: every applied input is -0.6 x̂ of the period before when it arrived, else the previous one "
      "(%d off: %s)" % (len(bad), bad[:5]))
common = [k for k in by_kb if k in by_k and 1 <= k < (k_change if k_change is not None else 10 ** 9)]
same = sum(1 for k in common if by_kb[k]["nu"] == by_k[k]["nu"])
check(len(common) >= 100 and same >= 0.97 * len(common),
      "same seed, zero vs hold: the same inputs were lost in %d of %d periods" % (same, len(common)))

# ---- C: below the critical rate the loop diverges, and the run fails
rc_c, rows_c, _, launch_c = run("below", variant("below", 0.7), 30)
check(rc_c == 1, "ν̄ = 0.3 < ν_c = %.3f: the loop diverged and the launch exits 1 (rc=%s)" % (critical, rc_c))
check("diverged" in launch_c.output(), "the launch says the loop diverged")
xmax = max((abs(row["x"][0]) for row in rows_c), default=0.0)
check(xmax > 1e5, "the state left its band (max |x| = %.3g)" % xmax)


# ---- D: the cost of TCP-like and UDP-like inputs with hold, live and in a NumPy Monte Carlo
def monte_carlo_cost(nu, acknowledged, runs=4000, steps=300, burn=60, seed=5):
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1.0, runs)
    xh, P = np.zeros(runs), np.ones(runs)
    held = np.zeros(runs)
    m, s2 = np.zeros(runs), np.zeros(runs)  # UDP: mean and second moment of the applied input
    cost = []
    for k in range(steps):
        got = rng.random(runs) < sensor_arrival
        y = x + rng.normal(0.0, math.sqrt(r), runs)
        K = np.where(got, P / (P + r), 0.0)
        xh = xh + K * (y - xh)
        P = (1 - K) * P
        u = -ell * xh
        arrived = rng.random(runs) < nu
        applied = np.where(arrived, u, held)
        held = applied
        x_next = a * x + b * applied + rng.normal(0.0, math.sqrt(q), runs)
        if acknowledged:
            xh, P = a * xh + b * applied, a * a * P + q
        else:
            m, s2 = nu * u + (1 - nu) * m, nu * u * u + (1 - nu) * s2
            xh, P = a * xh + b * m, a * a * P + q + b * b * (s2 - m * m)
        x = x_next
        if k >= burn:
            cost.append(np.mean(x * x + applied * applied))  # row k+1: x_{k+1}, u^a_k
    return float(np.mean(cost))


for name, acknowledged in (("tcp", True), ("udp", False)):
    rc, rows, _, _ = run(name, variant(name, 0.3, "hold", acknowledged), 12)
    check(rc == 0, "%s-like hold at ν̄ = 0.7: the launch exits 0 (rc=%s)" % (name.upper(), rc))
    steady = [row for row in rows if row["k"] >= 60]
    live = float(np.mean([row["x"][0] ** 2 + row["u"][0] ** 2 for row in steady])) if steady else float("nan")
    mc = monte_carlo_cost(0.7, acknowledged)
    print("%s: live mean cost %.4f over %d periods, Monte Carlo %.4f" % (name, live, len(steady), mc), flush=True)
    check(abs(live - mc) <= 0.35 * mc, "%s-like: live mean cost %.4f within 35%% of the Monte Carlo %.4f"
          % (name.upper(), live, mc))


# ---- E: the page: drag the control link's loss past ν_c on its card, the card's verdict turns
# and the loop leaves its band (the launch then fails: no --allow-divergence)
# A bound far away: the page is read (4 s after the change) before the state reaches it, about
# 300 periods (6 s) after the change at ν̄ = 0.25 (log |x| grows by ~0.1 a period).
page_scenario = variant("page", 0.15, state_bound=1.0e15)
d = os.path.join(out, "page")
os.makedirs(d)
with Launch(page_scenario, 40, d) as launch:
    ready = wait_for(lambda: last_period(launch.record) >= 100, 60)
    check(ready, "the run reached period 100 before the page was opened")
    shot = os.path.join(d, "actuation-page.png")
    page = node("dashboard_browser.mjs", "--url", "http://127.0.0.1:8470/", "--screenshot", shot,
                "--link", "control", "--loss", "0.75", "--seconds", "4", "--timeout", "60", timeout=90)
    rc_page = launch.wait(60)
rows_page = read_periods(launch.record, 1, truth_only=True)
check(not page.get("console_errors") and not page.get("page_errors"),
      "no console or page errors: %s %s" % (page.get("console_errors"), page.get("page_errors")))
before, after = page.get("actuation_theory_before") or {}, page.get("actuation_theory_after") or {}
check(before.get("stable") == "yes" and ("%.3f" % critical) in before.get("text", ""),
      "the control link's card shows the loop stable and ν_c = %.3f beside the rates: %s" % (critical, before))
check(page.get("applied") is True, "the page's change of the control link was applied (event log: %s)"
      % (page.get("event_log") or [])[:3])
check(after.get("stable") == "no", "after the change the card says the loop is not stable: %s" % after)
# The header's running cost against the recording: the mean of x² + u² (identity weights for a
# given gain) over the same first periods, computed here from the CSV.
shown = page.get("running_cost") or {}
costed = [row["x"][0] ** 2 + row["u"][0] ** 2 for row in rows_page if row["k"] < int(shown.get("periods") or 0)]
expected_cost = float(np.mean(costed)) if costed else float("nan")
check(len(costed) == int(shown.get("periods") or -1) and len(costed) >= 100 and
      abs(shown.get("value", float("nan")) - expected_cost) <= 1e-9 * expected_cost,
      "the page's running cost %s over %s periods is the recording's mean x² + u² %.6f over them"
      % (shown.get("value"), shown.get("periods"), expected_cost))
check(rc_page == 1 and "diverged" in launch.output(),
      "the loop left its band: the launch exits 1 and says it diverged (rc=%s)" % rc_page)
early = max((abs(row["x"][0]) for row in rows_page if row["k"] < 100), default=0.0)
late = max((abs(row["x"][0]) for row in rows_page), default=0.0)
check(late > 1000 * max(early, 1.0), "max |x| %.3g after the change, %.3g before period 100" % (late, early))

finish()
