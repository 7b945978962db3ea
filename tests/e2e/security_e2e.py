"""Shared steps of the DDS Security e2e tests (test_security_*.py): a secured launch, the
rogue participant (netkf_rogue), link status read by a secured observer, and the checks that
a forged sample never reached the network. Each test adds its own intruder."""
import json
import os
import shutil
import subprocess

from e2e_common import DATA, Launch, check, last_period, netkf, read_periods, read_samples, wait_for

ROGUE = os.environ.get("NETKF_ROGUE", "")
DOMAIN = os.environ.get("NETKF_DOMAIN", "")
SCENARIO = os.path.join(DATA, "secure.yaml")
FOREIGN = 31337.0   # marker of the samples an intruder forges
ALLOWED = 27182.0   # marker of the positive control (a legitimate sensor identity)


def init(directory, *extra):
    r = netkf("security", "init", directory, *extra, timeout=60)
    check(r.returncode == 0, "netkf security init %s exits 0 (rc=%d)" % (directory, r.returncode))
    return r


def rogue(*args, seconds=5):
    cmd = [ROGUE, "--domain", DOMAIN, "--seconds", str(seconds)] + [str(a) for a in args]
    print("$", " ".join(cmd), flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=seconds + 60)
    print(r.stderr[-2000:], flush=True)
    print(r.stdout, flush=True)
    try:
        return json.loads(r.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        check(False, "netkf_rogue printed one JSON object (rc=%d)" % r.returncode)
        return {"received": {}, "written": {}, "errors": [], "participant": False}


def link_status(secure_dir):
    """Links as a secured observer sees them: {sensor_id: link json}."""
    r = netkf("ctl", "status", "--json", "--secure", secure_dir, "--timeout", "20", timeout=60)
    check(r.returncode == 0, "a secured `ctl status` reads the link status (rc=%d)" % r.returncode)
    try:
        return {l["sensor_id"]: l for l in json.loads(r.stdout)["links"]}
    except (ValueError, KeyError):
        return {}


def start_secured_launch(secure_dir, out, duration=90):
    run = Launch(SCENARIO, duration, out, samples=True, extra=["--secure", secure_dir])
    running = wait_for(lambda: last_period(run.record) >= 50, 60)
    check(running, "the secured launch estimates (period %d reached)" % last_period(run.record))
    return run


def check_untouched(secure_dir, what):
    """Link 1 still has the scenario's Bernoulli 0.1."""
    links = link_status(secure_dir)
    l1 = links.get(1, {})
    check(l1.get("model") == "bernoulli" and abs(l1.get("loss", -1) - 0.1) < 1e-9,
          "%s: link 1 unchanged, bernoulli 0.1 (status: model %s, loss %s)" % (what, l1.get("model"), l1.get("loss")))


def positive_controls(secure_dir):
    """The checks could fail: a legitimate ctl changes link 1, a legitimate sensor identity's
    marker samples reach the network (after the intruder's attempts)."""
    r = netkf("ctl", "set-link", "1", "--bernoulli", "0.2", "--secure", secure_dir, "--timeout", "20", timeout=60)
    check(r.returncode == 0, "control: the secured ctl changes link 1 (rc=%d)" % r.returncode)
    l1 = link_status(secure_dir).get(1, {})
    check(abs(l1.get("loss", -1) - 0.2) < 1e-9, "control: the status shows link 1 at 0.2 (loss %s)" % l1.get("loss"))
    legit = rogue("--secure", secure_dir, "--role", "sensor", "--raw", "--sensor", "2", "--marker", ALLOWED,
                  "--after-truth", seconds=4)
    check(legit["received"].get("truth", 0) > 0, "control: a sensor identity receives the truth (%s)" % legit["received"])
    check(legit["written"].get("raw", 0) > 0 and legit["matched"].get("raw_readers", 0) > 0,
          "control: its raw samples are written to a matched channel (%s)" % legit.get("matched"))


def check_recording(run, intruder):
    """After the launch: nothing forged arrived, the positive control's samples did."""
    samples = read_samples(run.samples)
    foreign = [s for s in samples if FOREIGN in s["y"]]
    allowed = [s for s in samples if ALLOWED in s["y"]]
    check(len(samples) > 100, "delivered samples recorded (%d)" % len(samples))
    check(not foreign, "no sample forged by %s was delivered (%d found)" % (intruder, len(foreign)))
    check(len(allowed) > 0, "control: the sensor identity's marker samples were delivered (%d)" % len(allowed))
    rows = read_periods(run.record, 2)
    check(len(rows) > 100, "periods recorded (%d)" % len(rows))
    first_allowed = min((s["k"] for s in allowed), default=rows[-1]["k"] + 1 if rows else 0)
    before = [r for r in rows if r["k"] < first_allowed - 2]  # the control's samples move x̂
    err = max((abs(r["x"][0] - r["xhat"][0]) for r in before[10:]), default=1e9)
    check(err < 10.0, "estimates track the truth (largest |x0 - xhat0| %.2f): no forged 31337 fused" % err)


def copy_with_identity(src, dst, role, as_role):
    """A copy of a security directory in which `as_role`'s files are `role`'s: a command that
    picks `as_role` then runs with `role`'s certificate and permissions."""
    shutil.copytree(src, dst)
    shutil.rmtree(os.path.join(dst, "identities", as_role))
    shutil.copytree(os.path.join(src, "identities", role), os.path.join(dst, "identities", as_role))
    shutil.copy(os.path.join(src, "permissions", role + ".p7s"), os.path.join(dst, "permissions", as_role + ".p7s"))
