"""netkf from Python (docs/python.md): recordings, summaries and sweeps as pandas DataFrames
(pure Python over Debian's python3-numpy, python3-pandas and python3-yaml), and the core
library — scenarios, theory, Monte Carlo, fits, the filter — through the compiled module
netkf._core that the normal build makes (theory.py).
"""
import os as _os

# The compiled module lives in the build tree, not beside these sources: $NETKF_CORE_DIR, else the
# default preset's build/default/python/netkf of this checkout.
_core_dir = _os.environ.get("NETKF_CORE_DIR") or _os.path.join(
    _os.path.dirname(_os.path.dirname(_os.path.dirname(_os.path.abspath(__file__)))), "build", "default", "python",
    "netkf")
if _os.path.isdir(_core_dir):
    __path__.append(_core_dir)

from .mcap import McapError, McapFile
from .recording import (FormatError, fused_matrix, period_columns, read_mcap, read_mcap_periods,
                        read_mcap_samples, read_mcap_topic, read_periods, read_samples, states)
from .summary import QUANTITIES, checks_frame, read_summaries, read_summary, summary_series
from .sweep import Sweep, read_sweep
from .theory import Filter, analyze, bounds, critical_rate, fit, load_scenario, markov_criterion, simulate


def read_recording(path):
    """A period recording, CSV or MCAP (by its extension), as the period frame."""
    return read_mcap_periods(path) if str(path).endswith(".mcap") else read_periods(path)


__all__ = ["Filter", "analyze", "bounds", "critical_rate", "fit", "load_scenario", "markov_criterion", "simulate",
           "FormatError", "McapError", "McapFile", "QUANTITIES", "Sweep", "checks_frame", "fused_matrix",
           "period_columns", "read_mcap", "read_mcap_periods", "read_mcap_samples", "read_mcap_topic",
           "read_periods", "read_recording", "read_samples", "read_summaries", "read_summary", "read_sweep",
           "states", "summary_series"]
