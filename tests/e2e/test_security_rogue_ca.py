"""DDS Security: a participant with a certificate and permissions from another CA (a second
`netkf security init`) receives nothing, and its forged samples and link-control requests
change nothing."""
import os

from e2e_common import check, finish, netkf, require_netns, workdir
from security_e2e import FOREIGN, check_recording, check_untouched, init, positive_controls, rogue, \
    start_secured_launch

require_netns()
out = workdir("sec-rogue-ca")
secure = os.path.join(out, "security")
other = os.path.join(out, "other-ca")
init(secure)
init(other)  # same roles and subjects, another CA key
with start_secured_launch(secure, out) as run:
    for role in ("sensor", "ctl", "channel"):
        r = rogue("--secure", other, "--role", role, "--raw", "--delivered", "--link-control", "--sensor", "1",
                  "--marker", FOREIGN, seconds=4)
        check(r.get("participant") is True, "other CA's %s: the participant was created" % role)
        check(all(v == 0 for v in r["received"].values()), "other CA's %s: received nothing (%s)" % (role, r["received"]))
        check(all(v == 0 for v in r.get("matched", {}).values()),
              "other CA's %s: no endpoint matched (%s)" % (role, r.get("matched")))
    # The role that may write what it forges, in the other CA: sensor writes raw samples.
    r = rogue("--secure", other, "--role", "sensor", "--raw", "--sensor", "1", "--marker", FOREIGN, seconds=4)
    check(r["written"].get("raw", 0) > 0, "other CA's sensor wrote forged raw samples (%s)" % r["written"])
    rec = netkf("record", "--secure", other, "--out", os.path.join(out, "other.csv"), "--duration", "4", timeout=60)
    check(rec.returncode == 3, "`netkf record` with the other CA records nothing, exit 3 (rc=%d)" % rec.returncode)
    ctl = netkf("ctl", "set-link", "1", "--bernoulli", "0.9", "--secure", other, "--timeout", "4", timeout=60)
    check(ctl.returncode == 3, "`ctl set-link` with the other CA finds no channel, exit 3 (rc=%d)" % ctl.returncode)
    check_untouched(secure, "after the other CA's intruders")
    positive_controls(secure)
    rc = run.interrupt()
check(rc == 0, "the secured launch ends cleanly (rc=%s)" % rc)
check_recording(run, "the other CA's participants")
finish()
