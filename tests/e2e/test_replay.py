"""A live session becomes a script: `netkf ctl` changes links at arbitrary moments while the
launch records (--record FILE also writes FILE.events.yaml); the replay (`--events`) with the
same scenario and seed must deliver exactly the same (sensor, period) pairs — the second run is
the independent reference for the first. Changes: link 1's loss, link 3 by loss and mean burst
(Gilbert-Elliott, the user's form), link 2 a delay (which never changes a drop decision)."""
import os
import time

import yaml

from e2e_common import (DATA, Launch, check, finish, last_period, netkf, read_samples, require_netns, wait_for,
                        workdir)

require_netns()
scenario = os.path.join(DATA, "replay.yaml")
out = workdir("replay")
live_dir = os.path.join(out, "live")
os.makedirs(live_dir)
with Launch(scenario, 60, live_dir, samples=True, extra=("--dashboard", "off")) as live:
    time.sleep(2.3)
    r1 = netkf("ctl", "set-link", "1", "--bernoulli", "0.6")
    time.sleep(1.7)
    r2 = netkf("ctl", "set-link", "3", "--loss", "0.4", "--mean-burst", "8")
    time.sleep(1.1)
    r3 = netkf("ctl", "set-link", "2", "--delay", "3", "--jitter", "2")
    time.sleep(1.3)
    r4 = netkf("ctl", "set-link", "1", "--loss", "0.05")
    start = last_period(live.record)
    wait_for(lambda: last_period(live.record) >= start + 150, 30)
    rc = live.interrupt()
for i, r in enumerate((r1, r2, r3, r4), 1):
    check(r.returncode == 0, "ctl change %d applied (rc=%d) %s" % (i, r.returncode, r.stderr.strip()[-200:]))
check(rc == 0, "the live launch exits 0 (rc=%s)" % rc)
events_file = live.record + ".events.yaml"
check(os.path.exists(events_file), "--record also wrote %s" % os.path.basename(events_file))
events = (yaml.safe_load(open(events_file)) or {}).get("events", [])
check(len(events) == 4 and [e["link"] for e in events] == [1, 3, 2, 1],
      "the journal holds the four changes in order (%s)" % [(e.get("at_period"), e.get("link")) for e in events])
if len(events) == 4:
    check(events[1]["set"]["model"] == "gilbert_elliott" and abs(events[1]["set"]["r"] - 1 / 8) < 1e-12
          and abs(events[1]["set"]["p"] - (1 / 8) * 0.4 / 0.6) < 1e-12,
          "link 3's change is journaled as the chain it made (r = 1/8, p = r*0.4/0.6)")
    check(events[2]["set"]["model"] == "bernoulli" and events[2]["set"]["loss"] == 0.3
          and events[2]["set"]["delay_ms"] == 3,
          "link 2's delay change kept its loss model (bernoulli 0.3)")

replay_dir = os.path.join(out, "replay")
os.makedirs(replay_dir)
with Launch(scenario, 60, replay_dir, samples=True, extra=("--dashboard", "off", "--events", events_file)) as replay:
    target = max(last_period(live.record), 0)
    check(wait_for(lambda: last_period(replay.record) >= target, 60), "the replay reaches period %d" % target)
    rc = replay.interrupt()
check(rc == 0, "the replay exits 0 (rc=%s)" % rc)

live_pairs = {(s["sensor_id"], s["k"]) for s in read_samples(live.samples)}
replay_pairs = {(s["sensor_id"], s["k"]) for s in read_samples(replay.samples)}
last = min(max((k for _, k in live_pairs), default=0), max((k for _, k in replay_pairs), default=0)) - 20
check(last > max((e["at_period"] for e in events), default=10 ** 9) + 50,
      "both runs cover every change and 50 periods after the last (common range ends at %d)" % last)
a = {p for p in live_pairs if p[1] <= last}
b = {p for p in replay_pairs if p[1] <= last}
check(len(a) > 1000 and a == b, "identical delivered (sensor, period) sets up to period %d (%d pairs; %d differ)"
      % (last, len(a), len(a ^ b)))
finish()
