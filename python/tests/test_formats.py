"""The readers on hand-written files (python/tests/data): every column of the formats in
docs/recording.md, the values as written, and bad input refused with the file named."""
import json
import math
import os
import re
import struct
import zlib

import numpy as np
import pandas as pd
import pytest

import netkf
from netkf import mcap


def data(data_dir, name):
    return os.path.join(data_dir, name)


# ---- period CSV --------------------------------------------------------------------------

def test_period_csv_with_fuse_within_columns(data_dir):
    df = netkf.read_periods(data(data_dir, "periods_fuse_within.csv"))
    assert df.attrs["state_dim"] == 3 and df.attrs["fuse_within"]
    assert list(df.columns) == ["k", "t", "x0", "x1", "x2", "xhat0", "xhat1", "xhat2", "trace_P", "fused", "late",
                                "state", "late_samples", "revisions", "xhat_final0", "xhat_final1", "xhat_final2",
                                "trace_P_final", "fused_final"]
    assert df["k"].tolist() == [0, 1, 2] and df["k"].dtype == np.int64
    assert df["fused"].tolist() == [(3,), (), (1, 3, 12)]
    assert df["fused_final"].tolist() == [(3,), (12,), (1, 3, 12)]
    assert df["late_samples"].tolist() == [(), ((0, 1), (0, 12)), ()]
    assert df["late"].tolist() == [0, 2, 0] and df["revisions"].tolist() == [0, 1, 2]
    assert df["state"].tolist() == ["ok", "ok", "diverging"]
    # Exact doubles, the non-finite spellings of format_double, subnormal and extreme values.
    assert df.loc[1, "x0"] == 0.1 and df.loc[1, "xhat0"] == 0.09999999999999999
    assert df.loc[2, "x0"] == math.inf and df.loc[2, "x1"] == -math.inf and math.isnan(df.loc[2, "x2"])
    assert df.loc[2, "xhat0"] == 1e-300 and df.loc[2, "xhat1"] == -2.2250738585072014e-308
    assert df.loc[2, "xhat2"] == 1.7976931348623157e308 and df.loc[2, "trace_P"] == 12345.678901234567
    assert netkf.states(df, "xhat_final").tolist() == [[0.5, -0.25, 0.0], [0.1, 1.95, 2.9], [1.0, 2.0, 3.0]]
    m = netkf.fused_matrix(df, "fused_final")
    assert list(m.columns) == [1, 3, 12] and m.loc[1].tolist() == [False, False, True]


@pytest.mark.parametrize("name,why", [
    ("periods_bad_header.csv", "not a netkf period recording"),
    ("periods_bad_value.csv", "xhat0"),
    ("periods_bad_row.csv", "periods_bad_row.csv"),
    ("periods_bad_late.csv", "PERIOD:SENSOR"),
])
def test_bad_period_csv_is_refused_naming_the_file(data_dir, name, why):
    with pytest.raises(netkf.FormatError) as e:
        netkf.read_periods(data(data_dir, name))
    assert name in str(e.value) and why in str(e.value)


def test_empty_and_headerless_files(tmp_path):
    p = tmp_path / "empty.csv"
    p.write_text("")
    with pytest.raises(netkf.FormatError, match="empty"):
        netkf.read_periods(p)
    p.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples\n")
    assert len(netkf.read_periods(p)) == 0  # a recording stopped before its first period
    q = tmp_path / "fused.csv"
    q.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples\n0,0,1,1,1,1;x,0,ok,\n")
    with pytest.raises(netkf.FormatError, match="sensor id"):
        netkf.read_periods(q)


# ---- periods without an estimate (state none) and the applied input u ------------------------

def estimate_cells_are_empty(row, n, fuse_within):
    """What a `none` row holds in the estimate's columns (docs/python.md)."""
    cells = ["xhat%d" % i for i in range(n)] + ["trace_P"] + \
        (["xhat_final%d" % i for i in range(n)] + ["trace_P_final"] if fuse_within else [])
    return all(math.isnan(row[c]) for c in cells) and row["late"] is pd.NA and row["fused"] == () and \
        row["late_samples"] == () and (not fuse_within or (row["revisions"] is pd.NA and row["fused_final"] == ()))


def test_period_csv_rows_without_estimate_open_loop(data_dir):
    df = netkf.read_periods(data(data_dir, "periods_none.csv"))
    assert df.attrs["state_dim"] == 2 and not df.attrs["fuse_within"] and df.attrs["input_dim"] == 0
    assert list(df.columns) == ["k", "t", "x0", "x1", "xhat0", "xhat1", "trace_P", "fused", "late", "state",
                                "late_samples"]
    assert df["k"].tolist() == [0, 1, 2, 3] and df["k"].dtype == np.int64
    assert df["state"].tolist() == ["ok", "none", "diverging", "none"]
    assert str(df["late"].dtype) == "Int64" and df["xhat0"].dtype == np.float64
    # The truth of a period without an estimate is kept, value for value.
    assert df["x0"].tolist()[:3] == [1.0, 1.25, 1.5] and df.loc[3, "t"] == 0.03
    assert math.isnan(df.loc[3, "x0"]) and df.loc[3, "x1"] == math.inf
    assert estimate_cells_are_empty(df.loc[1], 2, False) and estimate_cells_are_empty(df.loc[3], 2, False)
    assert df["fused"].tolist() == [(1, 3), (), (2,), ()]
    assert df["late_samples"].tolist() == [(), (), ((1, 3),), ()]
    assert int(df["late"].sum()) == 1  # <NA> is skipped, not counted as a number
    est = df[df.state != "none"]  # the one-liner docs/python.md gives
    assert est["k"].tolist() == [0, 2] and est["late"].tolist() == [0, 1]
    assert netkf.states(est, "xhat").tolist() == [[0.5, -0.25], [1.25, -0.125]]
    assert netkf.fused_matrix(df).loc[1].tolist() == [False, False, False]


def test_period_csv_closed_loop_fuse_within_rows_without_estimate(data_dir):
    df = netkf.read_periods(data(data_dir, "periods_closed_loop_fuse_within.csv"))
    assert df.attrs["state_dim"] == 1 and df.attrs["fuse_within"] and df.attrs["input_dim"] == 2
    assert list(df.columns) == ["k", "t", "x0", "xhat0", "trace_P", "fused", "late", "state", "late_samples",
                                "revisions", "xhat_final0", "trace_P_final", "fused_final", "u0", "u1"]
    assert df["u0"].dtype == np.float64 and df["u1"].dtype == np.float64
    assert df["state"].tolist() == ["none", "ok", "ok", "none"]
    assert estimate_cells_are_empty(df.loc[0], 1, True) and estimate_cells_are_empty(df.loc[3], 1, True)
    assert str(df["revisions"].dtype) == "Int64" and df["revisions"].tolist()[1:3] == [1, 0]
    assert df["fused_final"].tolist() == [(), (1, 2), (), ()] and df["xhat_final0"].tolist()[1:3] == [1.25, 2.0]
    # The input is in every row, those without an estimate too; exact doubles.
    assert df["u0"].tolist() == [0.0, -0.5, -1.7976931348623157e308, 0.0]
    assert df["u1"].tolist() == [0.0, 0.25, 5e-324, 0.0]
    est = df[df.state != "none"]
    assert (est["revisions"] > 0).tolist() == [True, False]


# The writer's own expected output (tests/unit/cli_recording/test_record_csv.cpp, PeriodCsv.TruthWithoutEstimateIsARowInOrder
# and PeriodCsv.ClosedLoopRowsCarryTheAppliedInput), read back.
@pytest.mark.parametrize("text,states,inputs", [
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples\n0,0,1,0.5,1,1,0,ok,\n1,0.01,2,,,,,none,\n"
     "2,0.02,3,,,,,none,\n3,0.029999999999999999,4,3.5,1,1,0,ok,\n", ["ok", "none", "none", "ok"], []),
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,u1\n0,0,1,,,,,none,,0,0\n1,0.01,2,1.5,1,,0,ok,,-0.5,0.25\n",
     ["none", "ok"], [[0.0, 0.0], [-0.5, 0.25]]),
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,revisions,xhat_final0,trace_P_final,fused_final,u0\n"
     "0,0,1,,,,,none,,,,,,0\n", ["none"], [[0.0]]),
])
def test_period_csv_as_the_writer_writes_it(tmp_path, text, states, inputs):
    p = tmp_path / "p.csv"
    p.write_text(text)
    df = netkf.read_periods(p)
    assert df["state"].tolist() == states and df.attrs["input_dim"] == (len(inputs[0]) if inputs else 0)
    assert netkf.states(df, "u").tolist() == inputs if inputs else "u0" not in df.columns
    for i in df.index[df.state == "none"]:
        assert estimate_cells_are_empty(df.loc[i], 1, df.attrs["fuse_within"])


NONE_ROW = "k,t,x0,xhat0,trace_P,fused,late,state,late_samples\n0,0,1,0.5,1,1,0,ok,\n%s\n"
FW_HEADER = "k,t,x0,xhat0,trace_P,fused,late,state,late_samples,revisions,xhat_final0,trace_P_final,fused_final,u0\n"


@pytest.mark.parametrize("text,why", [
    # A none row with any estimate cell filled: not what the writer writes.
    (NONE_ROW % "1,0.01,2,0.5,,,,none,", r"line 3 \(period 1\): state none .* xhat0 is '0.5'"),
    (NONE_ROW % "1,0.01,2,nan,,,,none,", r"line 3 \(period 1\): state none .* xhat0 is 'nan'"),
    (NONE_ROW % "1,0.01,2,,1,,,none,", "trace_P is '1'"),
    (NONE_ROW % "1,0.01,2,,,3,,none,", "fused is '3'"),
    (NONE_ROW % "1,0.01,2,,,,0,none,", "late is '0'"),
    (NONE_ROW % "1,0.01,2,,,,,none,0:1", "late_samples is '0:1'"),
    (FW_HEADER + "0,0,1,,,,,none,,0,,,,0\n", "revisions is '0'"),
    (FW_HEADER + "0,0,1,,,,,none,,,1,,,0\n", "xhat_final0 is '1'"),
    (FW_HEADER + "0,0,1,,,,,none,,,,,2,0\n", "fused_final is '2'"),
    # A row with an estimate has its numbers (only a none row has empty ones).
    (NONE_ROW % "1,0.01,2,,1,,0,ok,", r"line 3 \(period 1\): xhat0 is empty"),
    (NONE_ROW % "1,0.01,2,1,1,,,ok,", "late is empty"),
    (NONE_ROW % "1,0.01,2,1,1,,,,", "late is empty"),
    (FW_HEADER + "0,0,1,1,1,,0,ok,,,1,1,,0\n", "revisions is empty"),
    (NONE_ROW % "1,0.01,2,1,1,,1.0,ok,0:1", "column late holds values that are not integers"),
    (FW_HEADER + "0,0,1,1,1,,0,ok,,0.5,1,1,,0\n", "column revisions holds values that are not integers"),
    # Inputs: u0..u{m-1} in order, last, in every row.
    (FW_HEADER + "0,0,1,,,,,none,,,,,,\n", "u0 is empty"),
    (FW_HEADER + "0,0,1,,,,,none,,,,,,x\n", "u0 holds values that are not numbers"),
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u1\n0,0,1,,,,,none,,0\n", "not a netkf period recording"),
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,u2\n0,0,1,,,,,none,,0,0\n", "not a netkf period recording"),
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u1,u0\n0,0,1,,,,,none,,0,0\n", "not a netkf period recording"),
    ("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,revisions,xhat_final0,trace_P_final,fused_final\n",
     "not a netkf period recording"),
    ("k,t,u0,x0,xhat0,trace_P,fused,late,state,late_samples\n", "not a netkf period recording"),
], ids=range(22))
def test_malformed_period_csv_rows_are_refused(tmp_path, text, why):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(netkf.FormatError, match="bad.csv: .*" + why):
        netkf.read_periods(p)


def test_period_frames_have_one_dtype_with_and_without_none_rows(data_dir, tmp_path):
    """`late`, `revisions` are Int64 whether or not a period lacks its estimate, so frames of two
    recordings (or a CSV and an MCAP) compare and concatenate."""
    p = tmp_path / "p.csv"
    p.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples\n0,0,1,0.5,1,1,0,ok,\n")
    assert str(netkf.read_periods(p)["late"].dtype) == "Int64"
    assert str(netkf.read_periods(data(data_dir, "periods_fuse_within.csv"))["revisions"].dtype) == "Int64"
    p.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0\n")
    empty = netkf.read_periods(p)
    assert len(empty) == 0 and str(empty["late"].dtype) == "Int64" and empty.attrs["input_dim"] == 1


# ---- samples CSV -------------------------------------------------------------------------

def test_samples_csv_with_two_measurement_sizes(data_dir):
    s = netkf.read_samples(data(data_dir, "samples_fuse_within.csv"))
    assert list(s.columns) == ["k", "sensor_id", "stamp", "fused", "fused_in_time", "y0", "y1"]
    assert s.attrs == {"measurement_dim": 2, "fuse_within": True, "path": data(data_dir, "samples_fuse_within.csv")}
    assert s["fused"].tolist() == [True, False, True] and s["fused_in_time"].tolist() == [True, False, False]
    assert s["y0"].tolist() == [-0.036672748747188261, 1.5, 0.25]
    assert math.isnan(s.loc[0, "y1"]) and s.loc[1, "y1"] == 2.5  # a 1-dim sensor leaves y1 empty
    assert s.loc[0, "stamp"] == 36026.622009531005


def test_bad_samples_csv(tmp_path):
    p = tmp_path / "s.csv"
    p.write_text("k,sensor_id,stamp,fused,y0\n0,1,0.5,2,1\n")
    with pytest.raises(netkf.FormatError, match="other than 0 and 1"):
        netkf.read_samples(p)
    p.write_text("k,sensor,stamp,fused,y0\n")
    with pytest.raises(netkf.FormatError, match="not a netkf samples recording"):
        netkf.read_samples(p)


# ---- summary -----------------------------------------------------------------------------

def test_summary_flattened_like_check_names(tmp_path):
    s = {"scenario": "x", "end": "duration reached", "periods": 10, "rms_error": 0.5, "rms_error_final": 0.5,
         "mean_trace_P": None, "link": {"10": {"late": 1, "observed_loss": None}, "2": {"late": 0}},
         "checks": [{"check": "rms_error<1", "name": "rms_error", "operator": "<", "threshold": 1, "value": 0.5,
                     "verdict": "PASS"}], "passed": True}
    p = tmp_path / "s.json"
    p.write_text(json.dumps(s))
    flat = netkf.summary_series(str(p))
    assert flat["periods"] == 10 and math.isnan(flat["mean_trace_P"])
    assert [k for k in flat.index if k.startswith("link.")] == ["link.2.late", "link.10.late", "link.10.observed_loss"]
    assert flat["link.10.late"] == 1 and math.isnan(flat["link.10.observed_loss"])
    assert netkf.checks_frame(str(p)).loc[0, "verdict"] == "PASS"
    assert netkf.read_summaries([str(p), str(p)]).shape[0] == 2
    p.write_text("[1, 2]")
    with pytest.raises(netkf.FormatError, match="not a netkf run summary"):
        netkf.read_summary(str(p))
    p.write_text("{")
    with pytest.raises(netkf.FormatError, match="not JSON"):
        netkf.read_summary(str(p))


# ---- MCAP: files built here from the specification's byte layout --------------------------

def record(opcode, content):
    return bytes([opcode]) + struct.pack("<Q", len(content)) + content


def string(s):
    b = s.encode()
    return struct.pack("<I", len(b)) + b


def schema(sid, name):
    return record(0x03, struct.pack("<H", sid) + string(name) + string("jsonschema") + string('{"type":"object"}'))


def channel(cid, sid, topic, meta=None):
    entries = b"".join(string(k) + string(v) for k, v in (meta or {}).items())
    return record(0x04, struct.pack("<HH", cid, sid) + string(topic) + string("json") +
                  struct.pack("<I", len(entries)) + entries)


def message(cid, seq, t, obj):
    return record(0x05, struct.pack("<HIQQ", cid, seq, t, t) + json.dumps(obj).encode())


def chunk(records, crc=None, compression=""):
    # The spec's Chunk: ..., compression String, records uint64 length-prefixed Bytes
    return record(0x06, struct.pack("<QQQI", 0, 0, len(records), zlib.crc32(records) if crc is None else crc) +
                  string(compression) + struct.pack("<Q", len(records)) + records)


HEADER = mcap.MAGIC + record(0x01, string("") + string("test"))
FOOTER = record(0x0F, struct.pack("<I", 0)) + record(0x02, struct.pack("<QQI", 0, 0, 0)) + mcap.MAGIC


def write(tmp_path, body, name="t.mcap"):
    p = tmp_path / name
    p.write_bytes(body)
    return str(p)


def test_mcap_chunks_metadata_and_unknown_records(tmp_path):
    inner = channel(1, 1, "b") + message(1, 0, 5, {"v": 2})
    body = HEADER + schema(1, "S") + channel(0, 1, "a", {"k": "v"}) + message(0, 0, 10, {"v": 1}) + \
        record(0x0C, b"\x00" * 7) + chunk(inner) + message(0, 1, 20, {"v": 3}) + FOOTER
    m = netkf.read_mcap(write(tmp_path, body))
    assert m.complete and not m.truncated and m.header == {"profile": "", "library": "test"}
    assert m.topics() == ["a", "b"] and m.channels[0].metadata == {"k": "v"}
    assert m.counts() == {"a": 2, "b": 1}
    assert m.decoded("a") == [(10, {"v": 1}), (20, {"v": 3})] and m.decoded("b") == [(5, {"v": 2})]
    assert netkf.read_mcap_topic(m, "a")["v"].tolist() == [1, 3]


def test_mcap_cut_anywhere_keeps_the_whole_records(tmp_path):
    """Every prefix of a file (what kill -9 may leave) reads as its whole records; `truncated`
    says a record (or the closing magic) was cut, `complete` only for the whole file."""
    parts = [HEADER, schema(1, "S"), channel(0, 1, "a")] + [message(0, i, i, {"i": i}) for i in range(5)] + [FOOTER]
    full = b"".join(parts)
    ends = np.cumsum([len(p) for p in parts])
    message_ends = ends[3:8]
    # A clean stop between records: after any record up to DataEnd (after the Footer, the
    # closing magic is missing: cut).
    boundaries = set(ends[:-1].tolist()) | {int(ends[-2]) + len(record(0x0F, struct.pack("<I", 0)))}
    for cut in range(len(HEADER), len(full) + 1):
        m = netkf.read_mcap(write(tmp_path, full[:cut]))
        assert len(m.messages) == int((message_ends <= cut).sum()), cut
        assert m.complete == (cut == len(full)), cut
        assert m.truncated == (cut not in boundaries and cut != len(full)), cut


@pytest.mark.parametrize("body,why", [
    (b"\x89MCAX0\r\n", "magic"),
    (HEADER + message(0, 0, 0, {}) + FOOTER, "no Channel record"),
    (HEADER + channel(0, 7, "a") + FOOTER, "schema 7"),
    (HEADER + schema(1, "S") + chunk(channel(0, 1, "a"), crc=1) + FOOTER, "CRC"),
    (HEADER + record(0x03, b"\x01\x00\xff\xff\xff\xff") + FOOTER, "shorter than its fields"),
    (HEADER + FOOTER + b"junk", "closing magic"),
    (HEADER + schema(1, "S") + chunk(channel(0, 1, "a"), compression="bz2") + FOOTER, "compression 'bz2'"),
    (HEADER + chunk(record(0x09, b"")) + FOOTER, "holds a Attachment record"),
    (HEADER + chunk(channel(0, 0, "a") + b"\x05\x00") + FOOTER, "ends inside a record"),
    (mcap.MAGIC + schema(1, "S") + FOOTER, "not a Header"),
    (HEADER + record(0x01, string("") + string("again")) + FOOTER, "second Header"),
    (HEADER + record(0x00, b"") + FOOTER, "opcode 0x00"),
    (HEADER + record(0x0B, b"") + FOOTER, "Statistics record in the data section"),
    (HEADER + record(0x0F, struct.pack("<I", 0)) + message(0, 0, 0, {}) + FOOTER, "Message record after Data End"),
    # A closed file (Footer and magic at its end) whose last message claims more bytes than
    # remain: damage, where the same bytes without the footer would be a cut.
    (HEADER + schema(1, "S") + channel(0, 1, "a") + b"\x05" + struct.pack("<Q", 1 << 40) + b"{}" + FOOTER,
     "runs past the footer"),
    (HEADER + FOOTER[:-len(mcap.MAGIC) - 29] + record(0x02, struct.pack("<QQI", 5, 0, 0)) + mcap.MAGIC,
     "summary_start"),
], ids=lambda v: v if isinstance(v, str) else "file")
def test_bad_mcap_is_refused(tmp_path, body, why):
    with pytest.raises(netkf.McapError, match=why):
        netkf.read_mcap(write(tmp_path, body))


def data_end_and_footer(body, crc=True):
    """Data End (with the CRC of `body`, or 0) and Footer, for a file that begins with `body`."""
    return record(0x0F, struct.pack("<I", zlib.crc32(body) if crc else 0)) + \
        record(0x02, struct.pack("<QQI", 0, 0, 0)) + mcap.MAGIC


def test_mcap_data_section_crc(tmp_path):
    body = HEADER + schema(1, "S") + channel(0, 1, "a") + message(0, 0, 10, {"v": 1})
    assert netkf.read_mcap(write(tmp_path, body + data_end_and_footer(body))).decoded("a") == [(10, {"v": 1})]
    changed = body.replace(b'{"v": 1}', b'{"v": 2}')
    with pytest.raises(netkf.McapError, match="data section fails its CRC"):
        netkf.read_mcap(write(tmp_path, changed + data_end_and_footer(body)))
    assert netkf.read_mcap(write(tmp_path, changed + data_end_and_footer(body, crc=False))).decoded("a") == \
        [(10, {"v": 2})]  # CRC 0: not computed, as netkf writes it


def test_mcap_message_that_is_not_json(tmp_path):
    body = HEADER + schema(1, "S") + channel(0, 1, "a") + record(0x05, struct.pack("<HIQQ", 0, 0, 0, 0) + b"{x") + FOOTER
    with pytest.raises(netkf.McapError, match="not JSON"):
        netkf.read_mcap(write(tmp_path, body)).decoded("a")


# ---- sweep -------------------------------------------------------------------------------

def test_sweep_fixture(data_dir):
    s = netkf.read_sweep(data(data_dir, "sweep-sinopoli"))
    assert s.varied == ["sensors.1.link.loss"] and s.seeds == 3 and s.mode == "offline"
    assert len(s.runs) == 24 and len(s.points) == 8
    assert s.quantities[:4] == ["periods", "rms_error", "rms_error_final", "mean_trace_P"]
    assert "link.1.observed_loss" in s.quantities
    assert s.points["theory_stable"].tolist() == [True] * 7 + [False]
    st = s.stats("mean_trace_P")
    assert list(st.columns[:3]) == ["point", "sensors.1.link.loss", "seeds"]
    # points.csv's spread equals the spread recomputed from runs.csv
    for q in ("mean_trace_P", "rms_error", "link.1.observed_loss"):
        agg = s.aggregate(q)
        st = s.stats(q).set_index("point")
        for c in ("mean", "se", "min", "max"):
            assert np.allclose(agg[c], st[c], rtol=1e-12, atol=0), (q, c)
    assert s.stats("pipeline_latency_p50_ms")["mean"].isna().all()  # not measured offline
    with pytest.raises(KeyError):
        s.stats("no_such_quantity")


def copy_sweep(data_dir, tmp_path):
    d = tmp_path / "sweep"
    d.mkdir()
    for n in ("runs.csv", "points.csv", "sweep.yaml"):
        (d / n).write_text(open(data(data_dir, os.path.join("sweep-sinopoli", n))).read())
    return d


@pytest.mark.parametrize("file,old,new,why", [
    ("sweep.yaml", "key: sensors.1.link.loss", "key: sensors.2.link.loss", "header starts"),
    ("points.csv", "theory_trace_V_bar,", "theory_V,", "columns missing: theory_trace_V_bar"),
    ("points.csv", "\n7,0.69999999999999996,", "\n7,0.75,", "not among sweep.yaml's values"),
    ("points.csv", ",false,", ",maybe,", "not true/false"),
    ("runs.csv", "\n0,1,0,ok,300,", "\n9,1,0,ok,300,", r"points \[9\]"),
    ("runs.csv", "\n0,1,0,ok,300,0.8", "\n0,1,0,ok,300,x0.8", "rms_error"),
    ("sweep.yaml", "vary:", "varied:", "`vary` must be"),
])
def test_bad_sweep_is_refused(data_dir, tmp_path, file, old, new, why):
    d = copy_sweep(data_dir, tmp_path)
    text = (d / file).read_text()
    assert old in text
    (d / file).write_text(text.replace(old, new, 1))
    with pytest.raises(netkf.FormatError, match=why):
        netkf.read_sweep(d)


def test_missing_sweep_file(data_dir, tmp_path):
    d = copy_sweep(data_dir, tmp_path)
    (d / "points.csv").unlink()
    with pytest.raises(netkf.FormatError, match="points.csv: missing"):
        netkf.read_sweep(d)


# ---- periods in order ------------------------------------------------------------------------

PERIOD_HEADER = "k,t,x0,xhat0,trace_P,fused,late,state,late_samples\n"


@pytest.mark.parametrize("ks,why", [([0, 1, 1, 2], r"period 1 \(line 4\) follows period 1"),
                                    ([0, 2, 1], r"period 1 \(line 4\) follows period 2")])
def test_period_csv_with_repeated_or_decreasing_k_is_refused(tmp_path, ks, why):
    p = tmp_path / "p.csv"
    p.write_text(PERIOD_HEADER + "".join("%d,%g,1,1,1,,0,ok,\n" % (k, k * 0.01) for k in ks))
    with pytest.raises(netkf.FormatError, match="p.csv: " + why + ": k must increase"):
        netkf.read_periods(p)
    p.write_text(PERIOD_HEADER + "".join("%d,%g,1,1,1,,0,ok,\n" % (k, k * 0.01) for k in sorted(set(ks))))
    assert netkf.read_periods(p)["k"].tolist() == sorted(set(ks))


def estimate(k, revision=0, trace_P=1.0):
    return {"k": k, "revision": revision, "t": k * 0.01, "x_hat": [0.5], "P": [1.0], "fused": [1], "late": 0,
            "late_samples": [], "state": "ok", "trace_P": trace_P}


def netkf_mcap(tmp_path, truths, estimates):
    """truths: periods (x = [1.0]) or the truth messages themselves."""
    body = HEADER + schema(1, "S") + channel(0, 1, "netkf/truth") + channel(1, 1, "netkf/estimate")
    truths = [t if isinstance(t, dict) else {"k": t, "t": t * 0.01, "x": [1.0]} for t in truths]
    body += b"".join(message(0, i, t["k"], t) for i, t in enumerate(truths))
    body += b"".join(message(1, i, i, e) for i, e in enumerate(estimates))
    return write(tmp_path, body + FOOTER)


@pytest.mark.parametrize("truths,ks,why", [
    ([0, 1, 1], [0, 1], "netkf/truth message 2"),
    ([0, 2, 1], [0, 1, 2], "netkf/truth message 2"),
    ([0, 1, 2], [0, 1, 1], "netkf/estimate revision 0, message 2"),
    ([0, 1, 2], [1, 0, 2], "netkf/estimate revision 0, message 1"),
])
def test_mcap_periods_repeated_or_decreasing_are_refused(tmp_path, truths, ks, why):
    with pytest.raises(netkf.FormatError, match="period . \\(%s\\) follows period .: k must increase" % why):
        netkf.read_mcap_periods(netkf_mcap(tmp_path, truths, [estimate(k) for k in ks]))


def test_mcap_periods_revisions_and_null_trace(tmp_path):
    """Revisions of earlier periods come after later in-time estimates (fuse_within); a
    non-finite trace is written as null."""
    es = [estimate(0), estimate(1, trace_P=None), estimate(0, revision=1, trace_P=0.5), estimate(2)]
    df = netkf.read_mcap_periods(netkf_mcap(tmp_path, [0, 1, 2], es))
    assert df["k"].tolist() == [0, 1, 2] and df["revisions"].tolist() == [1, 0, 0]
    assert math.isnan(df.loc[1, "trace_P"]) and df["trace_P_final"].tolist()[0] == 0.5


@pytest.mark.parametrize("change,why", [
    (lambda e: e.pop("x_hat"), "KeyError: 'x_hat'"),
    (lambda e: e.update(k="1"), "'1' is not an integer"),
    (lambda e: e.update(fused=3), "3 is not an array"),
    (lambda e: e.update(trace_P="big"), "'big' is not a number"),
    (lambda e: e.update(late_samples=[[1, 2]]), "TypeError"),
])
def test_mcap_estimate_without_its_fields_is_refused(tmp_path, change, why):
    e = estimate(1)
    change(e)
    with pytest.raises(netkf.FormatError, match="message 1 on netkf/estimate is not what netkf writes.*" +
                       re.escape(why)):
        netkf.read_mcap_periods(netkf_mcap(tmp_path, [0, 1], [estimate(0), e]))


def test_mcap_truth_without_estimate_and_with_input(tmp_path):
    """Every truth is a row (the CSV recorder's join): one without an in-time estimate is a none
    row, an estimate without truth is left out; the truth's u gives u0..u{m-1}. The CSV the
    writer makes of the same records reads as an equal frame."""
    truths = [{"k": 0, "t": 0.0, "x": [1.0], "u": [0.0, 0.0]}, {"k": 1, "t": 0.01, "x": [2.0], "u": [-0.5, 0.25]},
              {"k": 2, "t": 0.02, "x": [3.0], "u": [0.1, None]}]
    es = [dict(estimate(1), x_hat=[1.5], late=1, late_samples=[{"k": 0, "sensor_id": 1}]), estimate(3)]
    df = netkf.read_mcap_periods(netkf_mcap(tmp_path, truths, es))
    assert df["k"].tolist() == [0, 1, 2] and df["state"].tolist() == ["none", "ok", "none"]
    assert df.attrs["input_dim"] == 2 and list(df.columns[-2:]) == ["u0", "u1"]
    assert df["u0"].tolist() == [0.0, -0.5, 0.1] and df["u1"].tolist()[:2] == [0.0, 0.25]
    assert math.isnan(df.loc[2, "u1"])  # null: a non-finite double
    assert estimate_cells_are_empty(df.loc[0], 1, False) and estimate_cells_are_empty(df.loc[2], 1, False)
    csv = tmp_path / "same.csv"
    csv.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,u1\n0,0,1,,,,,none,,0,0\n"
                   "1,0.01,2,1.5,1,1,1,ok,0:1,-0.5,0.25\n2,0.02,3,,,,,none,,0.10000000000000001,nan\n")
    from_csv = netkf.read_periods(csv)
    df.attrs = from_csv.attrs = {}
    pd.testing.assert_frame_equal(df, from_csv, check_exact=True)
    # fuse_within: the final columns of a none row are empty too.
    fw = netkf.read_mcap_periods(netkf_mcap(tmp_path, truths, es), fuse_within=True)
    assert estimate_cells_are_empty(fw.loc[0], 1, True) and fw["revisions"].tolist()[1] == 0
    assert str(fw["revisions"].dtype) == "Int64"
    # Open loop: no u in the truth, no u column.
    plain = netkf.read_mcap_periods(netkf_mcap(tmp_path, [0, 1], [estimate(0)]))
    assert plain.attrs["input_dim"] == 0 and "u0" not in plain.columns and plain["state"].tolist() == ["ok", "none"]


def netkf_mcap_with_links(tmp_path, truths, estimates, link_messages, name="links.mcap"):
    """netkf_mcap's records and the channel's link messages: (topic, message) pairs on
    netkf/link/status or netkf/link/change."""
    body = HEADER + schema(1, "S") + channel(0, 1, "netkf/truth") + channel(1, 1, "netkf/estimate")
    body += channel(2, 1, "netkf/link/status") + channel(3, 1, "netkf/link/change")
    body += b"".join(message(0, i, t["k"], t) for i, t in enumerate(truths))
    body += b"".join(message(1, i, i, e) for i, e in enumerate(estimates))
    cid = {"netkf/link/status": 2, "netkf/link/change": 3}
    body += b"".join(message(cid[topic], i, 0, msg) for i, (topic, msg) in enumerate(link_messages))
    return write(tmp_path, body + FOOTER, name)


ARRIVAL_TRUTHS = [{"k": 0, "t": 0.0, "x": [1.0], "u": [0.0], "input_arrived": True},
                  {"k": 1, "t": 0.01, "x": [2.0], "u": [-0.5], "input_arrived": True},
                  {"k": 2, "t": 0.02, "x": [3.0], "u": [0.0], "input_arrived": False}]
CONTROL_STATUS = ("netkf/link/status", {"sensor_id": -1, "model": "bernoulli", "loss": 0.15})
SENSOR_STATUS = ("netkf/link/status", {"sensor_id": 1, "model": "bernoulli", "loss": 0.1})


def test_mcap_input_arrived_is_the_csvs_nu(tmp_path):
    """With an actuation link (the channel reports link control, sensor id -1) the truth's
    input_arrived is the frame's nu, last, as the CSV the writer makes of the same records
    (record_csv.cpp: nu 1/0 after u0) reads: equal frames, attrs included."""
    es = [estimate(0), dict(estimate(1), x_hat=[1.5])]
    df = netkf.read_mcap_periods(netkf_mcap_with_links(tmp_path, ARRIVAL_TRUTHS, es, [SENSOR_STATUS, CONTROL_STATUS]))
    assert list(df.columns[-2:]) == ["u0", "nu"] and df["nu"].tolist() == [True, True, False]
    assert df["nu"].dtype == bool and df.attrs["actuation_link"] is True
    csv = tmp_path / "same.csv"
    csv.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0,nu\n0,0,1,0.5,1,1,0,ok,,0,1\n"
                   "1,0.01,2,1.5,1,1,0,ok,,-0.5,1\n2,0.02,3,,,,,none,,0,0\n")
    from_csv = netkf.read_periods(csv)
    assert from_csv.attrs["actuation_link"] is True
    for frame in (df, from_csv):
        frame.attrs.pop("path")
    pd.testing.assert_frame_equal(df, from_csv, check_exact=True)
    assert df.attrs == from_csv.attrs
    # A change of the control link names it too (a recording that joined late may lack its first status).
    change = ("netkf/link/change", {"sensor_id": -1, "at_period": 1, "origin": "request", "model": "bernoulli",
                                    "loss": 0.5})
    by_change = netkf.read_mcap_periods(netkf_mcap_with_links(tmp_path, ARRIVAL_TRUTHS, es, [change], "c.mcap"))
    assert by_change["nu"].tolist() == [True, True, False]


def test_mcap_input_arrived_without_actuation_link(tmp_path):
    """Every closed loop's truth carries input_arrived, but the CSV has nu only with an
    actuation link: without the channel reporting link control the frame has no nu (unless
    asked for), and the frame equals the CSV's without the column."""
    plain_file = netkf_mcap_with_links(tmp_path, ARRIVAL_TRUTHS, [estimate(0)], [SENSOR_STATUS])
    plain = netkf.read_mcap_periods(plain_file)
    assert plain.columns[-1] == "u0" and plain.attrs["actuation_link"] is False
    csv = tmp_path / "plain.csv"
    csv.write_text("k,t,x0,xhat0,trace_P,fused,late,state,late_samples,u0\n0,0,1,0.5,1,1,0,ok,,0\n"
                   "1,0.01,2,,,,,none,,-0.5\n2,0.02,3,,,,,none,,0\n")
    from_csv = netkf.read_periods(csv)
    plain.attrs = from_csv.attrs = {}
    pd.testing.assert_frame_equal(plain, from_csv, check_exact=True)
    forced = netkf.read_mcap_periods(plain_file, actuation_link=True)
    assert forced["nu"].tolist() == [True, True, False]
    assert "nu" not in netkf.read_mcap_periods(
        netkf_mcap_with_links(tmp_path, ARRIVAL_TRUTHS, [], [CONTROL_STATUS], "c.mcap"), actuation_link=False).columns


@pytest.mark.parametrize("second,why", [
    ({"k": 1, "t": 0.01, "x": [2.0], "u": [0.5]}, "an actuation link, but the truth of period 1 has no input_arrived"),
    ({"k": 1, "t": 0.01, "x": [2.0], "u": [0.5], "input_arrived": 1}, "1 is not a boolean"),
    ({"k": 1, "t": 0.01, "x": [2.0], "u": [0.5], "input_arrived": "yes"}, "'yes' is not a boolean"),
])
def test_mcap_truth_without_its_input_arrived_is_refused(tmp_path, second, why):
    truths = [ARRIVAL_TRUTHS[0], second]
    with pytest.raises(netkf.FormatError, match=re.escape(why)):
        netkf.read_mcap_periods(netkf_mcap_with_links(tmp_path, truths, [], [CONTROL_STATUS]))


def test_mcap_actuation_link_of_an_open_loop_is_refused(tmp_path):
    with pytest.raises(netkf.FormatError, match="an actuation link, but the truth of period 0 has no input u"):
        netkf.read_mcap_periods(netkf_mcap_with_links(tmp_path, [{"k": 0, "t": 0.0, "x": [1.0]}], [],
                                                      [CONTROL_STATUS]))


@pytest.mark.parametrize("u1,why", [(None, "truth's input u of period 1 has 0 components, not 1"),
                                    ([1.0, 2.0], "truth's input u of period 1 has 2 components, not 1"),
                                    ("x", "message 1 on netkf/truth is not what netkf writes")])
def test_mcap_truth_inputs_of_different_sizes_are_refused(tmp_path, u1, why):
    second = {"k": 1, "t": 0.01, "x": [1.0]}
    if u1 is not None:
        second["u"] = u1
    with pytest.raises(netkf.FormatError, match=re.escape(why)):
        netkf.read_mcap_periods(netkf_mcap(tmp_path, [{"k": 0, "t": 0.0, "x": [1.0], "u": [0.0]}, second], []))
