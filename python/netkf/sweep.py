"""A sweep directory (`netkf sweep ... --out DIR`, issue 21 §1) as DataFrames.

DIR/runs.csv    point,seed,<varied keys...>,status,<summary quantities...>   one row per run
DIR/points.csv  point,<varied keys...>,seeds,<Q_mean,Q_se,Q_min,Q_max per quantity Q>,
                theory_stable,theory_trace_S_bar,theory_trace_V_bar,theory_critical_margin,
                theory_trace_P_sampled,theory_trace_P_sampled_se
DIR/sweep.yaml  vary: [{key, values}], seeds, mode, ... (the exact command, scenario hash,
                netkf version)

Varied keys are scenario paths (`sensors.1.link.loss`), quantities the summary's names
(`rms_error`, `link.1.observed_loss`): both may contain dots, so columns are found from the
`vary:` list and the fixed names, never by splitting on dots.
"""
import math
import os

import numpy as np
import pandas as pd
import yaml

from .recording import FormatError

STATS = ("mean", "se", "min", "max")
THEORY = ["theory_stable", "theory_trace_S_bar", "theory_trace_V_bar", "theory_critical_margin"]
# Links with memory: the simulated E[Tr P] and its standard error (an estimate, not a bound);
# absent from sweeps written before they existed.
THEORY_SAMPLED = ["theory_trace_P_sampled", "theory_trace_P_sampled_se"]
_TRUE = {"true", "yes", "1", "stable"}
_FALSE = {"false", "no", "0", "unstable"}


def _bool_column(path, col, values):
    out = []
    for v in values:
        s = str(v).strip().lower()
        if s in ("", "nan", "none", "null", "unknown"):
            out.append(pd.NA)
        elif s in _TRUE:
            out.append(True)
        elif s in _FALSE:
            out.append(False)
        else:
            raise FormatError("%s: %s holds %r, not true/false" % (path, col, v))
    return pd.array(out, dtype="boolean")


def _read(path):
    if not os.path.exists(path):
        raise FormatError("%s: missing (a sweep directory holds runs.csv, points.csv and sweep.yaml)" % path)
    try:
        return pd.read_csv(path, float_precision="round_trip", keep_default_na=False,
                           na_values=["", "nan", "NaN", "null"], dtype={"status": str})
    except (ValueError, pd.errors.ParserError) as e:
        raise FormatError("%s: %s" % (path, e)) from e


class Sweep:
    """runs, points (DataFrames), config (sweep.yaml as a dict), varied (the keys, in the
    vary list's order), quantities (the summary quantities of runs.csv), seeds, mode."""

    def __init__(self, directory):
        self.directory = str(directory)
        cfg_path = os.path.join(self.directory, "sweep.yaml")
        if not os.path.exists(cfg_path):
            raise FormatError("%s: missing (not a sweep directory?)" % cfg_path)
        with open(cfg_path) as f:
            try:
                self.config = yaml.safe_load(f) or {}
            except yaml.YAMLError as e:
                raise FormatError("%s: not YAML (%s)" % (cfg_path, e)) from e
        vary = self.config.get("vary")
        if not isinstance(vary, list) or not vary or not all(isinstance(v, dict) and "key" in v for v in vary):
            raise FormatError("%s: `vary` must be a list of {key, values}" % cfg_path)
        self.varied = [str(v["key"]) for v in vary]
        self.values = {str(v["key"]): list(v.get("values") or []) for v in vary}
        self.seeds = self.config.get("seeds")
        self.mode = self.config.get("mode")
        self.runs = self._load_runs(os.path.join(self.directory, "runs.csv"))
        self.points = self._load_points(os.path.join(self.directory, "points.csv"))
        self._check_consistent()

    def _load_runs(self, path):
        df = _read(path)
        head = ["point", "seed"] + self.varied + ["status"]
        if list(df.columns[:len(head)]) != head:
            raise FormatError("%s: header starts %s, expected %s" % (path, ",".join(df.columns[:len(head)]),
                                                                      ",".join(head)))
        self.quantities = list(df.columns[len(head):])
        for c in ["point", "seed"]:
            if not pd.api.types.is_integer_dtype(df[c]):
                raise FormatError("%s: column %s holds values that are not integers" % (path, c))
        for q in self.quantities + self.varied:
            if not pd.api.types.is_numeric_dtype(df[q]) and q in self.quantities:
                raise FormatError("%s: quantity %s holds values that are not numbers" % (path, q))
        df.attrs["path"] = path
        return df

    def _load_points(self, path):
        df = _read(path)
        head = ["point"] + self.varied + ["seeds"]
        if list(df.columns[:len(head)]) != head:
            raise FormatError("%s: header starts %s, expected %s" % (path, ",".join(df.columns[:len(head)]),
                                                                      ",".join(head)))
        missing = [c for c in THEORY if c not in df.columns]
        missing += ["%s_%s" % (q, s) for q in self.quantities for s in STATS if "%s_%s" % (q, s) not in df.columns]
        if missing:
            raise FormatError("%s: columns missing: %s" % (path, ", ".join(missing)))
        df["theory_stable"] = _bool_column(path, "theory_stable", df["theory_stable"])
        df.attrs["path"] = path
        return df

    def _check_consistent(self):
        unknown = sorted(set(self.runs["point"]) - set(self.points["point"]))
        if unknown:
            raise FormatError("%s: runs of points %s that points.csv does not list" % (self.runs.attrs["path"], unknown))
        for key in self.varied:
            allowed = self.values[key]
            if not allowed:
                continue
            bad = [v for v in self.points[key] if not any(_same(v, a) for a in allowed)]
            if bad:
                raise FormatError("%s: %s takes %s, not among sweep.yaml's values %s" %
                                  (self.points.attrs["path"], key, bad, allowed))

    def stats(self, quantity):
        """Per point: the varied keys, seeds, and the quantity's mean, se, min, max (as points.csv
        has them), plus the theory columns."""
        if quantity not in self.quantities:
            raise KeyError("the sweep has no quantity %r (it has %s)" % (quantity, ", ".join(self.quantities)))
        theory = THEORY + [c for c in THEORY_SAMPLED if c in self.points.columns]
        cols = ["point"] + self.varied + ["seeds"] + ["%s_%s" % (quantity, s) for s in STATS] + theory
        out = self.points[cols].copy()
        out.columns = ["point"] + self.varied + ["seeds"] + list(STATS) + theory
        return out

    def aggregate(self, quantity):
        """The per-point mean, standard error (sample sd / sqrt(n)), min and max of `quantity`
        recomputed from runs.csv over the runs that measured it (to check points.csv, or to
        aggregate a subset of the runs)."""
        g = self.runs.groupby("point")[quantity]
        n = g.count()
        out = pd.DataFrame({"n": n, "mean": g.mean(), "se": g.std(ddof=1) / np.sqrt(n), "min": g.min(),
                            "max": g.max()})
        out.loc[n < 2, "se"] = math.nan
        return out

    def __repr__(self):
        return "Sweep(%s: %d points x %s seeds, varied %s, %d runs)" % (
            self.directory, len(self.points), self.seeds, ", ".join(self.varied), len(self.runs))


def _same(a, b):
    try:
        return math.isclose(float(a), float(b), rel_tol=1e-12, abs_tol=1e-15)
    except (TypeError, ValueError):
        return str(a) == str(b)


def read_sweep(directory):
    """A sweep directory as a Sweep (runs, points, config, varied, quantities)."""
    return Sweep(directory)
