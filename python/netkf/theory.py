"""netkf's core for Python: scenarios, the papers' theory, Monte Carlo, loss-model fits and the
intermittent Kalman filter (docs/python.md, "The core in Python").

The compiled part is the module `netkf._core` (python/bindings, built by the normal build into
build/default/python/netkf/); this file is its friendly face: what a scenario argument may be,
and one clear error when the module is not built. The results carry the names of the `netkf`
command's JSON (`netkf analyze/simulate/fit --json`), with arrays of numbers as numpy arrays.
"""
import os

import numpy as np

try:
    from . import _core
    _CORE_ERROR = None
except ImportError as error:  # the reader works without it
    _core = None
    _CORE_ERROR = error


def _require_core():
    if _core is None:
        raise ImportError("netkf's compiled core (netkf._core) is not built or not found: run scripts/build.sh "
                          "(it builds build/default/python/netkf/_core*.so), or set NETKF_CORE_DIR to the folder "
                          "that holds it (%s)" % _CORE_ERROR)
    return _core


def _plain(value):
    """numpy values inside a scenario dict as plain lists and numbers (for YAML)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    return value


def load_scenario(source):
    """A validated scenario from a file path, YAML text or a dict (the file's keys,
    docs/scenario-format.md); a Scenario is returned as it is.

    A str is a path unless it holds a newline (then it is YAML text). A malformed scenario
    raises ValueError with the core's message (FILE:LINE:COL: what is wrong); a missing file
    FileNotFoundError.
    """
    core = _require_core()
    if isinstance(source, core.Scenario):
        return source
    if isinstance(source, dict):
        import yaml
        return core.parse_scenario(yaml.safe_dump(_plain(source), sort_keys=False), "<dict>")
    if isinstance(source, os.PathLike) or (isinstance(source, str) and "\n" not in source):
        path = os.fspath(source)
        if not os.path.isfile(path):
            raise FileNotFoundError("no scenario file %s" % path)
        return core.load_scenario_file(path)
    if isinstance(source, str):
        return core.parse_scenario(source, "<text>")
    raise TypeError("a scenario is a path, YAML text, a dict or a netkf.Scenario, not %s" % type(source).__name__)


def analyze(scenario, region=False, sweep=False, points=None, lmi=True, region_sensor=None):
    """`netkf analyze --json` as a dict: verdict, bounds, critical rates, Markov criterion,
    per-link arrival, notes; `region`/`sweep`/`points`/`region_sensor` as the command's flags,
    `lmi=False` as --no-lmi."""
    return _require_core().analyze(load_scenario(scenario), region, sweep, points, lmi, region_sensor)


def critical_rate(scenario, lmi=True):
    """The critical arrival rates of the scenario's sensors with every link Bernoulli at one
    shared rate λ: {'lower' (Sinopoli Thm 3 closed form), 'upper' (LMI), 'upper_iteration',
    'exact' (Markov criterion, None where it does not apply), 'notes'}. The links' configured
    models are not read (analyze() reports critical_rate only for shared Bernoulli links)."""
    return _require_core().critical_rate(load_scenario(scenario), lmi)


def bounds(scenario, arrival_rates):
    """(Tr S̄, Tr V̄) — Sinopoli Thm 4 — at each point of arrival_rates, as two numpy arrays (NaN:
    unbounded). 1-D: each entry a rate every sensor shares; 2-D: one row per point, one column
    per sensor (in the scenario's order)."""
    return _require_core().bounds(load_scenario(scenario), arrival_rates)


def markov_criterion(scenario, arrival_rates=None):
    """The necessary-and-sufficient criterion (stable iff value < 1) for the scenario's links,
    or for Bernoulli links at arrival_rates (one rate, or one per sensor): {'applies', 'value',
    'exact', 'stable', 'reasons', 'blocks'}."""
    return _require_core().markov_criterion(load_scenario(scenario), arrival_rates)


def simulate(scenario, runs=1000, steps=300, seed=None, threads=0, kernel="auto", series=True):
    """`netkf simulate --json` as a dict (means at the last step ± standard errors, diverged
    fraction, ...), with the per-step means under 'series' (numpy arrays). Deterministic given
    the seed (the scenario's by default), whatever the thread count."""
    return _require_core().simulate(load_scenario(scenario), runs, steps, seed, threads, kernel, series)


def fit(trace, model="auto", seed=1):
    """`netkf fit --json` as a dict: the loss model that explains a link's arrivals. trace: a
    trace CSV's path (docs/scenario-format.md, "Link traces") or an array of 1 (delivered) /
    0 (lost); model: auto (by AIC), bernoulli, simple_gilbert, gilbert, gilbert_elliott."""
    if isinstance(trace, os.PathLike):
        trace = os.fspath(trace)
    if isinstance(trace, str) and not os.path.isfile(trace):
        raise FileNotFoundError("no trace file %s" % trace)
    return _require_core().fit(trace, model, seed)


class Filter:
    """The intermittent multi-sensor Kalman filter (Sinopoli et al.; the estimator's own) on a
    scenario's model. Each period: update({sensor id: y, ...}) with the samples that arrived
    (absent = lost; NaN = lost too), read x and P (x̂_{k|k}, P_{k|k}), then predict(u)."""

    def __init__(self, scenario, x0=None, P0=None):
        self._filter = _require_core().Filter(load_scenario(scenario), x0, P0)

    def update(self, samples):
        return self._filter.update(dict(samples))

    def predict(self, u=None, input_covariance=None):
        self._filter.predict(u, input_covariance)

    def restore(self, x, P):
        self._filter.restore(x, P)

    x = property(lambda self: self._filter.x, doc="x̂ (after update: x̂_{k|k}; after predict: x̂_{k+1|k})")
    P = property(lambda self: self._filter.P, doc="P (after update: P_{k|k}; after predict: P_{k+1|k})")
    trace_P = property(lambda self: self._filter.trace_P)
    state = property(lambda self: self._filter.state, doc="'ok', or 'diverging' once Tr P passed the bound")
    rejections = property(lambda self: self._filter.rejections, doc="samples not fused so far, by reason")
    sensor_ids = property(lambda self: self._filter.sensor_ids)
    state_dim = property(lambda self: self._filter.state_dim)
