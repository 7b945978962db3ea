"""Bags ROS 2 can play (docs/recording.md): `netkf launch --record run.mcap --mcap-profile ros2`
and `netkf record --out x.mcap --mcap-profile ros2`, read back with Foxglove's libraries
(@mcap/core, @foxglove/rosmsg, @foxglove/rosmsg2-serialization: tests/e2e/mcap_ros2_read.mjs)
and with the pure-Python reader (python/netkf), against a CSV recording of the same run.

One launch records run.mcap in the ros2 profile with --record-samples (so the delivered
samples are in it, and in samples.csv); `netkf record --out same.csv` and `netkf record --out
attached.mcap --mcap-profile ros2` record the same network, attached; `netkf ctl set-link`
makes one link change. Checks:
- header profile ros2; one channel per topic under its ROS 2 name, schema encoding ros2msg
  named netkf_msgs/msg/TYPE (rcl_interfaces/msg/Log for /rosout), message encoding cdr, offered_qos_profiles in each channel's
  metadata (YAML, as rosbag2 writes it); the rosbag2 metadata record (serialized_metadata:
  the bag's YAML with every topic and its message count; ROS_DISTRO);
- every schema parses with @foxglove/rosmsg and every message decodes with
  @foxglove/rosmsg2-serialization's MessageReader, with no byte left over;
- every period of same.csv is in run.mcap with the same x̂ and Tr P (the exact doubles), the
  same fused set and state; the ctl change is on /netkf/link/change, and its event on /rosout
  (rcl_interfaces/msg/Log, INFO);
- the Python reader's period frame of run.mcap equals same.csv's on the periods both have, and
  its messages equal Foxglove's decoding;
- `netkf trace extract` of link 1 from run.mcap equals the one from samples.csv;
- the attached ros2 recorder's estimates equal the launch's.
"""
import json
import math
import os
import signal
import sys
import time

import yaml

from e2e_common import (DATA, NETKF, REPO, BackgroundProcess, Launch, check, finish, netkf, node, read_periods,
                        require_netns, workdir)

sys.path.insert(0, os.path.join(REPO, "python"))
import netkf as netkf_py  # noqa: E402  (the pure-Python reader)

require_netns()
scenario = os.path.join(DATA, "bernoulli3.yaml")  # three links, Bernoulli loss 0.3, period 40 ms, n = 2
N = 2
out = workdir("mcap_ros2")
TOPICS = {"/netkf/truth": "netkf_msgs/msg/Truth", "/netkf/estimate": "netkf_msgs/msg/Estimate",
          "/netkf/measurement/delivered": "netkf_msgs/msg/Measurement", "/netkf/link/status": "netkf_msgs/msg/LinkStatus",
          "/netkf/link/change": "netkf_msgs/msg/LinkChange", "/rosout": "rcl_interfaces/msg/Log"}
PERIOD_MS = 40  # bernoulli3.yaml's period


def recorder(args, log):
    cmd = [NETKF, "record", scenario] + args
    return BackgroundProcess(cmd, log=log)


run_mcap = os.path.join(out, "run.mcap")
same_csv = os.path.join(out, "same.csv")
attached_mcap = os.path.join(out, "attached.mcap")
samples_csv = os.path.join(out, "samples.csv")
with Launch(scenario, 60, out, record=False,
            extra=["--record", run_mcap, "--mcap-profile", "ros2", "--record-samples", samples_csv,
                   "--dashboard", "off"]) as run:
    time.sleep(2.0)  # the network runs
    rec_csv = recorder(["--out", same_csv, "--duration", "5"], same_csv + ".log")
    rec_mcap = recorder(["--out", attached_mcap, "--mcap-profile", "ros2", "--duration", "5"], attached_mcap + ".log")
    time.sleep(2.0)
    r = netkf("ctl", "set-link", "1", "--loss", "0.2", "--timeout", "10")
    check(r.returncode == 0, "ctl set-link 1 --loss 0.2 applied (rc=%d)" % r.returncode)
    for name, p in (("same.csv", rec_csv), ("attached.mcap", rec_mcap)):
        rc = p.stop(None, 30)  # it ends by itself after --duration; SIGKILL after 30 s
        p.close()
        print(p.output(), flush=True)
        check(rc == 0, "netkf record --out %s exits 0 (rc=%s)" % (name, rc))
    time.sleep(1.0)
    run.proc.send_signal(signal.SIGTERM)  # the launch stops its children and completes the file
    rc = run.wait(40)
    check(rc is not None, "the launch ended after SIGTERM (rc=%s)" % rc)
    run.stop()
    log = run.output()
print(log[-1500:], flush=True)

# ---- the file as Foxglove reads it ----
m = node("mcap_ros2_read.mjs", run_mcap, timeout=120)
check(m.get("problems") == [], "run.mcap: Foxglove's readers report no problem (%s)" % m.get("problems", [])[:5])
check(m.get("complete") is True, "run.mcap: complete after SIGTERM (Footer and closing magic)")
check(m.get("header") == {"profile": "ros2", "library": "netkf"}, "run.mcap: header profile ros2 (%s)" % m.get("header"))
channels = m.get("channels", [])
check([c["topic"] for c in channels] == list(TOPICS), "run.mcap: one channel per ROS 2 topic (%s)"
      % [c["topic"] for c in channels])
for c in channels:
    check(c["schemaName"] == TOPICS.get(c["topic"]) and c["schemaEncoding"] == "ros2msg"
          and c["messageEncoding"] == "cdr", "%s: schema %s (ros2msg), messages cdr" % (c["topic"], c["schemaName"]))
    qos = yaml.safe_load(c["metadata"].get("offered_qos_profiles", ""))
    check(isinstance(qos, list) and len(qos) == 1 and qos[0].get("reliability") == 1 and qos[0].get("history") == 1
          and qos[0].get("depth", 0) >= 1, "%s: offered_qos_profiles is rosbag2's YAML list (reliable, keep last)"
          % c["topic"])
    deps = {"/netkf/link/status": ["netkf_msgs/LinkSpec"], "/netkf/link/change": ["netkf_msgs/LinkSpec"],
            "/rosout": ["builtin_interfaces/Time"]}.get(c["topic"], [])
    check(c["types"] == ["(root)"] + deps,
          "%s: @foxglove/rosmsg parses the schema with its dependencies (%s)" % (c["topic"], c["types"]))
counts = m.get("counts", {})
print("message counts:", counts, flush=True)
check(counts.get("/netkf/estimate", 0) >= 100 and counts.get("/netkf/truth", 0) >= 100,
      "run.mcap: at least 100 estimates and truths (%s)" % counts)
check(counts.get("/netkf/measurement/delivered", 0) >= 100, "run.mcap: delivered samples (--record-samples)")
check(counts.get("/netkf/link/status", 0) >= 3, "run.mcap: link status messages")
decoded = m.get("messages", {})
check(all(len(decoded.get(t, [])) == counts.get(t, -1) for t in TOPICS),
      "every message decoded with @foxglove/rosmsg2-serialization")
check(all(v == 0 for v in m.get("trailing", {1: 1}).values()),
      "no message has bytes past its schema's last field (%s)" % m.get("trailing"))

# rosbag2's metadata record
meta = [x for x in m.get("metadata", []) if x["name"] == "rosbag2"]
check(len(meta) == 1 and meta[0]["metadata"].get("ROS_DISTRO"), "run.mcap: one rosbag2 metadata record with ROS_DISTRO")
bag = yaml.safe_load(meta[0]["metadata"].get("serialized_metadata", "")) if meta else {}
check(bag.get("storage_identifier") == "mcap" and bag.get("version") == 8 and bag.get("message_count") == sum(counts.values()),
      "serialized_metadata: storage mcap, version 8, the file's message count (%s)" % bag.get("message_count"))
bag_topics = {t["topic_metadata"]["name"]: t for t in bag.get("topics_with_message_count", [])}
check(set(bag_topics) == set(TOPICS) and all(
    bag_topics[t]["message_count"] == counts[t] and bag_topics[t]["topic_metadata"]["type"] == ty
    and bag_topics[t]["topic_metadata"]["serialization_format"] == "cdr" for t, ty in TOPICS.items()),
    "serialized_metadata lists every topic with its type and message count")

# ---- the numbers against the CSV ----
est = {e["k"]: e for e in decoded.get("/netkf/estimate", []) if e["revision"] == 0}
for e in decoded.get("/netkf/estimate", []):
    if e["log_time"] != round(e["t"] * 1e9):
        check(False, "estimate %d: log_time is t in ns" % e["k"])
        break
rows = read_periods(same_csv, N)
check(len(rows) >= 50, "same.csv (attached netkf record): at least 50 periods (%d)" % len(rows))
missing = [r["k"] for r in rows if r["k"] not in est]
check(not missing, "every period of same.csv is in run.mcap (missing %s)" % missing[:10])
diff = [r["k"] for r in rows if r["k"] in est and (est[r["k"]]["x_hat"] != r["xhat"] or est[r["k"]]["trace_p"] != r["trace_P"]
                                                 or sorted(est[r["k"]]["fused"]) != sorted(r["fused"])
                                                 or est[r["k"]]["state"] != r["state"])]
check(not diff, "x̂, Tr P (exact doubles), fused set and state are the same in run.mcap and same.csv (differ at %s)"
      % diff[:10])
truth = {t["k"]: t for t in decoded.get("/netkf/truth", [])}
check(all(r["k"] in truth and truth[r["k"]]["x"] == r["x"] for r in rows), "the truth x is the CSV's (exact doubles)")
changes = [c for c in decoded.get("/netkf/link/change", []) if c["origin"] == "request" and c["sensor_id"] == 1]
check(len(changes) == 1 and changes[0]["link"]["loss"] == 0.2, "the ctl change of link 1 is on /netkf/link/change")
# The run's events as ROS 2 log messages: the ctl change once, at INFO (20), stamped with its log
# time, from the period before the one the change applied from.
link_events = [e for e in decoded.get("/rosout", []) if "link 1" in e["msg"] and "loss=0.2" in e["msg"]]
check(len(link_events) == 1 and link_events[0]["level"] == 20 and link_events[0]["name"] == "netkf",
      "/rosout: one INFO log message announces link 1's change (%s)" % decoded.get("/rosout"))
if link_events and changes:
    ev = link_events[0]
    ev_ns = ev["stamp"]["sec"] * 1000000000 + ev["stamp"]["nanosec"]
    check(ev_ns == ev["log_time"] and ev_ns >= (changes[0]["at_period"] - 1) * PERIOD_MS * 1000000,
          "the log message's stamp is its log time, from the period before the change's (%d) on (%d ns)"
          % (changes[0]["at_period"], ev_ns))

# ---- the pure-Python reader ----
frame = netkf_py.read_mcap_periods(run_mcap)
csv_frame = netkf_py.read_periods(same_csv)
# The attached recorder's last periods can lack their estimate (it stopped first): compared are
# the periods it has one for.
csv_frame = csv_frame[csv_frame["state"] != "none"].reset_index(drop=True)
both = frame[frame["k"].isin(csv_frame["k"])].reset_index(drop=True)
check(len(both) == len(csv_frame) >= 50, "the Python reader's frame of run.mcap has every period of same.csv (%d)"
      % len(csv_frame))
cols = list(csv_frame.columns)
check(list(frame.columns) == cols, "the Python frames of run.mcap and same.csv have the same columns (%s)"
      % list(frame.columns))
unequal = [c for c in cols if len(both) != len(csv_frame) or not both[c].equals(csv_frame[c])]
check(not unequal, "the Python reader's frame of run.mcap equals same.csv's on its periods (every column, exact; "
      "differ: %s)" % unequal)
mf = netkf_py.read_mcap(run_mcap)
py_est = [msg for _, msg in mf.decoded("/netkf/estimate")]
fox_est = [{k: v for k, v in e.items() if k != "log_time"} for e in decoded.get("/netkf/estimate", [])]
check(py_est == fox_est, "the Python CDR decoder and Foxglove's decode the estimates alike (%d)" % len(py_est))
py_status = [msg for _, msg in mf.decoded("/netkf/link/status")]
fox_status = [{k: v for k, v in e.items() if k != "log_time"} for e in decoded.get("/netkf/link/status", [])]
check(py_status == fox_status, "... and the link status messages (nested LinkSpec)")
samples = netkf_py.read_mcap_samples(run_mcap)
check(len(samples) == counts.get("/netkf/measurement/delivered"), "the Python reader's samples frame of run.mcap")

# ---- netkf trace extract ----
traces = {}
for name, path in (("ros2", run_mcap), ("csv", samples_csv)):
    target = os.path.join(out, "trace-%s.csv" % name)
    res = netkf("trace", "extract", path, "--link", "1", "-o", target)
    check(res.returncode == 0, "netkf trace extract --link 1 of %s (rc=%d)" % (name, res.returncode))
    if res.returncode == 0:
        with open(target) as f:
            traces[name] = [line for line in f if not line.startswith("#")]
check(len(traces.get("ros2", [])) > 50 and traces.get("ros2") == traces.get("csv"),
      "netkf trace extract gives the same trace of link 1 from run.mcap (ros2) as from samples.csv (%d rows)"
      % len(traces.get("ros2", [])))

# ---- netkf record --mcap-profile ros2 ----
a = node("mcap_ros2_read.mjs", attached_mcap, timeout=120)
check(a.get("complete") is True and a.get("problems") == [] and a.get("header", {}).get("profile") == "ros2",
      "attached.mcap (netkf record --mcap-profile ros2): complete, profile ros2, no problem")
check([c["topic"] for c in a.get("channels", [])] == [t for t in TOPICS if t != "/netkf/measurement/delivered"],
      "attached.mcap: no delivered channel without --samples")
a_est = {e["k"]: e for e in a.get("messages", {}).get("/netkf/estimate", []) if e["revision"] == 0}
check(len(a_est) >= 50 and all(k in est and est[k]["x_hat"] == e["x_hat"] and est[k]["trace_p"] == e["trace_p"]
                               for k, e in a_est.items()), "attached.mcap: every estimate equals run.mcap's")

# ---- bad usage ----
res = netkf("launch", scenario, "--record", os.path.join(out, "x.csv"), "--mcap-profile", "ros2")
check(res.returncode == 2 and "--mcap-profile" in res.stderr, "--mcap-profile with a CSV recording: exit 2, named")
res = netkf("record", scenario, "--out", os.path.join(out, "y.mcap"), "--mcap-profile", "ros1")
check(res.returncode != 0 and not os.path.exists(os.path.join(out, "y.mcap")), "an unknown profile is refused")

finish()
