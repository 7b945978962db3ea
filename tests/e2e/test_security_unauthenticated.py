"""DDS Security: a participant without a certificate, on the domain of a secured launch,
receives nothing, and its forged samples and link-control requests change nothing."""
import os

from e2e_common import check, finish, netkf, require_netns, workdir
from security_e2e import FOREIGN, check_recording, check_untouched, init, positive_controls, rogue, \
    start_secured_launch

require_netns()
out = workdir("sec-unauth")
secure = os.path.join(out, "security")
init(secure)
with start_secured_launch(secure, out) as run:
    # No certificate at all: reads truth/estimates/status, forges raw and delivered samples of
    # sensor 1 and asks to drop 95 % of link 1.
    r = rogue("--raw", "--delivered", "--link-control", "--sensor", "1", "--marker", FOREIGN, seconds=6)
    check(r.get("participant") is True, "the unsecured participant was created (it is the network that refuses it)")
    check(r["written"].get("raw", 0) > 0 and r["written"].get("link_control", 0) > 0,
          "it wrote forged samples and link requests (%s)" % r["written"])
    check(all(v == 0 for v in r["received"].values()), "it received nothing (%s)" % r["received"])
    check(all(v == 0 for v in r.get("matched", {}).values()), "none of its endpoints matched (%s)" % r.get("matched"))
    rec = netkf("record", "--out", os.path.join(out, "unsecured.csv"), "--duration", "4", timeout=60)
    check(rec.returncode == 3, "an unsecured `netkf record` records nothing, exit 3 (rc=%d)" % rec.returncode)
    ctl = netkf("ctl", "set-link", "1", "--bernoulli", "0.9", "--timeout", "4", timeout=60)
    check(ctl.returncode == 3, "an unsecured `ctl set-link` finds no channel, exit 3 (rc=%d)" % ctl.returncode)
    check_untouched(secure, "after the unsecured intruder")
    positive_controls(secure)
    rc = run.interrupt()
check(rc == 0, "the secured launch ends cleanly (rc=%s)" % rc)
check_recording(run, "the unsecured participant")
finish()
