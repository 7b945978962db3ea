"""netkf's recordings, summaries and sweeps as pandas DataFrames (docs/python.md).

Pure Python over Debian's python3-numpy, python3-pandas and python3-yaml; no compiled part.
"""
from .mcap import McapError, McapFile
from .recording import (FormatError, fused_matrix, period_columns, read_mcap, read_mcap_periods,
                        read_mcap_samples, read_mcap_topic, read_periods, read_samples, states)
from .summary import QUANTITIES, checks_frame, read_summaries, read_summary, summary_series
from .sweep import Sweep, read_sweep


def read_recording(path):
    """A period recording, CSV or MCAP (by its extension), as the period frame."""
    return read_mcap_periods(path) if str(path).endswith(".mcap") else read_periods(path)


__all__ = ["FormatError", "McapError", "McapFile", "QUANTITIES", "Sweep", "checks_frame", "fused_matrix",
           "period_columns", "read_mcap", "read_mcap_periods", "read_mcap_samples", "read_mcap_topic",
           "read_periods", "read_recording", "read_samples", "read_summaries", "read_summary", "read_sweep",
           "states", "summary_series"]
