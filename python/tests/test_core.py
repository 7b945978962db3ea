"""The core's Python bindings (netkf._core through netkf/theory.py, docs/python.md "The core in
Python") against independent expectations: the `netkf` command's JSON on every shipped scenario
and trace, closed forms (Sinopoli Thm 3 and 4, the scalar Markov criterion), the NumPy-made sweep
fixture's theory columns, statsmodels' Kalman filter on runs with partial losses, and seeded
loss traces whose chain is known.

ctest runs this file as `python_core` with NETKF_CORE_DIR (the tree's module) and NETKF_BIN_DIR
set: there a missing module or binary fails; by hand, without them, this file skips.
"""
import glob
import json
import math
import os
import subprocess
import threading

import numpy as np
import pytest
import yaml

from conftest import DATA, REPO, netkf_binary
import netkf
from netkf import theory

if os.environ.get("NETKF_CORE_DIR"):  # for the example's subprocess, which runs elsewhere
    os.environ["NETKF_CORE_DIR"] = os.path.abspath(os.environ["NETKF_CORE_DIR"])
if theory._core is None:
    if os.environ.get("NETKF_CORE_DIR"):
        raise ImportError("NETKF_CORE_DIR is set but netkf._core does not import: %s" % theory._CORE_ERROR)
    pytest.skip("netkf._core is not built (scripts/build.sh builds it)", allow_module_level=True)

SCENARIOS = sorted(glob.glob(os.path.join(REPO, "deploy", "scenarios", "*.yaml")))
SCALAR = os.path.join(REPO, "deploy", "scenarios", "sinopoli-scalar.yaml")
TRACE = os.path.join(REPO, "deploy", "traces", "example-gilbert-elliott.csv")


def cli_json(*args):
    r = subprocess.run([netkf_binary(), *args, "--json"], capture_output=True, text=True, timeout=300, cwd=REPO)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def plain(value):
    """The bindings' result as JSON would hold it (numpy arrays as lists)."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def assert_same(got, want, where="", rel=1e-12):
    """Equal structure, strings and bools; numbers to `rel` (relative, absolute below 1)."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and set(got) == set(want), "%s: keys %s != %s" % (where, sorted(got), sorted(want))
        for k in want:
            assert_same(got[k], want[k], "%s.%s" % (where, k), rel)
    elif isinstance(want, list):
        assert isinstance(got, list) and len(got) == len(want), "%s: %r != %r" % (where, got, want)
        for i, (g, w) in enumerate(zip(got, want)):
            assert_same(g, w, "%s[%d]" % (where, i), rel)
    elif isinstance(want, bool) or want is None or isinstance(want, str):
        assert got == want, "%s: %r != %r" % (where, got, want)
    else:
        assert isinstance(got, (int, float)) and not isinstance(got, bool), "%s: %r is not a number" % (where, got)
        assert abs(got - want) <= rel * max(1.0, abs(want)), "%s: %r != %r" % (where, got, want)


# ---- every binding against the command's JSON ----

@pytest.mark.parametrize("path", SCENARIOS, ids=os.path.basename)
def test_analyze_equals_the_commands_json(path):
    assert_same(plain(netkf.analyze(path)), cli_json("analyze", path), os.path.basename(path))


def test_analyze_with_its_flags_equals_the_commands_json():
    fig5 = os.path.join(REPO, "deploy", "scenarios", "liu-goldsmith-fig5.yaml")
    assert_same(plain(netkf.analyze(fig5, region=True, points=5, lmi=False)),
                cli_json("analyze", fig5, "--region", "--points", "5", "--no-lmi"))
    assert_same(plain(netkf.analyze(SCALAR, sweep=True, points=11)), cli_json("analyze", SCALAR, "--sweep", "--points", "11"))
    boundary = os.path.join(REPO, "deploy", "scenarios", "actuation-boundary.yaml")
    assert_same(plain(netkf.analyze(boundary, region=True, points=4)),
                cli_json("analyze", boundary, "--region", "--points", "4"))


@pytest.mark.parametrize("path", SCENARIOS, ids=os.path.basename)
def test_critical_rate_and_markov_criterion_equal_analyze(path):
    report = cli_json("analyze", path)
    if report["critical_rate"] is not None:  # shared Bernoulli links: analyze() reports them
        got = netkf.critical_rate(path)
        assert_same(plain({k: got[k] for k in report["critical_rate"]}), report["critical_rate"])
    markov = netkf.markov_criterion(path)
    if report["markov_criterion"] is None:
        assert not markov["applies"]
    else:
        assert markov["applies"]
        assert_same(markov["value"], report["markov_criterion"])
        assert markov["stable"] == (markov["value"] < 1)


def test_bounds_equal_the_commands_sweep():
    for path in (SCALAR, os.path.join(REPO, "deploy", "scenarios", "liu-goldsmith-case1.yaml")):
        sweep = cli_json("analyze", path, "--sweep", "--points", "11")["sweep"]
        lower, upper = netkf.bounds(path, np.linspace(0, 1, 11))
        for p, s, v in zip(sweep, lower, upper):
            assert_same(None if math.isnan(s) else float(s), p["lower_trace"])
            assert_same(None if math.isnan(v) else float(v), p["upper_trace"])


def test_simulate_equals_the_commands_json():
    for path in (SCALAR, os.path.join(REPO, "deploy", "scenarios", "default.yaml")):
        want = cli_json("simulate", path, "--runs", "300", "--steps", "120", "--seed", "7", "--threads", "2")
        got = netkf.simulate(path, runs=300, steps=120, seed=7, threads=2)
        series = got.pop("series")
        assert_same(plain(got), want)
        # the per-step means: one per step, the last one the result's
        assert list(series["step"]) == list(range(120))
        assert series["mean_trace_P_pred"][-1] == pytest.approx(want["mean_trace_P_pred"], rel=1e-12)
        assert series["mean_sq_error_pred"][-1] == pytest.approx(want["mean_sq_error_pred"], rel=1e-12)
        # deterministic whatever the thread count
        one = netkf.simulate(path, runs=300, steps=120, seed=7, threads=1, series=False)
        assert_same(plain(one), want)


def test_fit_equals_the_commands_json(tmp_path):
    want = cli_json("fit", TRACE)
    assert_same(plain(netkf.fit(TRACE)), want)
    assert_same(plain(netkf.fit(TRACE, model="gilbert")), cli_json("fit", TRACE, "--model", "gilbert"))
    # the same arrivals as an array: the fit the command makes of a trace file of them alone
    delivered = np.loadtxt(TRACE, delimiter=",", skiprows=3, usecols=1, comments="#").astype(np.uint8)
    arrivals_only = os.path.join(tmp_path, "arrivals.csv")
    with open(arrivals_only, "w") as f:
        f.write("k,delivered\n" + "".join("%d,%d\n" % (k, d) for k, d in enumerate(delivered)))
    got = plain(netkf.fit(delivered.astype(bool)))
    want = cli_json("fit", arrivals_only)
    assert got.pop("trace") == "<array>" and want.pop("trace") == arrivals_only
    assert_same(got, want)


# ---- closed forms and independent computations ----

def test_scalar_closed_forms():
    # Sinopoli Sec. IV: A = -1.25, so lambda_c = 1 - 1/A^2 = 0.36 exactly, the LMI's bound with it
    rates = netkf.critical_rate(SCALAR)
    assert rates["lower"] == pytest.approx(0.36, abs=1e-15)
    assert rates["exact"] == pytest.approx(0.36, abs=1e-9)
    assert rates["upper"] == pytest.approx(0.36, abs=1e-4)
    # scalar Bernoulli link: the criterion is A^2 (1 - lambda)
    for rate in (0.3, 0.5, 0.9):
        assert netkf.markov_criterion(SCALAR, rate)["value"] == pytest.approx(1.5625 * (1 - rate), rel=1e-12)
    # V-bar is the fixed point of g_lambda (Sinopoli eq. 17); S-bar = Q / (1 - (1 - lambda) A^2) (Thm 4)
    lam = np.array([0.37, 0.6, 0.95])
    lower, upper = netkf.bounds(SCALAR, lam)
    assert lower == pytest.approx(1.0 / (1 - (1 - lam) * 1.5625), rel=1e-12)
    for v, l in zip(upper, lam):
        assert v == pytest.approx(1.5625 * v + 1 - l * 1.5625 * v * v / (v + 2.5), rel=1e-9)
    # below the critical rate both diverge
    below = netkf.bounds(SCALAR, [0.2])
    assert math.isnan(below[0][0]) and math.isnan(below[1][0])


def test_bounds_equal_the_numpy_sweep_fixture():
    # python/tests/data/sweep-sinopoli: theory columns written by NumPy from the scalar closed forms
    points = netkf.read_sweep(os.path.join(DATA, "sweep-sinopoli")).points
    lam = 1 - points["sensors.1.link.loss"].to_numpy()
    lower, upper = netkf.bounds(SCALAR, lam)
    for s, v, want_s, want_v in zip(lower, upper, points["theory_trace_S_bar"], points["theory_trace_V_bar"]):
        if math.isnan(want_s):
            assert math.isnan(s)
        else:
            assert s == pytest.approx(want_s, rel=1e-9)
        if math.isnan(want_v):
            assert math.isnan(v)
        else:
            assert v == pytest.approx(want_v, rel=1e-8)


def two_sensor_scalar(loss1=0.5, loss2=0.5):
    return {"name": "two-scalar", "period_ms": 10, "seed": 3,
            "plant": {"A": np.array([[1.25]]), "Q": [[1.0]]},
            "sensors": [{"id": 1, "C": [[1.0]], "R": [[2.5]], "link": {"model": "bernoulli", "loss": loss1}},
                        {"id": 4, "C": [[1.0]], "R": [[0.5]], "link": {"model": "bernoulli", "loss": loss2}}]}


def test_bounds_per_sensor_rates():
    s = netkf.load_scenario(two_sensor_scalar())
    rates = np.array([[0.3, 0.6], [0.6, 0.3], [0.5, 0.5]])
    lower, upper = netkf.bounds(s, rates)
    # Liu-Goldsmith: S-bar = Q / (1 - A^2 P(nothing arrives)) for a scalar plant
    nothing = (1 - rates[:, 0]) * (1 - rates[:, 1])
    assert lower == pytest.approx(1.0 / (1 - 1.5625 * nothing), rel=1e-12)
    # the sensors differ (R): the precise one (4) arriving more often lowers V-bar, not S-bar
    assert upper[0] < upper[1] and lower[0] == pytest.approx(lower[1], rel=1e-15)
    shared = netkf.bounds(s, [0.5])
    assert (lower[2], upper[2]) == (shared[0][0], shared[1][0])


def test_a_dict_a_text_and_a_path_are_the_same_scenario():
    with open(SCALAR) as f:
        text = f.read()
    from_path = netkf.analyze(SCALAR)
    assert_same(plain(netkf.analyze(yaml.safe_load(text))), plain(from_path))
    assert_same(plain(netkf.analyze(text)), plain(from_path))
    s = netkf.load_scenario(SCALAR)
    assert_same(plain(netkf.analyze(s.to_yaml())), plain(from_path))
    assert s.state_dim == 1 and s.sensor_ids == [1] and s.A.shape == (1, 1) and s.source.endswith("sinopoli-scalar.yaml")


# ---- the filter ----

def statsmodels_filter(A, Q, Cs, Rs, x0, P0, y):
    from statsmodels.tsa.statespace.kalman_filter import KalmanFilter
    C = np.vstack(Cs)
    R = np.zeros((C.shape[0], C.shape[0]))
    row = 0
    for r in Rs:
        m = r.shape[0]
        R[row:row + m, row:row + m] = r
        row += m
    kf = KalmanFilter(k_endog=C.shape[0], k_states=A.shape[0], design=C, obs_cov=R, transition=A,
                      selection=np.eye(A.shape[0]), state_cov=Q)
    kf.initialize_known(x0, P0)
    kf.bind(y)
    return kf.filter()


def test_the_filter_equals_statsmodels_with_partial_losses():
    A = np.array([[0.98, 0.2], [0.0, 0.9]])  # stable: x stays of the size of its noise
    Q = np.array([[0.3, 0.05], [0.05, 0.2]])
    Cs = [np.array([[1.0, 0.0]]), np.array([[0.0, 1.0], [1.0, 1.0]])]
    Rs = [np.array([[0.5]]), np.array([[0.8, 0.1], [0.1, 0.4]])]
    x0, P0 = np.array([0.5, -1.0]), np.array([[2.0, 0.3], [0.3, 1.0]])
    scenario = {"name": "statsmodels", "period_ms": 10, "seed": 1,
                "plant": {"A": A, "Q": Q, "x0": x0, "P0": P0},
                "sensors": [{"id": 1, "C": Cs[0], "R": Rs[0], "link": {"model": "bernoulli", "loss": 0.4}},
                            {"id": 2, "C": Cs[1], "R": Rs[1], "link": {"model": "bernoulli", "loss": 0.4}}]}
    rng = np.random.default_rng(20261206)
    steps = 300
    x = rng.multivariate_normal(x0, P0)
    y = np.full((steps, 3), np.nan)
    arrived = rng.random((steps, 2)) > 0.4
    for k in range(steps):
        if arrived[k, 0]:
            y[k, 0] = Cs[0] @ x + rng.multivariate_normal([0.0], Rs[0])
        if arrived[k, 1]:
            y[k, 1:] = Cs[1] @ x + rng.multivariate_normal([0.0, 0.0], Rs[1])
        x = A @ x + rng.multivariate_normal([0.0, 0.0], Q)
    assert 0 < arrived.all(axis=1).sum() < steps and (~arrived).all(axis=1).sum() > 0  # partial and whole losses
    want = statsmodels_filter(A, Q, Cs, Rs, x0, P0, y)

    f = netkf.Filter(scenario)
    for k in range(steps):
        samples = {}
        if arrived[k, 0]:
            samples[1] = y[k, 0]
        if arrived[k, 1]:
            samples[2] = y[k, 1:]
        result = f.update(samples)
        assert result["fused"] == sorted(samples) and result["rejected"] == {}
        np.testing.assert_allclose(f.x, want.filtered_state[:, k], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(f.P, want.filtered_state_cov[:, :, k], rtol=1e-10, atol=1e-10)
        f.predict()
        np.testing.assert_allclose(f.x, want.predicted_state[:, k + 1], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(f.P, want.predicted_state_cov[:, :, k + 1], rtol=1e-10, atol=1e-10)
    assert f.state == "ok" and sum(f.rejections.values()) == 0


def test_nan_is_a_lost_sample_like_statsmodels():
    f, g = netkf.Filter(SCALAR), netkf.Filter(SCALAR)
    r = f.update({1: float("nan")})
    assert r == {"fused": [], "rejected": {1: "non_finite"}} and f.rejections["non_finite"] == 1
    g.update({})
    assert f.x == pytest.approx(g.x) and f.P == pytest.approx(g.P)


def test_the_filter_refuses_what_does_not_fit():
    f = netkf.Filter(SCALAR)
    with pytest.raises(ValueError, match="no sensor 9"):
        f.update({9: 1.0})
    with pytest.raises(ValueError, match="sensor 1 measures 1 value, got 2"):
        f.update({1: [1.0, 2.0]})
    with pytest.raises(TypeError, match="sensor ids"):
        f.update({"1": 1.0})
    with pytest.raises(ValueError, match="not an array of numbers"):
        f.update({1: "abc"})
    with pytest.raises(ValueError, match="u has 2 entries"):
        f.predict([1.0, 2.0])
    with pytest.raises(ValueError, match="not finite"):
        f.predict([float("nan")])
    with pytest.raises(ValueError):
        f.restore([1.0, 2.0], np.eye(2))
    with pytest.raises(ValueError, match="P0 must be 1 x 1"):
        netkf.Filter(SCALAR, P0=np.eye(2))
    with pytest.raises(ValueError, match="plant has no input"):
        netkf.Filter(two_sensor_scalar()).predict([1.0])
    # nothing above changed the filter
    assert f.x == pytest.approx([0.0]) and f.P[0, 0] == 1.0
    f.update({1: 2.0})
    f.predict([1.0])  # the scenario's B = 1: x-hat moves by u
    assert f.x[0] == pytest.approx(-1.25 * (2.0 / 3.5) + 1.0, rel=1e-12)


# ---- bad inputs ----

def test_bad_scenarios_raise_with_the_cores_message():
    with open(SCALAR) as f:
        text = f.read()
    with pytest.raises(ValueError, match=r"<text>:\d+:\d+: .*R"):
        netkf.load_scenario(text.replace("R: [[2.5]]", "R: [[-2.5]]"))
    with pytest.raises(ValueError, match=r"<text>:\d+:\d+: .*unknown key"):
        netkf.load_scenario(text.replace("period_ms: 10", "period_ms: 10\nperiod_mss: 3"))
    bad = two_sensor_scalar()
    bad["plant"]["A"] = [[1.0, 0.0]]
    with pytest.raises(ValueError, match="<dict>"):
        netkf.load_scenario(bad)
    with pytest.raises(FileNotFoundError):
        netkf.analyze(os.path.join(REPO, "no-such-scenario.yaml"))
    with pytest.raises(TypeError):
        netkf.analyze(42)
    with pytest.raises(ValueError, match="in \\[0, 1\\]"):
        netkf.bounds(SCALAR, [0.5, 1.5])
    with pytest.raises(ValueError, match="3 columns for 1 sensors"):
        netkf.bounds(SCALAR, np.full((2, 3), 0.5))
    with pytest.raises(ValueError, match="in \\[0, 1\\]"):
        netkf.markov_criterion(SCALAR, float("nan"))
    with pytest.raises(ValueError, match="runs and steps"):
        netkf.simulate(SCALAR, runs=0)
    with pytest.raises(ValueError, match="kernel"):
        netkf.simulate(SCALAR, runs=2, kernel="quick")
    with pytest.raises(ValueError, match="points"):
        netkf.analyze(SCALAR, sweep=True, points=1)


def test_bad_traces_raise(tmp_path):
    with pytest.raises(ValueError, match="1 \\(delivered\\) or 0"):
        netkf.fit([1, 0, 2])
    with pytest.raises(ValueError, match="not finite"):
        netkf.fit([1, 0, float("nan")])
    with pytest.raises(ValueError, match="empty"):
        netkf.fit(np.array([]))
    with pytest.raises(ValueError, match="model"):
        netkf.fit([1, 0, 1], model="poisson")
    with pytest.raises(FileNotFoundError):
        netkf.fit(str(tmp_path / "no-such-trace.csv"))
    bad = tmp_path / "bad.csv"
    bad.write_text("k,delivered\n0,1\n1,7\n")
    with pytest.raises(ValueError, match=r"bad.csv:3:\d+"):
        netkf.fit(bad)


# ---- fits recover the chain that made the trace ----

def gilbert_elliott_trace(rng, n, p, r, loss_good, loss_bad):
    bad = np.empty(n, dtype=bool)
    state = rng.random() < p / (p + r)
    flips = rng.random(n)
    for t in range(n):
        bad[t] = state
        state = (flips[t] >= r) if state else (flips[t] < p)
    lost = rng.random(n) < np.where(bad, loss_bad, loss_good)
    return (~lost).astype(np.uint8)


def test_fit_recovers_a_gilbert_elliott_chain():
    rng = np.random.default_rng(7)
    truth = {"p": 0.03, "r": 0.25, "loss_good": 0.02, "loss_bad": 0.8}
    trace = gilbert_elliott_trace(rng, 60000, **truth)
    got = netkf.fit(trace, model="gilbert_elliott")
    for key, value in truth.items():
        assert abs(got["link"][key] - value) <= 4 * got["stderr"][key], (key, got["link"][key], got["stderr"][key])
    auto = netkf.fit(trace)
    assert auto["family"] != "bernoulli"  # bursts: the chain has memory


def test_fit_recovers_a_bernoulli_loss():
    trace = (np.random.default_rng(11).random(40000) > 0.3).astype(np.uint8)
    got = netkf.fit(trace)
    assert got["family"] == "bernoulli"
    assert abs(got["loss"] - 0.3) <= 4 * got["stderr"]["loss"]


# ---- the GIL ----

def test_simulate_and_fit_release_the_gil():
    # While the core computes in another thread, this thread's Python runs: it finishes a fixed
    # piece of work (a tenth of the call's length or less) before the call has returned. With the
    # GIL held it could not run until the call returned.
    trace = gilbert_elliott_trace(np.random.default_rng(3), 200000, 0.03, 0.25, 0.02, 0.8)
    for call in (lambda: netkf.simulate(SCALAR, runs=10000, steps=300, threads=1, kernel="reference", series=False),
                 lambda: netkf.fit(trace, model="gilbert_elliott")):
        started, done = threading.Event(), threading.Event()

        def work():
            started.set()
            call()
            done.set()
        t = threading.Thread(target=work)
        t.start()
        started.wait()
        total = 0
        for i in range(300000):
            total += i
        finished_first = not done.is_set()
        t.join()
        assert finished_first


# ---- the example of docs/python.md ----

def test_the_example_draws_fig2_and_fig7(tmp_path):
    import sys
    import pandas as pd
    script = os.path.join(REPO, "python", "examples", "sinopoli_core.py")
    out = str(tmp_path / "sc")
    r = subprocess.run([sys.executable, script, "--runs", "2000", "--sweep", os.path.join(DATA, "sweep-sinopoli"),
                        "--out", out], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "critical arrival rate: lower 0.360000" in r.stdout
    fig2 = pd.read_csv(out + "-fig2.csv")
    # Fig. 2: both bounds unbounded up to lambda_c = 0.36, finite above, S-bar in closed form
    unbounded = fig2["lambda"] <= 0.36 + 1e-12
    assert fig2[unbounded][["S_bar", "V_bar"]].isna().all().all()
    above = fig2[~unbounded]
    assert above[["S_bar", "V_bar"]].notna().all().all() and (above["S_bar"] <= above["V_bar"]).all()
    assert above["S_bar"].to_numpy() == pytest.approx(1 / (1 - (1 - above["lambda"].to_numpy()) * 1.5625), rel=1e-9)
    # Fig. 7: the filter's empirical E[P_{k|k-1}] between the bounds (Sinopoli Thm 4), to 4 standard errors
    fig7 = pd.read_csv(out + "-fig7.csv")
    assert len(fig7) == 7
    for _, row in fig7.iterrows():
        assert row["S_bar"] - 4 * row["mc_P_se"] <= row["mc_P"] <= row["V_bar"] + 4 * row["mc_P_se"], row.to_dict()
    sweep = pd.read_csv(out + "-sweep.csv")
    assert len(sweep) == 8 and sweep["S_bar"].isna().sum() == 1  # the fixture's point at lambda 0.3 < 0.36
