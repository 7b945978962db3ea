"""`netkf sweep --offline` (docs/experiments.md, "Sweeps") on the shipped default scenario over
link 2's loss x 3 seeds, against expectations made here:

- the four files: runs.csv with the exact header (point, seed, the key, status, every summary
  quantity of the launch's --summary) and one ok row per (point, seed); points.csv with one row
  per point whose mean/se/min/max are recomputed here from runs.csv; sweep.yaml with the
  scenario's sha256 (hashlib) and the vary list; report.html self-contained (uPlot inlined, no
  http(s) reference) holding the data.
- link 2's observed loss over the seeds agrees with the loss of its point (binomial, 5 se).
- the theory columns equal `netkf analyze --json` on the point's scenario, made here by editing
  the file's text (not the sweep's key path): stable, Tr S̄, Tr V̄ and 1 - the Markov criterion.
- report.html in headless Chromium (network refused): the margin plot and one plot per measured
  quantity, no script error, no request.
- reruns are identical; --check on the points' means fails exactly at the points whose mean
  fails it (exit 1, stderr names them); a bad value is exit 2 naming the point.
No DDS is started (the harness's network namespace is kept for uniformity).
"""
import csv
import hashlib
import json
import math
import os
import re

from e2e_common import REPO, check, finish, netkf, node, require_netns, workdir

require_netns()
scenario = os.path.join(REPO, "deploy", "scenarios", "default.yaml")
out = workdir("sweep-offline")
losses = ["0.1", "0.5", "0.9"]
seeds = 3
periods = 2000
sweep_dir = os.path.join(out, "sweep")
r = netkf("sweep", scenario, "--vary", "sensors.2.link.loss=" + ",".join(losses), "--seeds", seeds,
          "--periods", periods, "--offline", "--out", sweep_dir, timeout=120)
check(r.returncode == 0, "the sweep exits 0 (rc=%d)" % r.returncode)
for name in ("runs.csv", "points.csv", "sweep.yaml", "report.html"):
    check(os.path.exists(os.path.join(sweep_dir, name)), "it wrote %s" % name)

# ---- runs.csv
run_q = ["periods", "rms_error", "rms_error_final", "mean_trace_P", "mean_trace_P_pred", "late_fraction", "fused_fraction",
         "periods_diverging", "pipeline_latency_p50_ms", "pipeline_latency_p99_ms", "cost"]
link_q = ["samples", "delivered", "dropped", "observed_loss", "observed_arrival_rate_since_change",
          "observed_arrival_rate_window", "observed_window_samples", "late", "fused"]
quantities = run_q + ["link.%d.%s" % (i, q) for i in (1, 2, 3) for q in link_q]
with open(os.path.join(sweep_dir, "runs.csv")) as f:
    rows = list(csv.reader(f))
header = ["point", "seed", "sensors.2.link.loss", "status"] + quantities
check(rows[0] == header, "runs.csv header is point,seed,<key>,status,<the summary's quantities>")
runs = [dict(zip(rows[0], row)) for row in rows[1:]]
expected = {(str(p), str(s)) for p in range(len(losses)) for s in range(1, seeds + 1)}
check({(x["point"], x["seed"]) for x in runs} == expected and len(runs) == len(expected),
      "one row per point x seed (%d rows)" % len(runs))
check(all(x["status"] == "ok" for x in runs), "every run ok")
check(all(x["sensors.2.link.loss"] == losses[int(x["point"])] for x in runs), "each row carries its point's loss")
check(all(x["periods"] == str(periods) for x in runs), "each run has %d periods" % periods)
check(all(x["pipeline_latency_p50_ms"] == "" for x in runs), "latency is empty offline (nothing to measure)")
for p, loss in enumerate(losses):
    dropped = sum(int(x["link.2.dropped"]) for x in runs if x["point"] == str(p))
    n = seeds * periods
    se = math.sqrt(float(loss) * (1 - float(loss)) / n)
    check(abs(dropped / n - float(loss)) < 5 * se, "point %d: link 2 dropped %.4f, loss %s (5 se %.4f)" %
          (p, dropped / n, loss, 5 * se))

# ---- points.csv: the stats recomputed from runs.csv
with open(os.path.join(sweep_dir, "points.csv")) as f:
    points = list(csv.DictReader(f))
check(len(points) == len(losses), "points.csv has one row per point")


def stats(values):
    v = [float(x) for x in values if x != ""]
    if not v:
        return None
    mean = sum(v) / len(v)
    se = math.sqrt(sum((x - mean) ** 2 for x in v) / (len(v) - 1) / len(v)) if len(v) > 1 else None
    return mean, se, min(v), max(v)


def close(a, b):
    return (a is None and b == "") or (a is not None and b != "" and abs(a - float(b)) <= 1e-12 * max(1.0, abs(a)))


agree = True
for p in points:
    for q in quantities:
        s = stats([x[q] for x in runs if x["point"] == p["point"]])
        got = [p[q + "_mean"], p[q + "_se"], p[q + "_min"], p[q + "_max"]]
        want = [None] * 4 if s is None else list(s)
        if not all(close(w, g) for w, g in zip(want, got)):
            agree = False
            print("  point %s %s: want %s got %s" % (p["point"], q, want, got))
check(agree, "points.csv mean, se, min, max equal a recomputation from runs.csv")
check(all(p["seeds"] == str(seeds) for p in points), "each point counts %d seeds" % seeds)

# ---- theory: netkf analyze on the point's scenario, made here by editing the text
with open(scenario) as f:
    text = f.read()
for p, loss in zip(points, losses):
    edited, n = re.subn(r"(- id: 2\n(?:.*\n){2}\s*link: \{ model: bernoulli, loss: )0\.3( \})", r"\g<1>%s\2" % loss, text)
    path = os.path.join(out, "point%s.yaml" % p["point"])
    with open(path, "w") as f:
        f.write(edited)
    a = netkf("analyze", path, "--json", timeout=60)
    j = json.loads(a.stdout)
    stable = {"yes": "true", "no": "false", "unknown": ""}[j["stable"]]
    crit = j["markov_criterion"]
    lower, upper = j["expected_covariance"]["lower_trace"], j["expected_covariance"]["upper_trace"]
    check(n == 1 and p["theory_stable"] == stable, "point %s: theory_stable %s = analyze's %s" % (p["point"], p["theory_stable"], j["stable"]))
    check(close(None if crit is None else 1 - crit, p["theory_critical_margin"]),
          "point %s: critical margin %s = 1 - analyze's Markov criterion %s" % (p["point"], p["theory_critical_margin"], crit))
    check(close(lower, p["theory_trace_S_bar"]) and close(upper, p["theory_trace_V_bar"]),
          "point %s: Tr S, Tr V (%s, %s) = analyze's (%s, %s)" % (p["point"], p["theory_trace_S_bar"],
                                                                  p["theory_trace_V_bar"], lower, upper))
    # Link 3 is Gilbert-Elliott: no i.i.d. bound, the sampled E[Tr P_k|k-1] instead (stable points).
    sampled = j["expected_covariance"]["sampled_trace"]
    check((sampled is not None) == (stable == "true") and close(sampled, p["theory_trace_P_sampled"]) and
          close(j["expected_covariance"]["sampled_trace_standard_error"], p["theory_trace_P_sampled_se"]),
          "point %s: sampled E[Tr P] %s +/- %s = analyze's %s" % (p["point"], p["theory_trace_P_sampled"],
                                                                  p["theory_trace_P_sampled_se"], sampled))
    if sampled is not None:
        # The offline filter (core's Kalman filter, not the recursion analyze samples) over the
        # seeds' own loss sequences: its mean Tr P_k|k-1 agrees with the estimate within the
        # two standard errors (5 of them) and 5 %.
        got, se = float(p["mean_trace_P_pred_mean"]), float(p["mean_trace_P_pred_se"] or 0)
        tol = 5 * math.hypot(se, float(p["theory_trace_P_sampled_se"])) + 0.05 * sampled
        check(abs(got - sampled) <= tol, "point %s: measured mean Tr P_k|k-1 %.5g (se %.2g) agrees with the sampled "
              "theory %.5g (tolerance %.3g)" % (p["point"], got, se, sampled, tol))

# ---- Tr S̄ and Tr V̄ where they apply (every link Bernoulli): a second sweep over all links' loss
b3 = os.path.join(REPO, "tests", "e2e", "data", "bernoulli3.yaml")
b3_dir = os.path.join(out, "b3")
r = netkf("sweep", b3, "--vary", "sensors.*.link.loss=0.2:0.4:2", "--periods", 50, "--out", b3_dir, timeout=120)
with open(os.path.join(b3_dir, "points.csv")) as f:
    b3_points = list(csv.DictReader(f))
with open(b3) as f:
    b3_text = f.read()
for p in b3_points:
    loss = p["sensors.*.link.loss"]
    path = os.path.join(out, "b3-%s.yaml" % p["point"])
    with open(path, "w") as f:
        f.write(b3_text.replace("loss: 0.3 }", "loss: %s }" % loss))
    j = json.loads(netkf("analyze", path, "--json", timeout=60).stdout)
    lower, upper = j["expected_covariance"]["lower_trace"], j["expected_covariance"]["upper_trace"]
    check(lower is not None and close(lower, p["theory_trace_S_bar"]) and close(upper, p["theory_trace_V_bar"]),
          "all-Bernoulli point loss %s: Tr S, Tr V (%s, %s) = analyze's (%s, %s)" %
          (loss, p["theory_trace_S_bar"], p["theory_trace_V_bar"], lower, upper))

# ---- sweep.yaml, report.html
with open(os.path.join(sweep_dir, "sweep.yaml")) as f:
    meta = f.read()
with open(scenario, "rb") as f:
    sha = hashlib.sha256(f.read()).hexdigest()
check("sha256: " + sha in meta, "sweep.yaml carries the scenario's sha256")
check("key: sensors.2.link.loss" in meta and "values: [0.1, 0.5, 0.9]" in meta and "mode: offline" in meta,
      "sweep.yaml carries the vary list and the mode")
with open(os.path.join(sweep_dir, "report.html")) as f:
    html = f.read()
check("uPlot" in html and not re.search(r"(src|href)\s*=\s*[\"']?https?:", html), "report.html inlines uPlot, loads nothing")
data = json.loads(re.search(r'<script type="application/json" id="sweep-data">(.*?)</script>', html, re.S).group(1))
check(data["keys"] == ["sensors.2.link.loss"] and len(data["points"]) == 3, "report.html holds the sweep's data")
# In a browser with the network refused: the page draws its plots, without a script error or a request.
page = node("report_browser.mjs", "--report", os.path.join(sweep_dir, "report.html"), "--screenshot",
            os.path.join(out, "report.png"))
measured = [q for q in quantities if any(x[q] != "" for x in runs)]
check(page.get("errors") == [] and page.get("requests") == [], "report.html: no script error, no request (%s)" % page)
check(page.get("titles", [])[1:] == measured and page["titles"][0].startswith("theory: critical margin"),
      "report.html: the theory's margin, then one plot per measured quantity (%d plots)" % page.get("plots", 0))

# ---- a rerun is identical
again = os.path.join(out, "again")
netkf("sweep", scenario, "--vary", "sensors.2.link.loss=" + ",".join(losses), "--seeds", seeds,
      "--periods", periods, "--out", again, timeout=120)
with open(os.path.join(sweep_dir, "runs.csv")) as a, open(os.path.join(again, "runs.csv")) as b:
    check(a.read() == b.read(), "a rerun writes the same runs.csv")

# ---- --check on every point's mean
threshold = 0.7
failing = [p["point"] for p in points if not float(p["fused_fraction_mean"]) > threshold]
c = netkf("sweep", scenario, "--vary", "sensors.2.link.loss=" + ",".join(losses), "--seeds", seeds,
          "--periods", periods, "--out", os.path.join(out, "checked"), "--check", "fused_fraction>%g" % threshold)
named = re.findall(r"FAILED at point (\d+)", c.stderr)
check(failing and len(failing) < len(points), "the check splits the points (failing: %s)" % failing)
check(c.returncode == 1 and named == failing, "--check: exit 1 naming exactly points %s (rc=%d, named %s)" %
      (failing, c.returncode, named))
bad = netkf("sweep", scenario, "--vary", "sensors.2.link.loss=0.2,1.5", "--out", os.path.join(out, "bad"))
check(bad.returncode == 2 and "point 1: sensors.2.link.loss=1.5" in bad.stderr, "a refused value: exit 2 naming the point")
finish()
