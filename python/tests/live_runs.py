"""Writes the files the reader's tests read, with the real launch (conftest.py runs this
through scripts/in-netns.sh: a private network namespace, loopback only, its own DDS domain).

Four runs, each a `netkf launch` and an attached `netkf record` of the same network, started
once the launch's own recording has its first period (an attached recorder that is up before
the launch lets the plant start before the launch's own recorder has matched the truth topic,
and the launch's recording then misses the first periods: docs/python.md):
  csv:   launch --record R.csv --record-samples S.csv --summary J.json; attached A.mcap (+ AS.csv)
  mcap:  launch --record R.mcap --record-samples S.csv --summary J.json; attached A.csv (+ AS.csv)
  late:  the same as csv with deploy/scenarios/late-fusion-boundary.yaml (late_policy fuse_within)
  loop:  the same as csv with data/closed_loop.yaml (a scalar closed loop with an explicit gain)
Writes OUT/runs.json: per run its directory, the commands, return codes and log tails.
Usage: live_runs.py NETKF OUT DOMAIN
"""
import json
import os
import signal
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DURATION = "4"
sys.path.insert(0, os.path.join(REPO, "python"))
sys.path.insert(0, os.path.join(REPO, "tests", "support"))  # the shared test support
from netkf.mcap import McapFile  # noqa: E402
from netkf_proc import BackgroundProcess  # noqa: E402


def has_first_period(path):
    """The launch's recording has a period: a CSV row after the header, or an MCAP file past
    its header and channels (records are flushed every 100 ms)."""
    try:
        if path.endswith(".csv"):
            with open(path) as f:
                return len(f.read().splitlines()) >= 2
        return McapFile(path).counts().get("netkf/estimate", 0) > 0
    except (OSError, ValueError):  # not there yet, or cut inside its first records
        return False


def wait(proc, timeout):
    """Its exit status, or when it did not end in `timeout` s how it was ended: SIGTERM, then
    SIGKILL (with whatever it spawned) after 10 s."""
    rc = proc.wait(timeout)
    if rc is not None:
        return rc
    rc = proc.stop(signal.SIGTERM, 10)
    return "%s (%s)" % ("killed" if proc.killed else "stopped", rc)


def run(netkf, out, domain, name, scenario, launch_record, attached_record):
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    scenario = os.path.join(REPO, scenario)
    rec_cmd = [netkf, "record", scenario, "--out", os.path.join(d, attached_record),
               "--samples", os.path.join(d, "AS.csv"), "--domain", domain, "--duration", "60"]
    launch_cmd = [netkf, "launch", scenario, "--duration", DURATION, "--record", os.path.join(d, launch_record),
                  "--record-samples", os.path.join(d, "S.csv"), "--summary", os.path.join(d, "J.json"),
                  "--dashboard", "off", "--domain", domain]
    first = os.path.join(d, launch_record)
    launch = BackgroundProcess(launch_cmd, log=os.path.join(d, "launch.log"), new_session=True, echo=False)
    rec = None
    try:
        end = time.monotonic() + 90
        while launch.running() and time.monotonic() < end:
            if has_first_period(first):
                rec = BackgroundProcess(rec_cmd, log=os.path.join(d, "record.log"), new_session=True, echo=False)
                break
            time.sleep(0.1)
        launch_rc = wait(launch, 120)
        rec_rc = wait(rec, 30) if rec else "never started"  # it ends by itself a second after the run
    finally:
        for p in (launch, rec):  # nothing of theirs left running (SIGKILL what is); our log handles closed
            if p is not None:
                p.kill()
                p.close()
    tails = {}
    for log in ("launch.log", "record.log"):
        try:
            with open(os.path.join(d, log)) as f:
                tails[log] = f.read()[-1500:]
        except FileNotFoundError:  # the recorder never started
            tails[log] = ""
    return {"dir": d, "launch": launch_cmd, "record": rec_cmd, "launch_rc": launch_rc, "record_rc": rec_rc,
            "logs": tails}


def main():
    netkf, out, domain = sys.argv[1:4]
    if os.environ.get("NETKF_IN_NETNS") != "1":
        sys.exit("live_runs.py starts DDS participants: run it through scripts/in-netns.sh")
    runs = {
        "csv": run(netkf, out, domain, "csv", "deploy/scenarios/default.yaml", "R.csv", "A.mcap"),
        "mcap": run(netkf, out, domain, "mcap", "deploy/scenarios/default.yaml", "R.mcap", "A.csv"),
        "late": run(netkf, out, domain, "late", "deploy/scenarios/late-fusion-boundary.yaml", "R.csv", "A.mcap"),
        "loop": run(netkf, out, domain, "loop", "python/tests/data/closed_loop.yaml", "R.csv", "A.mcap"),
    }
    with open(os.path.join(out, "runs.json"), "w") as f:
        json.dump(runs, f, indent=1)


if __name__ == "__main__":
    main()
