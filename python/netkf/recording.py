"""Recordings of `netkf launch --record` / `netkf record --out` as pandas DataFrames.

The formats are docs/recording.md's (written by cli/recording/record_csv.cpp and
record_mcap.cpp). A CSV recording and an MCAP recording of the same run give equal frames:
read_periods(run.csv) and read_mcap_periods(run.mcap) have the same columns, dtypes and
values (the doubles are the same: the CSV writes 17 significant digits, read back exactly).

Period frame columns, one row per period k the plant ran, in order of k:
  k, t, x0..x{n-1} (truth), xhat0..xhat{n-1} (in-time estimate x̂_{k|k}), trace_P (Tr P_{k|k}),
  fused (tuple of the fused sensor ids), late (samples counted late in this estimate, Int64),
  state ('ok' / 'diverging', or 'none': no estimate of k was recorded), late_samples (tuple of
  (period, sensor id) of each late sample); with late_policy fuse_within also revisions (Int64),
  xhat_final0.., trace_P_final, fused_final; in a closed loop (plant.B) u0..u{m-1}: the
  input u_{k-1} the plant applied to produce x_k; with an actuation link (plant.control.link)
  nu last (bool: u_{k-1} reached the plant in time; in an MCAP the truth's input_arrived).
  A 'none' row holds the period's truth (and u) only: NaN in the estimate's floats, <NA> in
  late and revisions, () in fused, late_samples and fused_final. df[df.state != "none"] keeps
  the periods with an estimate.
Samples frame columns, one row per delivered sample:
  k, sensor_id, stamp, fused (bool), [fused_in_time (bool), with fuse_within], y0..y{m-1}
  (NaN past a sensor's own measurement size).
"""
import csv
import math
import re

import numpy as np
import pandas as pd

from .mcap import McapFile


class FormatError(ValueError):
    """A file that is not what netkf writes (names the file and what is wrong)."""


_BASE_TAIL = ["trace_P", "fused", "late", "state", "late_samples"]


# The state of a period whose estimate was never recorded (its row holds the truth only).
NO_ESTIMATE = "none"


def period_columns(n, fuse_within=False, input_dim=0, actuation_link=False):
    """The period CSV's header for state size n and input size m = input_dim
    (record_csv.cpp's PeriodCsvRecorder::header); with an actuation link (plant.control.link)
    it ends with nu (1 when u_{k-1} reached the plant in time, else 0)."""
    cols = ["k", "t"] + ["x%d" % i for i in range(n)] + _estimate_columns(n, fuse_within)
    return cols + ["u%d" % i for i in range(input_dim)] + (["nu"] if actuation_link else [])


def _estimate_columns(n, fuse_within):
    """The cells a period's estimate fills (empty in a `none` row), state included."""
    cols = ["xhat%d" % i for i in range(n)] + _BASE_TAIL
    if fuse_within:
        cols += ["revisions"] + ["xhat_final%d" % i for i in range(n)] + ["trace_P_final", "fused_final"]
    return cols


def _float_columns(columns):
    return [c for c in columns if c == "t" or c.startswith("trace_P") or re.fullmatch(r"(x|xhat|xhat_final|u)\d+", c)]


def _integer_columns(fuse_within):
    """Integers of the estimate (nullable: <NA> in a `none` row)."""
    return ["late"] + (["revisions"] if fuse_within else [])


def _ids(text):
    """'1;3' -> (1, 3); '' -> ()."""
    try:
        return tuple(int(v) for v in text.split(";") if v != "")
    except ValueError:
        raise ValueError("fused %r is not a list of sensor ids (ID;ID;...)" % text) from None


def _late_samples(text):
    """'29:1;29:3' -> ((29, 1), (29, 3))."""
    out = []
    for item in text.split(";"):
        if item == "":
            continue
        try:
            period, sensor = item.split(":")
            out.append((int(period), int(sensor)))
        except ValueError:
            raise ValueError("late_samples item %r is not PERIOD:SENSOR" % item) from None
    return tuple(out)


def _header(path):
    with open(path, newline="") as f:
        try:
            return next(csv.reader(f))
        except StopIteration:
            raise FormatError("%s: empty file (no header)" % path) from None
        except (UnicodeDecodeError, csv.Error) as e:
            raise FormatError("%s: not a CSV file (%s)" % (path, e)) from None


def _layout(path, header):
    """(n, fuse_within, m, actuation_link) of a period CSV's header, which must be exactly the
    writer's: the inputs u0..u{m-1} in order at its end, then nu with an actuation link."""
    n = sum(1 for c in header if re.fullmatch(r"x\d+", c))
    m = sum(1 for c in header if re.fullmatch(r"u\d+", c))
    actuation_link = bool(header) and header[-1] == "nu" and m > 0
    for fuse_within in (False, True):
        if header == period_columns(n, fuse_within, m, actuation_link):
            return n, fuse_within, m, actuation_link
    raise FormatError("%s: not a netkf period recording; its header is %s, expected %s" %
                      (path, ",".join(header), ",".join(period_columns(n, False, m))))


def _read_csv(path, converters, dtypes):
    try:
        # round_trip: the exact double of each 17-digit field (pandas' default parser can be
        # one ulp off), so a CSV and an MCAP of one run compare equal.
        return pd.read_csv(path, converters=converters, dtype=dtypes, float_precision="round_trip",
                           keep_default_na=False, na_values=["nan", "NaN", ""])
    except (ValueError, TypeError, pd.errors.ParserError) as e:
        raise FormatError("%s: %s" % (path, e)) from e


def _read_text(path):
    """Every cell as written (an empty cell is '', not NaN): what tells an empty cell from `nan`."""
    try:
        return pd.read_csv(path, dtype=str, keep_default_na=False, na_filter=False)
    except (ValueError, pd.errors.ParserError) as e:
        raise FormatError("%s: %s" % (path, e)) from e


def _check_cells(path, text, n, fuse_within, m):
    """The cells the parsed frame cannot tell apart: a `none` row has every estimate cell empty,
    any other row has the estimate's numbers (fused and late_samples may be empty lists), every
    row has its inputs, and integers are written as integers."""
    if len(text) == 0:
        return
    none = (text["state"] == NO_ESTIMATE).to_numpy()
    estimate = [c for c in _estimate_columns(n, fuse_within) if c != "state"]
    numbers = [c for c in estimate if c not in ("fused", "late_samples", "fused_final")]

    def refuse(row, what):
        raise FormatError("%s: line %d (period %s): %s" % (path, row + 2, text["k"].iloc[row], what))

    for c in estimate:
        filled = (text[c] != "").to_numpy() & none
        if filled.any():
            row = int(np.argmax(filled))
            refuse(row, "state %s (no estimate) but %s is %r: a none row has every estimate cell empty" %
                   (NO_ESTIMATE, c, text[c].iloc[row]))
    for c in numbers:
        empty = (text[c] == "").to_numpy() & ~none
        if empty.any():
            refuse(int(np.argmax(empty)), "%s is empty (only a row with state %s has no estimate)" % (c, NO_ESTIMATE))
    for c in ["u%d" % i for i in range(m)]:
        empty = (text[c] == "").to_numpy()
        if empty.any():
            refuse(int(np.argmax(empty)), "%s is empty (every row has the applied input)" % c)
    for c in ["k"] + _integer_columns(fuse_within):
        bad = ~text[c].str.fullmatch(r"-?[0-9]+").to_numpy() & (text[c] != "").to_numpy()
        if bad.any() or (c == "k" and (text[c] == "").any()):
            raise FormatError("%s: column %s holds values that are not integers" % (path, c))


def _check_numeric(path, df, columns, integer=()):
    if len(df) == 0:  # a header alone (stopped before the first period): nothing to check
        return
    for c in columns:
        if not pd.api.types.is_numeric_dtype(df[c]):
            raise FormatError("%s: column %s holds values that are not numbers" % (path, c))
    for c in integer:
        if df[c].isna().any() or not pd.api.types.is_integer_dtype(df[c]):
            raise FormatError("%s: column %s holds values that are not integers" % (path, c))


def read_periods(path):
    """A period CSV (`--record FILE.csv`) as a DataFrame (columns: the module's docstring), one
    row per period the plant ran, those without an estimate (state `none`) included.

    attrs: state_dim (n), fuse_within (whether the final-estimate columns are there),
    input_dim (m, 0 without plant.B), actuation_link (whether `nu` is there), path."""
    header = _header(path)
    n, fuse_within, m, actuation_link = _layout(path, header)
    _check_cells(path, _read_text(path), n, fuse_within, m)
    converters = {"fused": _ids, "late_samples": _late_samples}
    if fuse_within:
        converters["fused_final"] = _ids
    nullable = _integer_columns(fuse_within)
    dtypes = dict({"state": str}, **{c: "Int64" for c in nullable})
    df = _read_csv(path, converters, dtypes)
    floats = _float_columns(df.columns)
    _check_numeric(path, df, floats + ["k"], integer=["k"])
    for c in floats:
        df[c] = df[c].astype(np.float64)
    df["k"] = df["k"].astype(np.int64)
    for c in nullable:
        df[c] = df[c].astype("Int64")  # also when the file has no row (an empty column's dtype)
    df["state"] = df["state"].astype(str)
    if actuation_link:
        _check_numeric(path, df, ["nu"], integer=["nu"])
        if not df["nu"].isin([0, 1]).all():
            raise FormatError("%s: column nu holds values other than 0 and 1" % path)
        df["nu"] = df["nu"].astype(bool)
    _check_periods_increase(path, df["k"].tolist(), "line %d", 2)
    df.attrs.update(state_dim=n, fuse_within=fuse_within, input_dim=m, actuation_link=actuation_link, path=str(path))
    return df


def _check_periods_increase(path, ks, where, first):
    """A recording has one row (one truth, one in-time estimate) per period, in period order:
    a repeated or decreasing k is a damaged or concatenated file, not something to average."""
    for i in range(1, len(ks)):
        if ks[i] <= ks[i - 1]:
            raise FormatError("%s: period %d (%s) follows period %d: k must increase" %
                              (path, ks[i], where % (first + i), ks[i - 1]))


def read_samples(path):
    """A samples CSV (`--record-samples FILE`) as a DataFrame (module docstring).

    attrs: measurement_dim (m, the widest sensor's), fuse_within, path."""
    header = _header(path)
    fuse_within = header[:5] == ["k", "sensor_id", "stamp", "fused", "fused_in_time"]
    fixed = 5 if fuse_within else 4
    ys = header[fixed:]
    expected = ["k", "sensor_id", "stamp", "fused"] + (["fused_in_time"] if fuse_within else []) + \
        ["y%d" % i for i in range(len(ys))]
    if header != expected:
        raise FormatError("%s: not a netkf samples recording; its header is %s, expected %s" %
                          (path, ",".join(header), ",".join(expected)))
    df = _read_csv(path, None, None)
    flags = ["fused"] + (["fused_in_time"] if fuse_within else [])
    _check_numeric(path, df, ["stamp"] + ys + flags + ["k", "sensor_id"], integer=["k", "sensor_id"] + flags)
    for c in flags:
        if not df[c].isin([0, 1]).all():
            raise FormatError("%s: column %s holds values other than 0 and 1" % (path, c))
        df[c] = df[c].astype(bool)
    for c in ["stamp"] + ys:
        df[c] = df[c].astype(np.float64)
    for c in ["k", "sensor_id"]:
        df[c] = df[c].astype(np.int64)
    df.attrs.update(measurement_dim=len(ys), fuse_within=fuse_within, path=str(path))
    return df


# ---- MCAP --------------------------------------------------------------------------------

TRUTH = "netkf/truth"
ESTIMATE = "netkf/estimate"
DELIVERED = "netkf/measurement/delivered"
LINK_STATUS = "netkf/link/status"
LINK_CHANGE = "netkf/link/change"
CONTROL_LINK_ID = -1  # the actuation link (link `control`) where links are numbered (core/scenario.hpp)
# The ros2 profile (--mcap-profile ros2, docs/recording.md): the same records as CDR of the
# netkf_msgs types on the ROS 2 topic names; read here into the json profile's messages.
ROS2_TOPICS = {TRUTH: "/netkf/truth", ESTIMATE: "/netkf/estimate", DELIVERED: "/netkf/measurement/delivered",
               LINK_STATUS: "/netkf/link/status", LINK_CHANGE: "/netkf/link/change"}


def _from_ros2_truth(msg):
    out = {"k": msg["k"], "t": msg["t"], "x": msg["x"]}
    if msg["applied_input"]:  # a closed loop (the json profile writes u and input_arrived only then)
        out.update(u=msg["applied_input"], input_arrived=msg["input_arrived"])
    return out


def _from_ros2_estimate(msg):
    if len(msg["late_sensors"]) != len(msg["late_periods"]):
        raise FormatError("an estimate of period %d has %d late sensors but %d late periods"
                          % (msg["k"], len(msg["late_sensors"]), len(msg["late_periods"])))
    return {"k": msg["k"], "revision": msg["revision"], "x_hat": msg["x_hat"], "trace_P": msg["trace_p"],
            "fused": msg["fused"], "late": msg["late"], "state": msg["state"],
            "late_samples": [{"k": k, "sensor_id": s} for k, s in zip(msg["late_periods"], msg["late_sensors"])]}


def _from_ros2_delivered(msg):
    # The json profile's stamp is seconds, the wire's nanoseconds (the recorder's ns * 1e-9).
    return {"k": msg["k"], "sensor_id": msg["sensor_id"], "stamp": msg["stamp_ns"] * 1e-9, "y": msg["y"]}


_FROM_ROS2 = {TRUTH: _from_ros2_truth, ESTIMATE: _from_ros2_estimate, DELIVERED: _from_ros2_delivered,
              LINK_STATUS: dict, LINK_CHANGE: dict}


def _has_topic(m, topic):
    return topic in m.topics() or ROS2_TOPICS.get(topic) in m.topics()


def _topic_messages(m, topic):
    """(log_time ns, message) of netkf's channel `topic` in either profile: its JSON messages,
    or the ros2 profile's CDR messages in the json profile's form."""
    ros2 = ROS2_TOPICS.get(topic)
    if topic not in m.topics() and ros2 in m.topics():
        convert = _FROM_ROS2[topic]
        out = []
        for i, (t, msg) in enumerate(m.decoded(ros2)):
            try:
                out.append((t, convert(msg)))
            except (KeyError, TypeError) as e:  # a schema other than netkf_msgs' (a field missing)
                raise FormatError("%s: message %d on %s is not what netkf writes (%s: %s)"
                                  % (m.path, i, ros2, type(e).__name__, e)) from None
        return out
    return m.decoded(topic)


def read_mcap(path):
    """The MCAP file itself (netkf.mcap.McapFile): channels, schemas, raw and decoded messages."""
    return McapFile(path)


def read_mcap_topic(path_or_file, topic):
    """Every message of one channel as a DataFrame: log_time (ns) and the message's top-level
    fields (JSON, or a ros2 bag's CDR by its .msg names; arrays stay Python lists)."""
    m = path_or_file if isinstance(path_or_file, McapFile) else McapFile(path_or_file)
    rows = []
    for i, (t, msg) in enumerate(m.decoded(topic)):
        if not isinstance(msg, dict):
            raise FormatError("%s: message %d on %s is not a JSON object" % (m.path, i, topic))
        rows.append(dict(msg, log_time=t))
    return pd.DataFrame(rows)


def _int(v):
    if isinstance(v, bool) or not isinstance(v, int):
        raise ValueError("%r is not an integer" % (v,))
    return v


def _num(v):
    """A JSON number; null (how netkf writes a non-finite double) is NaN."""
    if v is None:
        return math.nan
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError("%r is not a number" % (v,))
    return float(v)


def _list(v):
    if not isinstance(v, list):
        raise ValueError("%r is not an array" % (v,))
    return v


def _str(v):
    if not isinstance(v, str):
        raise ValueError("%r is not a string" % (v,))
    return v


def _bool(v):
    if not isinstance(v, bool):
        raise ValueError("%r is not a boolean" % (v,))
    return v


def _truth(msg):
    """u (closed loop: the input u_{k-1} the plant applied to produce x_k) and input_arrived
    (closed loop: whether it reached the plant in time) are optional."""
    return {"k": _int(msg["k"]), "t": _num(msg["t"]), "x": [_num(v) for v in _list(msg["x"])],
            "u": [_num(v) for v in _list(msg["u"])] if "u" in msg else [],
            "input_arrived": _bool(msg["input_arrived"]) if "input_arrived" in msg else None}


def _estimate(msg):
    return {"k": _int(msg["k"]), "revision": _int(msg.get("revision", 0)),
            "x_hat": [_num(v) for v in _list(msg["x_hat"])], "trace_P": _num(msg["trace_P"]),
            "fused": tuple(_int(i) for i in _list(msg["fused"])), "late": _int(msg["late"]),
            "state": _str(msg["state"]),
            "late_samples": tuple((_int(s["k"]), _int(s["sensor_id"])) for s in _list(msg.get("late_samples", [])))}


def _delivered(msg):
    return {"k": _int(msg["k"]), "sensor_id": _int(msg["sensor_id"]), "stamp": _num(msg["stamp"]),
            "y": [_num(v) for v in _list(msg["y"])]}


def _parsed(m, topic, parse):
    """The messages of `topic`, each parsed into the fields netkf writes; a message without
    them (or with the wrong types) is a FormatError naming it."""
    out = []
    for i, (_, msg) in enumerate(_topic_messages(m, topic)):
        try:
            out.append(parse(msg))
        except (KeyError, TypeError, ValueError) as e:
            raise FormatError("%s: message %d on %s is not what netkf writes (%s: %s)" %
                              (m.path, i, topic, type(e).__name__, e)) from None
    return out


def _estimates(m):
    """k -> (in-time estimate, final estimate): the first revision 0 and the highest revision
    (as the CSV recorder keeps them). The in-time estimates come in period order."""
    in_time, final = {}, {}
    ordered = []
    for e in _parsed(m, ESTIMATE, _estimate):
        k = e["k"]
        if e["revision"] == 0:
            ordered.append(k)
            in_time.setdefault(k, e)
        if k not in final or e["revision"] >= final[k]["revision"]:
            final[k] = e
    _check_periods_increase(m.path, ordered, ESTIMATE + " revision 0, message %d", 0)
    return in_time, final


def _vector(path, what, k, values, n):
    if len(values) != n:
        raise FormatError("%s: %s of period %d has %d components, not %d" % (path, what, k, len(values), n))
    return values


def _reports_actuation_link(m):
    """Whether the recording's channel emulator reported the actuation link (sensor id -1): its
    link status, which the channel publishes from its start (so every recording of a run has
    one), or a change of it. The truth's input_arrived alone does not say so: every closed loop
    writes it, while the CSV has `nu` only with an actuation link."""
    for topic in (LINK_STATUS, LINK_CHANGE):
        if _has_topic(m, topic) and any(isinstance(msg, dict) and msg.get("sensor_id") == CONTROL_LINK_ID
                                        for _, msg in _topic_messages(m, topic)):
            return True
    return False


def read_mcap_periods(path, fuse_within=None, actuation_link=None):
    """The period frame of an MCAP recording: one row per netkf/truth message (in order of k),
    joined with the period's in-time estimate as the CSV recorder joins them; a period without
    one is a `none` row, an estimate without truth is left out. fuse_within: add the final
    columns (True), not (False), or only when an estimate was revised (None). The truth's `u`
    gives u0..u{m-1} (m from the first truth; every truth must carry the same size).
    actuation_link: add `nu` (the truth's input_arrived) last, as the CSV has it with an
    actuation link (True), not (False), or when the file's link messages name the actuation
    link (None)."""
    m = path if isinstance(path, McapFile) else McapFile(path)
    truth_list = _parsed(m, TRUTH, _truth)
    _check_periods_increase(m.path, [tr["k"] for tr in truth_list], TRUTH + " message %d", 0)
    in_time, final = _estimates(m)
    if fuse_within is None:
        fuse_within = any(e["revision"] > 0 for e in final.values())
    if actuation_link is None:
        actuation_link = _reports_actuation_link(m)
    n = len(truth_list[0]["x"]) if truth_list else 0
    inputs = len(truth_list[0]["u"]) if truth_list else 0
    if actuation_link and truth_list and inputs == 0:
        raise FormatError("%s: an actuation link, but the truth of period %d has no input u (an open loop)" %
                          (m.path, truth_list[0]["k"]))
    no_final = [pd.NA] + [math.nan] * n + [math.nan, ()]
    no_estimate = [math.nan] * n + [math.nan, (), pd.NA, NO_ESTIMATE, ()] + (no_final if fuse_within else [])
    rows = []
    for tr in truth_list:
        k = tr["k"]
        row = [k, tr["t"]] + _vector(m.path, "truth", k, tr["x"], n)
        e = in_time.get(k)
        if e is None:
            row += no_estimate
        else:
            row += _vector(m.path, "estimate", k, e["x_hat"], n)
            row += [e["trace_P"], e["fused"], e["late"], e["state"], e["late_samples"]]
            if fuse_within:
                f = final[k]
                row += [f["revision"]] + _vector(m.path, "final estimate", k, f["x_hat"], n)
                row += [f["trace_P"], f["fused"]]
        row += _vector(m.path, "truth's input u", k, tr["u"], inputs)
        if actuation_link:
            if tr["input_arrived"] is None:
                raise FormatError("%s: an actuation link, but the truth of period %d has no input_arrived" %
                                  (m.path, k))
            row.append(tr["input_arrived"])
        rows.append(row)
    df = pd.DataFrame(rows, columns=period_columns(n, fuse_within, inputs, actuation_link))
    df["k"] = df["k"].astype(np.int64)
    for c in _integer_columns(fuse_within):
        df[c] = df[c].astype("Int64")
    for c in _float_columns(df.columns):
        df[c] = df[c].astype(np.float64)
    df["state"] = df["state"].astype(str)
    if actuation_link:
        df["nu"] = df["nu"].astype(bool)  # also when the file has no truth (an empty column's dtype)
    df.attrs.update(state_dim=n, fuse_within=fuse_within, input_dim=inputs, actuation_link=bool(actuation_link),
                    path=str(m.path))
    return df


def read_mcap_samples(path, fuse_within=None):
    """The samples frame of an MCAP recording made with --record-samples (the
    netkf/measurement/delivered channel). `fused` is whether the sensor is in its period's
    final estimate, `fused_in_time` (fuse_within) in the in-time one, as in the samples CSV;
    rows in the file's order."""
    m = path if isinstance(path, McapFile) else McapFile(path)
    in_time, final = _estimates(m)
    if fuse_within is None:
        fuse_within = any(e["revision"] > 0 for e in final.values())
    msgs = _parsed(m, DELIVERED, _delivered)
    width = max((len(s["y"]) for s in msgs), default=0)
    rows = []
    for s in msgs:
        k, sid = s["k"], s["sensor_id"]
        row = [k, sid, s["stamp"], sid in final.get(k, {}).get("fused", ())]
        if fuse_within:
            row.append(sid in in_time.get(k, {}).get("fused", ()))
        rows.append(row + s["y"] + [math.nan] * (width - len(s["y"])))
    cols = ["k", "sensor_id", "stamp", "fused"] + (["fused_in_time"] if fuse_within else []) + \
        ["y%d" % i for i in range(width)]
    df = pd.DataFrame(rows, columns=cols)
    for c in ("k", "sensor_id"):
        df[c] = df[c].astype(np.int64)
    for c in ["fused"] + (["fused_in_time"] if fuse_within else []):
        df[c] = df[c].astype(bool)
    for c in ["stamp"] + cols[len(cols) - width:]:
        df[c] = df[c].astype(np.float64)
    df.attrs.update(measurement_dim=width, fuse_within=fuse_within, path=str(m.path))
    return df


# ---- helpers on a period frame -----------------------------------------------------------

def states(df, prefix="x"):
    """The (periods × n) array of x (truth), xhat or xhat_final; with prefix "u" the
    (periods × m) array of the applied inputs. A `none` row's estimate is NaN."""
    size = df.attrs.get("input_dim" if prefix == "u" else "state_dim")
    return df[["%s%d" % (prefix, i) for i in range(size or _count(df, prefix))]].to_numpy()


def _count(df, prefix):
    return sum(1 for c in df.columns if re.fullmatch(r"%s\d+" % prefix, c))


def fused_matrix(df, column="fused"):
    """A boolean frame, index k, one column per sensor id seen: whether the sensor was fused."""
    ids = sorted({i for f in df[column] for i in f})
    return pd.DataFrame({i: [i in f for f in df[column]] for i in ids}, index=df["k"].to_numpy())
