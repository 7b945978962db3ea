"""A hot-standby estimator (`netkf launch --standby`): two estimators fuse the same samples, the
plant and every reader take the primary's inputs and estimates (DDS exclusive ownership), and a
kill -9 of the primary at any moment hands the plant to the standby once the primary's
liveliness lease (5 periods) expires; the launch restarts the dead one as the new standby
(weaker, so it never takes the plant back). Three kills of whichever estimator is primary at that
moment, at random moments, on the unstable closed loop (A = 1.2: open loop it grows 1.2x a period).
Asserted against the recording: at each kill, at most twice the lease's periods go without an
applied input (the plant applied zero); |x| stays within a few times the undisturbed range; every
applied input is -L x̂ of the recorded estimate of the period before, where the recording has one
(the plant and the recording follow the same estimator); every period has an estimate; the run exits 0."""
import os
import random
import signal
import time

from e2e_common import (DATA, Launch, check, finish, inputs_missing, last_period, node_pids, primary_estimator,
                        read_periods, require_netns, wait_for, workdir)

require_netns()
domain = int(os.environ["NETKF_DOMAIN"])
GAIN, LEASE = 1.2, 5
rng = random.Random(int(os.environ.get("NETKF_TEST_SEED", "1")))
out = workdir("standby")
kills = []  # (period recorded at the kill, strength killed)
with Launch(os.path.join(DATA, "closed_loop.yaml"), 0, out, extra=["--standby", "--dashboard", "off"]) as run:
    check(wait_for(lambda: last_period(run.record) >= 150, 60), "the run reaches period 150")
    estimators = [n for n in node_pids(domain) if n.startswith("estimator_node@")]
    check(len(estimators) == 2, "two estimators run (%s)" % estimators)
    for i in range(3):
        time.sleep(rng.uniform(0.3, 1.5))
        primary = primary_estimator(domain)
        check(primary is not None, "kill %d: found the primary estimator" % (i + 1))
        if not primary:
            break
        kills.append((last_period(run.record), primary[1]))
        os.kill(primary[0], signal.SIGKILL)
        # The launch restarts it as the new standby: two estimators again.
        check(wait_for(lambda: len([n for n in node_pids(domain) if n.startswith("estimator_node@")]) == 2 and
                       primary_estimator(domain)[1] < primary[1], 30),
              "kill %d: the dead primary came back as the standby, the other one leads" % (i + 1))
        wait_for(lambda: last_period(run.record) >= kills[-1][0] + 150, 30)
    rc = run.interrupt(30)
    log = run.output()
check(rc == 0, "launch exits 0 (rc=%s)" % rc)
check(log.count("restarting estimator_node") == 3, "the launch restarted an estimator three times")
rows = read_periods(run.record, 1, m=1, truth_only=True)
ks = [r["k"] for r in rows]
check(bool(ks) and ks == list(range(len(ks))), "a row for every period from 0 (%d)" % len(ks))
# While the lease of a killed primary runs, readers take no one's estimates: those periods (and
# only those) have none.
unexplained = [r["k"] for r in rows[:-20] if r["xhat"] is None and
               not any(k - 10 <= r["k"] <= k + 4 * LEASE for k, _ in kills)]
check(not unexplained, "every period has an estimate but a few at each takeover (%d without: %s)"
      % (len(unexplained), unexplained[:10]))
by_k = {r["k"]: r for r in rows}
missing = set(inputs_missing(rows))
# The plant's input reader and the recording's estimate reader each decide on their own when the
# dead primary's lease ran out, so at a takeover the plant may apply the new primary's input of a
# period whose estimate the recording still dropped (a `none` row, allowed above only at a kill):
# such an input has nothing recorded to be checked against, and is only counted.
unrecorded = [r["k"] for r in rows[1:] if r["k"] not in missing and by_k[r["k"] - 1]["xhat"] is None]
mismatched = [r["k"] for r in rows[1:] if r["k"] not in missing and r["k"] not in unrecorded and abs(
    r["u"][0] + GAIN * by_k[r["k"] - 1]["xhat"][0]) > 1e-12 * max(1.0, abs(GAIN * by_k[r["k"] - 1]["xhat"][0]))]
check(not mismatched, "every applied input is -L x̂ of the recorded estimate (%d differ: %s; %d inputs of a "
      "period the recording has no estimate of: %s)" % (len(mismatched), mismatched[:5], len(unrecorded), unrecorded))
undisturbed = max(abs(r["x"][0]) for r in rows if 50 <= r["k"] < kills[0][0]) if kills else 1.0
for i, (k_kill, strength) in enumerate(kills):
    window = [r for r in rows if k_kill - 10 <= r["k"] <= k_kill + 60]
    zero = sorted(set(inputs_missing(rows)) & {r["k"] for r in window})
    worst = max((abs(r["x"][0]) for r in window), default=0.0)
    print("kill %d (strength %d) near period %d: %d periods without an input %s, max |x| %.3g (undisturbed %.3g)"
          % (i + 1, strength, k_kill, len(zero), zero, worst, undisturbed))
    check(len(zero) <= 2 * LEASE, "kill %d: at most twice the lease's periods without an input (%d)" % (i + 1, len(zero)))
    check(worst <= 4 * undisturbed + 1.0, "kill %d: |x| stays within a few times its range (%.3g, undisturbed %.3g)"
          % (i + 1, worst, undisturbed))
finish()
