"""netkf's own network under ROS 2 names (docs/ros2.md): a scenario with `naming: ros2` makes
every process use rt/netkf/... topics of netkf_msgs::msg::dds_::X_ types (what rmw makes of the
ROS 2 topic /netkf/X and the message netkf_msgs/msg/X), with shared ownership as ROS 2's readers
have.

Independent expectations:
- A Cyclone DDS subscriber (tests/interop/netkf_cyclone_reader.c built as
  netkf_cyclone_reader_ros2) whose types idlc generated from the IDL that
  tests/interop/msg_to_idl.py writes of the shipped netkf_msgs/msg/*.msg, as ROS 2 would, reads
  rt/netkf/estimate with a shared-ownership reader: every estimate equals the launch's --record
  CSV row of its period in the CSV's own text (x_hat, Tr P and the trace of P, fused set, late,
  state, t) — the .msg files describe the bytes netkf sends.
- At the same time the same reader built from idl/netkf.idl (netkf's names) matches nothing.
- `netkf ctl set-link --naming ros2` changes link 1 (the control topic under its ROS 2 name):
  the ROS 2 reader's journal (rt/netkf/link/change) has that change with ctl's request id, and
  `ctl status --naming ros2` shows it; the keyed link status does not match the reader of the
  unkeyed .msg type (docs/ros2.md, "Keyed topics").
- A closed loop under `--naming ros2` (the flag, not the key): the plant applies the inputs the
  estimator sends over rt/netkf/control (each applied input is -L x_hat of the recorded estimate
  of the period before) and the run ends 0.
- `--standby` with the ros2 naming is refused (exclusive ownership, which ROS 2 readers lack).
- `netkf relay --naming ros2` answers `ctl --naming ros2` and lists its topic's link there."""
import json
import os
import re
import signal
import sys
import time

import yaml

from e2e_common import (DATA, NETKF, REPO, BackgroundProcess, CycloneReader, Launch, check, finish, inputs_missing,
                        last_period, netkf, read_periods, require_netns, wait_for, workdir)

require_netns()
DOMAIN = 115
READER = os.environ.get("NETKF_CYCLONE_READER", "")
READER_ROS2 = os.environ.get("NETKF_CYCLONE_READER_ROS2", "")
if not all(r and os.access(r, os.X_OK) for r in (READER, READER_ROS2)):
    required = os.environ.get("NETKF_REQUIRE_INTEROP") in ("1", "ON", "TRUE", "true") or os.environ.get("CI") == "true"
    print("the Cyclone DDS readers are not built (install cyclonedds-dev cyclonedds-tools, scripts/deps.sh)",
          flush=True)
    sys.exit(1 if required else 77)  # 77: ctest SKIP_RETURN_CODE
CONFIG = "file://" + os.path.join(REPO, "deploy", "dds", "cyclonedds-localhost.xml")
out = workdir("ros2_naming")


def Reader(name, exe):
    return CycloneReader(exe, DOMAIN, out, name, CONFIG)


# ---- the key: exact.yaml (open loop, links 1 and 2) with `naming: ros2`
with open(os.path.join(DATA, "exact.yaml")) as f:
    scenario = yaml.safe_load(f)
scenario["naming"] = "ros2"
scenario_path = os.path.join(out, "exact-ros2.yaml")
with open(scenario_path, "w") as f:
    yaml.safe_dump(scenario, f)

ros2 = Reader("ros2", READER_ROS2)
netkf_named = Reader("netkf-named", READER)
try:
    check(wait_for(lambda: "ready" in ros2.log() and "ready" in netkf_named.log(), 20), "both Cyclone readers are up")
    with Launch(scenario_path, 12, out, extra=("--domain", str(DOMAIN), "--dashboard", "off")) as run:
        check(wait_for(lambda: last_period(run.record) >= 150, 30), "the launch is past period 150")
        changed = netkf("ctl", "set-link", "1", "--bernoulli", "0.5", "--domain", DOMAIN, "--naming", "ros2")
        status = netkf("ctl", "status", "--json", "--domain", DOMAIN, "--timeout", "10", "--naming", "ros2")
        unnamed = netkf("ctl", "set-link", "2", "--bernoulli", "0.5", "--domain", DOMAIN, "--timeout", "3")
        rc = run.wait(60)
    time.sleep(1.5)  # the channel's final status is written as the launch stops
finally:
    rc_ros2, rc_netkf = ros2.stop(), netkf_named.stop()
check(rc == 0, "the launch of a scenario with naming: ros2 exits 0 (rc=%s)" % rc)
check(rc_ros2 == 0 and rc_netkf == 0, "both readers exit 0 (%s, %s)" % (rc_ros2, rc_netkf))
check(changed.returncode == 0, "netkf ctl --naming ros2 changed link 1 (rc=%d): %s"
      % (changed.returncode, changed.stdout + changed.stderr))
check(unnamed.returncode != 0, "netkf ctl with netkf's names finds no channel on the ROS 2 network (rc=%d)"
      % unnamed.returncode)

netkf_lines = netkf_named.lines()
netkf_summary = netkf_lines[-1].get("summary", {}) if netkf_lines else {}
check(netkf_summary.get("estimates") == 0 and netkf_summary.get("estimate_writers_matched") == 0,
      "the reader of netkf's names matched and received nothing (%s)" % netkf_summary)

lines = ros2.lines()
summary = lines[-1].get("summary", {}) if lines else {}
print("ROS 2 reader's summary:", summary, flush=True)
check(summary.get("estimate_writers_matched") == 1, "the ROS 2 reader matched the estimator's writer (%s)" % summary)
estimates = {}
duplicates = 0
for l in lines:
    if l.get("topic") == "rt/netkf/estimate":
        duplicates += l["k"] in estimates
        estimates[l["k"]] = l
check(duplicates == 0, "no period received twice (%d)" % duplicates)
with open(run.record) as f:
    header = f.readline().rstrip("\n").split(",")
    csv_text = {int(c[0]): c for c in (line.rstrip("\n").split(",") for line in f) if c and c[0]}
col = {name: i for i, name in enumerate(header)}
csv_text = {k: c for k, c in csv_text.items() if c[col["state"]] != "none"}
first = min(estimates) if estimates else None
missing = sorted(k for k in set(csv_text) - set(estimates) if first is not None and k >= first)
check(first is not None and first <= 50 and not missing and len(estimates) >= 200,
      "the ROS 2 reader received every recorded period from its first one (k=%s) on: %d received, %d missing %s"
      % (first, len(estimates), len(missing), missing[:5]))
bad = []
for k in sorted(set(csv_text) & set(estimates)):
    c, e = csv_text[k], estimates[k]
    same = ([str(v) for v in e["x_hat"]] == [c[col["xhat0"]], c[col["xhat1"]]]
            and str(e["trace_P"]) == c[col["trace_P"]]
            and ";".join(str(i) for i in e["fused"]) == c[col["fused"]]
            and str(e["late"]) == c[col["late"]] and e["state"] == c[col["state"]] and str(e["t"]) == c[col["t"]]
            and len(e["P"]) == 4 and float(e["P"][0]) + float(e["P"][3]) == float(c[col["trace_P"]]))
    if not same:
        bad.append("k=%d: %s vs %s" % (k, e, c))
check(not bad, "each of the %d estimates decoded with the .msg types equals its CSV row bit for bit%s"
      % (len(estimates), "".join("\n    " + b for b in bad[:3])))

# The link status is keyed by the link; a .msg cannot say so, and a reader of the unkeyed type
# does not match a keyed writer (Cyclone compares the topic kind, as Fast DDS does): docs/ros2.md,
# "Keyed topics". netkf's own reader under the ROS 2 names reads it.
check(summary.get("link_status_writers_matched") == 0 and summary.get("link_status") == 0,
      "the reader of the unkeyed LinkStatus .msg type does not match the channel's keyed writer, as docs/ros2.md "
      "says (%s)" % summary)
# The journal is unkeyed: the ROS 2 reader gets ctl's change, with the request id ctl printed.
journal = [l for l in lines if l.get("topic") == "rt/netkf/link/change"]
request = re.search(r"request (\d+)", changed.stdout)
check(len(journal) == 1 and journal[0]["sensor_id"] == 1 and journal[0]["loss"] == "0.5"
      and journal[0]["origin"] == "request" and request and journal[0]["request_id"] == int(request.group(1)),
      "the ROS 2 reader of rt/netkf/link/change got the one change: link 1 to loss 0.5 by ctl's request %s (%s)"
      % (request.group(1) if request else None, journal))
links = {l["sensor_id"]: l for l in json.loads(status.stdout)["links"]} if status.returncode == 0 else {}
check(links.get(1, {}).get("loss") == 0.5 and links.get(2, {}).get("loss") == 0.4,
      "netkf ctl status --naming ros2 shows link 1 changed to loss 0.5 and link 2 at the scenario's 0.4 (%s)"
      % {k: l.get("loss") for k, l in links.items()})

# ---- the flag, on a closed loop: the inputs travel over rt/netkf/control
loop_out = os.path.join(out, "closed")
os.makedirs(loop_out, exist_ok=True)
with Launch(os.path.join(DATA, "closed_loop.yaml"), 5, loop_out,
            extra=("--domain", str(DOMAIN), "--dashboard", "off", "--naming", "ros2")) as loop:
    rc_loop = loop.wait(60)
    log = loop.output()
check(rc_loop == 0, "a closed loop launched with --naming ros2 exits 0 (rc=%s)\n%s" % (rc_loop, log[-1500:]))
rows = read_periods(loop.record, 1, m=1, truth_only=True)
gain = 1.2
by_k = {r["k"]: r for r in rows}
missing_inputs = set(inputs_missing(rows))
applied = [r for r in rows[1:] if r["k"] not in missing_inputs and by_k.get(r["k"] - 1) is not None
           and by_k[r["k"] - 1]["xhat"] is not None]
wrong = [r["k"] for r in applied if abs(r["u"][0] + gain * by_k[r["k"] - 1]["xhat"][0]) >
         1e-12 * max(1.0, abs(gain * by_k[r["k"] - 1]["xhat"][0]))]
check(len(rows) >= 200 and len(applied) >= 0.9 * len(rows) and not wrong,
      "the plant applied -L x_hat of the estimate before in %d of %d periods (%d inputs missing, %d wrong: %s)"
      % (len(applied), len(rows), len(missing_inputs), len(wrong), wrong[:5]))

refused = netkf("launch", os.path.join(DATA, "closed_loop.yaml"), "--duration", "1", "--standby", "--naming", "ros2",
                "--domain", DOMAIN, "--dashboard", "off")
check(refused.returncode == 2 and "--standby needs exclusive ownership" in refused.stderr,
      "--standby with the ros2 naming is refused with exit 2 (rc=%d): %s" % (refused.returncode, refused.stderr[-300:]))
# ---- a relay answers and reports under the naming its ctl uses (its relayed topics keep theirs)
# Leaving the block: SIGINT, SIGKILL after 30 s.
with BackgroundProcess([NETKF, "relay", "--from-domain", "116", "--to-domain", str(DOMAIN), "--topic", "rt/chatter",
                        "--bernoulli", "0.3", "--naming", "ros2", "--duration", "30"],
                       log=os.path.join(out, "relay.log"), stop_signal=signal.SIGINT, grace=30) as relay:
    relay_status = netkf("ctl", "status", "--json", "--domain", DOMAIN, "--timeout", "10", "--naming", "ros2")
    relay_change = netkf("ctl", "set-link", "rt/chatter", "--bernoulli", "0.1", "--domain", DOMAIN, "--naming", "ros2")
    relay_unnamed = netkf("ctl", "status", "--json", "--domain", DOMAIN, "--timeout", "3")
relay_log = relay.output()
topics = [l.get("topic") for l in json.loads(relay_status.stdout)["links"]] if relay_status.returncode == 0 else []
check(topics == ["rt/chatter"] and relay_change.returncode == 0 and relay_unnamed.returncode != 0,
      "a relay with --naming ros2: ctl status --naming ros2 lists its topic's link %s, set-link changes it (rc=%d), "
      "ctl with netkf's names finds nothing (rc=%d)\n%s" % (topics, relay_change.returncode, relay_unnamed.returncode,
                                                           relay_log[-1500:]))
finish()
