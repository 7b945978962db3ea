"""Gilbert-Elliott link (p=0.1, r=0.3, loss_good=0, loss_bad=1): observed loss and mean
burst length within tolerance of theory: stationary loss p/(p+r) = 0.25, mean burst
1/r = 3.33 (docs/scenario-format.md, Gilbert-Elliott)."""
import json
import math
import os
import time

from e2e_common import DATA, Launch, check, finish, netkf, read_periods, read_samples, require_netns, workdir

P, R = 0.1, 0.3
LOSS = P / (P + R)
BURST = 1.0 / R
require_netns()
out = workdir("gilbert")
with Launch(os.path.join(DATA, "gilbert.yaml"), 90, out, samples=True) as run:
    time.sleep(16)
    st = netkf("ctl", "status", "--json", "--timeout", "20")
    rc = run.interrupt()
check(rc == 0, "launch exits 0 on Ctrl-C (rc=%s)" % rc)


def tolerances(n):
    # Loss: the chain's drops are correlated (lag-1 correlation rho = 1 - p - r), which
    # inflates the variance of the mean by (1 + rho)/(1 - rho). Bursts: geometric with
    # sd sqrt(1 - r)/r over about n*loss/burst bursts. 4.5 sigma each.
    rho = 1 - P - R
    tol_loss = 4.5 * math.sqrt(LOSS * (1 - LOSS) / n * (1 + rho) / (1 - rho))
    bursts = max(n * LOSS / BURST, 1)
    tol_burst = 4.5 * math.sqrt(1 - R) / R / math.sqrt(bursts)
    return tol_loss, tol_burst


check(st.returncode == 0, "ctl status --json works")
if st.returncode == 0:
    for l in json.loads(st.stdout)["links"]:
        tl, tb = tolerances(l["samples_in"])
        check(abs(l["observed_loss"] - LOSS) <= tl, "link %d (channel): observed loss %.4f within %.4f of %.4f"
              % (l["sensor_id"], l["observed_loss"], tl, LOSS))
        check(abs(l["mean_burst_length"] - BURST) <= tb, "link %d (channel): mean burst %.3f within %.3f of %.3f"
              % (l["sensor_id"], l["mean_burst_length"], tb, BURST))
        # The model the link's last <= 5000 samples show: the configured chain, p and r within
        # 4.5 binomial standard errors of transition frequencies over about n(1 - loss) and n loss samples.
        fit = l.get("recent_fit") or {}
        n = fit.get("samples", 0)
        tp, tr = (4.5 * math.sqrt(P * (1 - P) / max(n * (1 - LOSS), 1)), 4.5 * math.sqrt(R * (1 - R) / max(n * LOSS, 1)))
        check(fit.get("family") == "simple_gilbert" and n == min(l["samples_in"], 5000) and
              abs(fit["link"]["p"] - P) <= tp and abs(fit["link"]["r"] - R) <= tr and fit["aic_gain"] > 2,
              "link %d (channel): its last %d samples fit simple_gilbert p %s r %s (within %.3f, %.3f of %g, %g)"
              % (l["sensor_id"], n, fit.get("link", {}).get("p"), fit.get("link", {}).get("r"), tp, tr, P, R))

# Independently, from the delivered samples in the recording.
rows = read_periods(run.record, 1)
samples = read_samples(run.samples)
kmin, kmax = rows[0]["k"], rows[-1]["k"]
for sid in (1, 2):
    got = set(s["k"] for s in samples if s["sensor_id"] == sid)
    seq = [k not in got for k in range(kmin, kmax + 1)]  # True = dropped
    n = len(seq)
    loss = sum(seq) / n
    runs, cur = [], 0
    for d in seq:
        if d:
            cur += 1
        elif cur:
            runs.append(cur)
            cur = 0
    burst = sum(runs) / len(runs) if runs else 0.0
    tl, tb = tolerances(n)
    check(abs(loss - LOSS) <= tl, "sensor %d (recording): loss %.4f within %.4f of %.4f" % (sid, loss, tl, LOSS))
    check(abs(burst - BURST) <= tb, "sensor %d (recording): mean burst %.3f within %.3f of %.3f" % (sid, burst, tb, BURST))
finish()
