"""The run summary (`netkf launch --summary FILE.json`, docs/experiments.md).

read_summary gives the JSON object as it is (a dict); summary_series flattens it into the
names a `--check` and a sweep's runs.csv use: `rms_error`, ..., `link.ID.NAME`.
"""
import json
import math

import pandas as pd

from .recording import FormatError

# The run's quantities (docs/experiments.md), in the summary's order; null = not measured.
QUANTITIES = ["periods", "rms_error", "rms_error_final", "mean_trace_P", "mean_trace_P_pred", "late_fraction", "fused_fraction",
              "periods_diverging", "pipeline_latency_p50_ms", "pipeline_latency_p99_ms", "cost"]


def read_summary(path):
    """The summary JSON as a dict; a FormatError when it is not one netkf writes."""
    try:
        with open(path) as f:
            s = json.load(f)
    except ValueError as e:
        raise FormatError("%s: not JSON (%s)" % (path, e)) from e
    if not isinstance(s, dict) or "periods" not in s or not isinstance(s.get("link", {}), dict):
        raise FormatError("%s: not a netkf run summary (no `periods`, or `link` is not an object)" % path)
    return s


def summary_series(summary):
    """One run's quantities as a Series named like --check's names (null -> NaN):
    scenario, end, passed, the QUANTITIES present, then link.ID.NAME per link (ids in order)."""
    if not isinstance(summary, dict):
        summary = read_summary(summary)
    out = {}
    for key in ("scenario", "end", "passed"):
        if key in summary:
            out[key] = summary[key]
    for q in QUANTITIES:
        if q in summary:
            out[q] = math.nan if summary[q] is None else summary[q]
    links = summary.get("link", {})
    for lid in sorted(links, key=lambda i: (len(i), i)):
        for name, v in links[lid].items():
            out["link.%s.%s" % (lid, name)] = math.nan if v is None else v
    return pd.Series(out)


def read_summaries(paths):
    """Several summaries as a DataFrame, one row each (index: the paths)."""
    return pd.DataFrame([summary_series(read_summary(p)) for p in paths], index=[str(p) for p in paths])


def checks_frame(summary):
    """The summary's `checks` as a DataFrame (check, name, operator, threshold, value, verdict, reason)."""
    if not isinstance(summary, dict):
        summary = read_summary(summary)
    return pd.DataFrame(summary.get("checks", []),
                        columns=["check", "name", "operator", "threshold", "value", "verdict", "reason"])
