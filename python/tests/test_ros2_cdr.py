"""The ros2 MCAP profile's CDR (docs/recording.md, "Bags ROS 2 can play"): records encoded by
netkf's recorder codec (Fast CDR, cli/recording/ros2_cdr_codec.hpp, through the test helper
netkf_ros2_cdr_sample) decode with the pure-Python decoder (netkf.ros2msg, driven by the
committed .msg definitions) to the values sent; and the decoder on hand-made big-endian bytes,
nested types and bad input."""
import json
import os
import random
import struct
import subprocess

import pytest

from conftest import REPO
from netkf import ros2msg

MSG_DIR = os.path.join(REPO, "netkf_msgs", "msg")


def msg_text(name):
    with open(os.path.join(MSG_DIR, name + ".msg")) as f:
        return f.read()


def sample_binary():
    bin_dir = os.environ.get("NETKF_BIN_DIR")
    path = os.path.join(bin_dir or os.path.join(REPO, "build", "default"), "tests", "netkf_ros2_cdr_sample")
    if not os.path.exists(path):
        if bin_dir:
            pytest.fail("NETKF_BIN_DIR is set but %s does not exist" % path)
        pytest.skip("netkf_ros2_cdr_sample is not built (build/default/tests)")
    return path


def encoded(kind, values):
    r = subprocess.run([sample_binary(), kind, json.dumps(values)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return bytes.fromhex(r.stdout.strip())


def decoded(type_name, data):
    types = ros2msg.parse_definition("netkf_msgs/msg/" + type_name, msg_text(type_name))
    return ros2msg.decode(types, "netkf_msgs/" + type_name, data)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_an_estimate_from_the_recorder_decodes_to_its_values(seed):
    rng = random.Random(seed)
    n = rng.choice([1, 2, 3, 5])  # odd sizes leave the next field unaligned
    late = rng.randint(0, 3)
    e = {"k": rng.randrange(2 ** 64), "revision": rng.randrange(2 ** 32), "t": rng.uniform(-1e6, 1e6),
         "x_hat": [rng.uniform(-1e3, 1e3) for _ in range(n)], "P": [rng.gauss(0, 1) for _ in range(n * n)],
         "trace_P_pred": rng.uniform(0, 1e4), "fused": sorted(rng.sample(range(-1, 200), rng.randint(0, 5))),
         "late_sensors": [rng.randint(-2 ** 31, 2 ** 31 - 1) for _ in range(late)],
         "late_periods": [rng.randrange(2 ** 64) for _ in range(late)], "late_total": rng.randrange(2 ** 64),
         "rejected_total": rng.randrange(2 ** 64), "state": rng.choice(["ok", "diverging"]),
         "restarts": rng.randrange(2 ** 32), "fused_at_ns": rng.randint(-2 ** 63, 2 ** 63 - 1),
         "stamp_ns": rng.randint(-2 ** 63, 2 ** 63 - 1), "last_sample_stamp_ns": rng.randint(-2 ** 63, 2 ** 63 - 1)}
    data = encoded("estimate", e)
    assert data[:2] in (b"\x00\x01", b"\x00\x00")  # the encapsulation header of plain CDR
    m = decoded("Estimate", data)
    trace = 0.0
    for i in range(n):
        trace += e["P"][i * n + i]
    expected = {"k": e["k"], "t": e["t"], "x_hat": e["x_hat"], "p": e["P"], "fused": e["fused"], "late": late,
                "late_total": e["late_total"], "rejected_total": e["rejected_total"], "state": e["state"],
                "trace_p": trace, "fused_at_ns": e["fused_at_ns"], "stamp_ns": e["stamp_ns"],
                "last_sample_stamp_ns": e["last_sample_stamp_ns"], "trace_p_pred": e["trace_P_pred"],
                "late_sensors": e["late_sensors"], "restarts": e["restarts"], "run": 0,
                "late_periods": e["late_periods"], "revision": e["revision"]}
    assert m == expected


def test_a_truth_and_a_delivered_sample_from_the_recorder():
    t = {"k": 12345, "t": 0.5, "x": [1.5, -2.25, 3.0], "u": [0.125], "input_arrived": False}
    assert decoded("Truth", encoded("truth", t)) == {"k": 12345, "t": 0.5, "x": t["x"], "applied_input": [0.125],
                                                     "run": 0, "input_arrived": False}
    stamp_ns = 66123456789012  # a steady clock's ns (18 h after boot), as sensors stamp samples
    d = {"sensor_id": -7, "k": 99, "stamp": stamp_ns * 1e-9, "y": [0.1, 0.2]}
    m = decoded("Measurement", encoded("delivered", d))
    # The record keeps the stamp in seconds, the wire in ns: the recorder rounds back to them, exact
    # at a steady clock's magnitudes.
    assert m == {"sensor_id": -7, "k": 99, "stamp_ns": round(d["stamp"] * 1e9), "y": [0.1, 0.2], "run": 0}
    assert m["stamp_ns"] * 1e-9 == d["stamp"]




def test_big_endian_and_alignment():
    # Truth{k=3, t=0.25, x=[1.0], applied_input=[], run=7, input_arrived=true} big endian:
    body = struct.pack(">Qd", 3, 0.25)            # offset 0..16
    body += struct.pack(">I", 1) + b"\0" * 4      # sequence length at 16, pad to 24
    body += struct.pack(">d", 1.0)                # 24..32
    body += struct.pack(">I", 0) + b"\0" * 4      # empty applied_input at 32, pad to 40 for the uint64
    body += struct.pack(">Q", 7)                  # run at 40
    body += b"\x01"                               # input_arrived
    data = b"\x00\x00\x00\x00" + body
    assert decoded("Truth", data) == {"k": 3, "t": 0.25, "x": [1.0], "applied_input": [], "run": 7,
                                      "input_arrived": True}
    # The same little endian.
    le = b"\x00\x01\x00\x00" + struct.pack("<Qd", 3, 0.25) + struct.pack("<I", 1) + b"\0" * 4 + \
        struct.pack("<d", 1.0) + struct.pack("<I", 0) + b"\0" * 4 + struct.pack("<Q", 7) + b"\x01"
    assert decoded("Truth", le) == decoded("Truth", data)


def test_nested_types_and_strings():
    # LinkChange with its LinkSpec appended as rosbag2 does.
    text = msg_text("LinkChange") + "\n" + "=" * 80 + "\nMSG: netkf_msgs/LinkSpec\n" + msg_text("LinkSpec")
    types = ros2msg.parse_definition("netkf_msgs/msg/LinkChange", text)
    assert set(types) == {"netkf_msgs/LinkChange", "netkf_msgs/LinkSpec"}

    def s(v):
        raw = v.encode() + b"\0"
        return struct.pack("<I", len(raw)) + raw

    out = bytearray()

    def put(b, align=1):
        while len(out) % align:
            out.append(0)
        out.extend(b)

    put(struct.pack("<i", -1), 4)          # sensor_id
    put(struct.pack("<Q", 40), 8)          # at_period
    put(s("request"), 4)                   # origin
    put(struct.pack("<Q", 5), 8)           # request_id
    put(s("bernoulli"), 4)                 # link.model
    for v in (0.2, 0, 0, 0, 0, 10.0, 2.0):
        put(struct.pack("<d", v), 8)       # loss, p, r, loss_good, loss_bad, delay_ms, jitter_ms
    put(s("uniform"), 4)                   # delay_distribution
    put(s(""), 4)                          # trace
    put(b"\x00")                           # loop
    put(struct.pack("<Q", 0), 8)           # offset
    put(struct.pack("<q", -3), 8)          # stamp_ns
    put(s("rt/chatter"), 4)                # topic (a relayed topic's link)
    m = ros2msg.decode(types, "netkf_msgs/LinkChange", b"\x00\x01\x00\x00" + bytes(out))
    assert m == {"sensor_id": -1, "at_period": 40, "origin": "request", "request_id": 5,
                 "link": {"model": "bernoulli", "loss": 0.2, "p": 0.0, "r": 0.0, "loss_good": 0.0, "loss_bad": 0.0,
                          "delay_ms": 10.0, "jitter_ms": 2.0, "delay_distribution": "uniform", "trace": "",
                          "loop": False, "offset": 0},
                 "stamp_ns": -3, "topic": "rt/chatter"}


# ROS 2's rcl_interfaces/msg/Log and builtin_interfaces/msg/Time, written here from ROS 2's
# interface definitions (not taken from netkf), as rosbag2 concatenates them.
ROS2_LOG = """byte DEBUG=10
byte INFO=20
byte WARN=30
byte ERROR=40
byte FATAL=50
builtin_interfaces/Time stamp
uint8 level
string name
string msg
string file
string function
uint32 line
""" + "=" * 80 + """
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def test_an_event_as_a_ros2_log_message():
    text = "link 1: loss=0.2 (request 7) \u00e9"  # an odd length, and a character beyond ASCII
    data = encoded("log", {"stamp_ns": 3 * 10 ** 9 + 40 * 10 ** 6, "level": 30, "name": "netkf", "text": text})
    types = ros2msg.parse_definition("rcl_interfaces/msg/Log", ROS2_LOG)
    assert ros2msg.decode(types, "rcl_interfaces/Log", data) == {
        "stamp": {"sec": 3, "nanosec": 40000000}, "level": 30, "name": "netkf", "msg": text, "file": "",
        "function": "", "line": 0}


def test_bad_input_is_a_clear_error():
    good = encoded("truth", {"k": 1, "t": 0.1, "x": [1.0, 2.0], "u": [], "input_arrived": True})
    for cut in (0, 3, 10, len(good) - 1):
        with pytest.raises(ros2msg.Ros2MsgError):
            decoded("Truth", good[:cut])
    with pytest.raises(ros2msg.Ros2MsgError, match="encapsulation"):
        decoded("Truth", b"\x00\x07\x00\x00" + good[4:])  # XCDR2: not what ROS 2's CDR is
    huge = good[:20] + struct.pack("<I", 0x7fffffff) + good[24:]  # x claims 2^31 doubles
    with pytest.raises(ros2msg.Ros2MsgError):
        decoded("Truth", huge)
    with pytest.raises(ros2msg.Ros2MsgError, match="does not define"):
        ros2msg.parse_definition("netkf_msgs/msg/LinkChange", msg_text("LinkChange"))  # LinkSpec missing
    with pytest.raises(ros2msg.Ros2MsgError):
        ros2msg.parse_definition("netkf_msgs/msg/Truth", "uint64 k\nfloat64[ x\n")


def test_a_bag_of_other_types_is_a_format_error(tmp_path):
    """A ros2-profile file whose /netkf/truth is some other type: the period reader says so."""
    import netkf

    def record(op, body):
        return bytes([op]) + struct.pack("<Q", len(body)) + body

    def s(v):
        return struct.pack("<I", len(v)) + v.encode()

    magic = b"\x89MCAP0\r\n"
    body = record(0x01, s("ros2") + s("test"))
    body += record(0x03, struct.pack("<H", 1) + s("other_msgs/msg/Truth") + s("ros2msg") + s("uint64 k\n"))
    body += record(0x04, struct.pack("<HH", 0, 1) + s("/netkf/truth") + s("cdr") + struct.pack("<I", 0))
    body += record(0x05, struct.pack("<HIQQ", 0, 0, 0, 0) + b"\x00\x01\x00\x00" + struct.pack("<Q", 4))
    body += record(0x0F, struct.pack("<I", 0)) + record(0x02, struct.pack("<QQI", 0, 0, 0))
    path = tmp_path / "other.mcap"
    path.write_bytes(magic + body + magic)
    assert netkf.read_mcap(str(path)).decoded("/netkf/truth")[0][1] == {"k": 4}
    with pytest.raises(netkf.FormatError, match="not what netkf writes"):
        netkf.read_mcap_periods(str(path))
