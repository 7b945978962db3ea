"""The reader against files written by the real launch (conftest.py's `live` fixture).

Independent expectations: the launch's own summary (computed in C++ from the estimates it
received), a second recording of the same run in the other format (an attached `netkf
record`), a second MCAP implementation (@mcap/core, tests/e2e/mcap_read.mjs), and the scenario's
control gain (the input the plant applied is -L times the previous period's estimate).

Every scenario here is a closed loop (plant.B with one column): the period frames end with u0,
and a period the plant ran without an estimate recorded (e.g. its last, when the run ended
first) is a `none` row; the summary's quantities are over the periods with an estimate.
"""
import math
import os
import shutil
import subprocess
import json

import numpy as np
import pandas as pd
import pytest
import yaml

import netkf
from conftest import REPO


def path(live, run, name):
    return os.path.join(live[run]["dir"], name)


def rms(df, prefix):
    e = netkf.states(df, "x") - netkf.states(df, prefix)
    return math.sqrt(float(np.mean(np.sum(e * e, axis=1))))


def close(a, b):
    return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-15)


def with_estimate(df):
    return df[df.state != "none"]  # the one-liner of docs/python.md


def truth_columns(df):
    return ["k", "t"] + [c for c in df.columns if c[0] in "xu" and c[1:].isdigit()]


@pytest.mark.parametrize("run", ["csv", "late", "loop"])
def test_csv_rows_are_the_summarys_periods_from_period_0(live, run):
    df = netkf.read_periods(path(live, run, "R.csv"))
    summary = netkf.read_summary(path(live, run, "J.json"))
    assert summary["periods"] > 50
    assert len(with_estimate(df)) == summary["periods"]  # the summary counts the estimates
    assert df["k"].iloc[0] == 0 and df["k"].is_monotonic_increasing and df["k"].is_unique
    assert np.allclose(df["t"], df["k"] * 0.01, rtol=0, atol=1e-9)  # period_ms 10 in every scenario
    # plant.B has one column: u0 ends each row, 0 at period 0 (no input before the first period).
    assert df.attrs["input_dim"] == 1 and df.columns[-1] == "u0" and df["u0"].iloc[0] == 0.0
    # How many inputs arrive in time depends on the load (a starved run had half of them 0).
    assert df["u0"].notna().all() and (df["u0"] != 0).any()


@pytest.mark.parametrize("run", ["csv", "late", "loop"])
def test_summary_quantities_recomputed_from_the_csv(live, run):
    df = with_estimate(netkf.read_periods(path(live, run, "R.csv")))
    s = netkf.read_summary(path(live, run, "J.json"))
    assert close(rms(df, "xhat"), s["rms_error"])
    final = "xhat_final" if df.attrs["fuse_within"] else "xhat"
    assert close(rms(df, final), s["rms_error_final"])
    assert close(df["trace_P"].mean(), s["mean_trace_P"])
    assert int((df["state"] == "diverging").sum()) == s["periods_diverging"]
    sensors = sorted(s["link"], key=int)
    fused = netkf.fused_matrix(df)
    assert close(fused.to_numpy().sum() / (len(df) * len(sensors)), s["fused_fraction"])
    late_by_sensor = {}
    for samples in df["late_samples"]:
        for _, sensor in samples:
            late_by_sensor[sensor] = late_by_sensor.get(sensor, 0) + 1
    for lid in sensors:
        assert int(fused[int(lid)].sum()) == s["link"][lid]["fused"], "link %s fused" % lid
        assert late_by_sensor.get(int(lid), 0) == s["link"][lid]["late"], "link %s late" % lid
    assert (df["late"] == df["late_samples"].map(len)).all()
    delivered = sum(s["link"][lid]["delivered"] for lid in sensors)
    assert close(df["late"].sum() / delivered, s["late_fraction"])


def test_late_fusion_columns(live):
    df = netkf.read_periods(path(live, "late", "R.csv"))
    assert df.attrs["fuse_within"] and df.attrs["state_dim"] == 1
    df = with_estimate(df)  # a none row has <NA> revisions, which a mask cannot take
    revised = df[df["revisions"] > 0]
    assert len(revised) > 0, "a fuse_within run over a link delayed by 0-20 ms at 10 ms revises some periods"
    # A revision only adds samples; an unrevised period repeats the in-time estimate.
    assert all(set(a) <= set(b) for a, b in zip(df["fused"], df["fused_final"]))
    plain = df[df["revisions"] == 0]
    assert (plain["xhat_final0"] == plain["xhat0"]).all() and (plain["fused_final"] == plain["fused"]).all()
    # Some revision fused a late sample into its own period (a revision of a later period, re-run
    # from an earlier one, keeps its fused set).
    assert (revised["fused_final"].map(len) > revised["fused"].map(len)).any()
    assert (df["fused_final"].map(len) > df["fused"].map(len)).sum() <= len(revised)


def attached_and_launch(live, run):
    """(attached recorder's period frame, launch's period frame) of one run, in the two formats."""
    launch_name, attached_name = ("R.mcap", "A.csv") if run == "mcap" else ("R.csv", "A.mcap")
    def read(name, fuse_within=None):
        p = path(live, run, name)
        return netkf.read_periods(p) if name.endswith(".csv") else netkf.read_mcap_periods(p, fuse_within)
    launch = read(launch_name, run == "late")
    attached = read(attached_name, run == "late")
    return attached, launch


@pytest.mark.parametrize("run", ["csv", "mcap", "late", "loop"])
def test_csv_and_mcap_of_one_run_are_equal_frames(live, run):
    """The attached recorder (started once the launch recorded its first period) holds a
    stretch of the run: every one of its periods is the launch's, the same doubles (truth,
    input and, from its first estimate on, the estimate; before that it may have a period's
    truth whose estimate was published before it subscribed)."""
    attached, launch = attached_and_launch(live, run)
    assert len(attached) >= 10 and set(attached["k"]) <= set(launch["k"])
    assert attached.attrs["input_dim"] == launch.attrs["input_dim"] == 1
    same = launch.set_index("k").loc[attached["k"]].reset_index()
    same.attrs = attached.attrs = {}
    truth = truth_columns(attached)
    pd.testing.assert_frame_equal(attached[truth], same[truth], check_exact=True)
    estimated = (attached["state"] != "none").to_numpy()
    assert estimated.sum() >= 10
    first = int(np.argmax(estimated))
    pd.testing.assert_frame_equal(attached.iloc[first:].reset_index(drop=True),
                                  same.iloc[first:].reset_index(drop=True), check_exact=True)


def test_launch_mcap_samples_equal_its_samples_csv(live):
    m = netkf.read_mcap_samples(path(live, "mcap", "R.mcap"), fuse_within=False)
    s = netkf.read_samples(path(live, "mcap", "S.csv"))
    assert len(m) > 50
    key = ["k", "sensor_id"]
    m.attrs = s.attrs = {}
    pd.testing.assert_frame_equal(s.sort_values(key).reset_index(drop=True), m.sort_values(key).reset_index(drop=True),
                                  check_exact=True)


@pytest.mark.parametrize("run", ["csv", "late"])
def test_attached_samples_csv_and_mcap_are_the_launchs(live, run):
    """The attached recorder's samples, from its MCAP and its CSV, are equal, and each is the
    launch's sample of that (period, sensor) after its first period with an estimate (before, and
    in that one, it may have seen a sample but not the estimate that says whether it was fused)."""
    fuse_within = run == "late"
    key = ["k", "sensor_id"]
    m = netkf.read_mcap_samples(path(live, run, "A.mcap"), fuse_within=fuse_within)
    a = netkf.read_samples(path(live, run, "AS.csv"))
    assert len(m) >= 10 and a.attrs["fuse_within"] == fuse_within
    m = m.sort_values(key).reset_index(drop=True)
    a = a.sort_values(key).reset_index(drop=True)
    m.attrs = a.attrs = {}
    pd.testing.assert_frame_equal(a, m, check_exact=True)
    launch = netkf.read_samples(path(live, run, "S.csv"))
    launch.attrs = {}
    first = with_estimate(netkf.read_mcap_periods(path(live, run, "A.mcap")))["k"].min()
    mine = a[a["k"] > first].reset_index(drop=True)
    theirs = launch.merge(mine[key], on=key).sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(mine, theirs, check_exact=True)


@pytest.mark.parametrize("run", ["csv", "late"])
def test_samples_fused_flags_are_the_periods_fused_sets(live, run):
    df = netkf.read_periods(path(live, run, "R.csv"))
    s = netkf.read_samples(path(live, run, "S.csv"))
    final = "fused_final" if df.attrs["fuse_within"] else "fused"
    by_k = s[s["fused"]].groupby("k")["sensor_id"].apply(lambda ids: tuple(sorted(ids)))
    assert len(by_k) > 50
    expected = df.set_index("k")[final]
    assert all(by_k[k] == tuple(sorted(expected[k])) for k in by_k.index if k in expected.index)
    assert all(expected[k] == () for k in expected.index if k not in by_k.index)
    if df.attrs["fuse_within"]:
        in_time = s[s["fused_in_time"]].groupby("k")["sensor_id"].apply(lambda ids: tuple(sorted(ids)))
        assert all(in_time[k] == tuple(sorted(df.set_index("k")["fused"][k])) for k in in_time.index
                   if k in expected.index)


def test_mcap_periods_are_the_summarys_periods(live):
    m = netkf.read_mcap(path(live, "mcap", "R.mcap"))
    s = netkf.read_summary(path(live, "mcap", "J.json"))
    assert m.complete and not m.truncated
    assert m.header == {"profile": "", "library": "netkf"}
    estimates = netkf.read_mcap_topic(m, "netkf/estimate")
    assert int((estimates["revision"] == 0).sum()) == s["periods"]
    frame = netkf.read_recording(path(live, "mcap", "R.mcap"))  # by the extension
    assert frame["k"].iloc[0] == 0 and frame["k"].is_monotonic_increasing
    assert len(frame) == len(netkf.read_mcap_topic(m, "netkf/truth"))  # a row per truth
    frame = with_estimate(frame)
    assert len(frame) == s["periods"]
    assert close(rms(frame, "xhat"), s["rms_error"]) and close(frame["trace_P"].mean(), s["mean_trace_P"])
    assert (estimates["log_time"] == (estimates["t"] * 1e9).round().astype(np.int64)).all()


def mcap_core(mcap_path):
    """@mcap/core's reading of the file (tests/e2e/mcap_read.mjs), or a skip when Node.js or
    the package is missing outside ctest."""
    node = shutil.which("node")
    if not node or not os.path.isdir(os.path.join(REPO, "node_modules", "@mcap", "core")):
        if os.environ.get("NETKF_BIN_DIR"):
            pytest.fail("node and node_modules/@mcap/core are needed (scripts/deps.sh installs them)")
        pytest.skip("node or node_modules/@mcap/core missing")
    r = subprocess.run([node, os.path.join(REPO, "tests", "e2e", "mcap_read.mjs"), mcap_path], cwd=REPO,
                       capture_output=True, text=True, timeout=120)
    return json.loads(r.stdout)


@pytest.mark.parametrize("cut", [False, True])
def test_mcap_reader_agrees_with_mcap_core(live, tmp_path, cut):
    src = path(live, "mcap", "R.mcap")
    if cut:  # what kill -9 leaves: no footer, the last record cut short
        with open(src, "rb") as f:
            data = f.read()
        src = str(tmp_path / "cut.mcap")
        with open(src, "wb") as f:
            f.write(data[:len(data) * 2 // 3 + 5])
    theirs = mcap_core(src)
    assert theirs["problems"] == []
    mine = netkf.read_mcap(src)
    assert mine.complete == theirs["complete"] == (not cut)
    assert mine.truncated == cut
    assert mine.header == theirs["header"]
    assert [(c.id, c.topic, mine.schemas[c.schema_id].name, mine.schemas[c.schema_id].encoding, c.message_encoding)
            for c in mine.channels.values()] == \
        [(c["id"], c["topic"], c["schemaName"], c["schemaEncoding"], c["messageEncoding"]) for c in theirs["channels"]]
    assert mine.counts() == theirs["counts"]
    ours = [{"k": e["k"], "t": e["t"], "x_hat": e["x_hat"], "trace_P": e["trace_P"], "log_time": str(t)}
            for t, e in mine.decoded("netkf/estimate")]
    assert ours == theirs["estimates"]


def test_damaged_launch_mcap_is_an_error_and_a_cut_one_is_not(live, tmp_path):
    """The launch's MCAP with one record's length in its middle set to 2^40: the file still
    ends with its Footer and magic, so it is damaged (netkf trace extract refuses it too),
    not a recording with half its periods. Cut at that record instead, it reads up to the cut."""
    with open(path(live, "mcap", "R.mcap"), "rb") as f:
        data = f.read()
    whole = netkf.read_mcap_periods(path(live, "mcap", "R.mcap"))
    pos, starts = len(netkf.mcap.MAGIC), []
    while pos < len(data) - len(netkf.mcap.MAGIC):
        starts.append(pos)
        pos += 9 + int.from_bytes(data[pos + 1:pos + 9], "little")
    middle = starts[len(starts) // 2]
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(data[:middle + 1] + (1 << 40).to_bytes(8, "little") + data[middle + 9:])
    with pytest.raises(netkf.McapError, match="runs past the footer"):
        netkf.read_mcap_periods(str(damaged))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:middle + 5])
    m = netkf.read_mcap(str(cut))
    assert m.truncated and not m.complete
    frame = netkf.read_mcap_periods(m)
    assert 0 < len(frame) < len(whole)
    same = whole.iloc[:len(frame)].reset_index(drop=True)
    frame.attrs = same.attrs = {}
    # The cut may fall between the last periods' truth and their estimates: those read as none.
    kept = int(frame.index[frame["state"] != "none"].max()) + 1
    assert kept > 0
    pd.testing.assert_frame_equal(frame.iloc[:kept], same.iloc[:kept], check_exact=True)
    truth = truth_columns(frame)
    pd.testing.assert_frame_equal(frame[truth], same[truth], check_exact=True)


@pytest.mark.parametrize("run,name", [("loop", "R.csv"), ("loop", "A.mcap"), ("late", "R.csv"), ("late", "A.mcap")])
def test_applied_input_is_minus_L_times_the_previous_estimate(live, run, name):
    """u0 of period k is the input u_{k-1} = -L x̂_{k-1|k-1} the plant applied (certainty
    equivalence with the scenario's gain L), or 0 where no input arrived in time: exactly, as the
    estimator computes it (-L times a double) and the recording keeps every double."""
    scenario_path = live[run]["launch"][2]
    with open(scenario_path) as f:
        gain = yaml.safe_load(f)["plant"]["control"]["gain"]
    assert len(gain) == 1 and len(gain[0]) == 1, "a scalar gain, so -L x̂ is one multiplication"
    L = float(gain[0][0])
    p = path(live, run, name)
    df = netkf.read_periods(p) if name.endswith(".csv") else netkf.read_mcap_periods(p)
    assert df.attrs["input_dim"] == 1
    rows = df.to_dict("records")
    checked = 0
    for prev, row in zip(rows, rows[1:]):
        if row["k"] != prev["k"] + 1 or prev["state"] == "none" or row["u0"] == 0.0:
            continue
        assert row["u0"] == -L * prev["xhat0"], "period %d: u0 %r, -L x̂ of period %d %r" % (
            row["k"], row["u0"], prev["k"], -L * prev["xhat0"])
        checked += 1
    # Not vacuous; how many inputs arrive in time depends on the load, so no fraction is asked
    # (a run starved of CPU still had ~100 of 220).
    assert checked >= 10
