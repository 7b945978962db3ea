"""DDS Security: a sensor identity (a real certificate of the launch's CA) cannot write link
control, nor samples of another role's topic; a missing identity file is a clear error."""
import os

from e2e_common import check, finish, netkf, require_netns, workdir
from security_e2e import FOREIGN, check_recording, check_untouched, copy_with_identity, init, positive_controls, \
    rogue, start_secured_launch

require_netns()
out = workdir("sec-sensor-role")
secure = os.path.join(out, "security")
init(secure)
# `netkf ctl set-link` picks the ctl identity: in this copy it is the sensor's.
as_sensor = os.path.join(out, "sensor-as-ctl")
copy_with_identity(secure, as_sensor, "sensor", "ctl")
# A directory without the observer's key: a clear error naming the file, before any DDS traffic.
broken = os.path.join(out, "broken")
copy_with_identity(secure, broken, "observer", "observer")
os.remove(os.path.join(broken, "identities", "observer", "key.pem"))
r = netkf("record", "--secure", broken, "--out", os.path.join(out, "x.csv"), "--duration", "1", timeout=60)
check(r.returncode == 2, "a missing identity file: exit 2 (rc=%d)" % r.returncode)
check(os.path.join("identities", "observer", "key.pem") in r.stderr and "missing" in r.stderr,
      "the error names the missing key file")

with start_secured_launch(secure, out) as run:
    ctl = netkf("ctl", "set-link", "1", "--bernoulli", "0.9", "--secure", as_sensor, "--timeout", "6", timeout=60)
    check(ctl.returncode != 0, "`ctl set-link` with the sensor identity fails (rc=%d)" % ctl.returncode)
    # The sensor's permissions already refuse ctl's link-status reader, before the writer.
    check("DDS Security: the permissions" in ctl.stderr, "its error says the role's permissions refuse it")
    r = rogue("--secure", secure, "--role", "sensor", "--link-control", "--delivered", "--sensor", "1",
              "--marker", FOREIGN, seconds=5)
    check(r["received"].get("truth", 0) > 0, "the sensor identity is admitted (it receives the truth)")
    check(r["written"].get("link_control", 0) == 0 and r["written"].get("delivered", 0) == 0,
          "it could not write link control nor delivered samples (%s)" % r["written"])
    check(any("netkf/link/control" in e for e in r["errors"]) and any("netkf/measurement/delivered" in e
                                                                      for e in r["errors"]),
          "DDS refused both writers (%s)" % r["errors"])
    check_untouched(secure, "after the sensor identity's requests")
    positive_controls(secure)
    rc = run.interrupt()
check(rc == 0, "the secured launch ends cleanly (rc=%s)" % rc)
check_recording(run, "the sensor identity")
finish()
