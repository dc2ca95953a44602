"""Outputs: the output directory, history CSV, summary JSON and XDMF time series, written as
the run goes."""

from crane_fem.io.history import HistoryWriter, read_history
from crane_fem.io.outdir import prepare_output_dir
from crane_fem.io.summary import write_summary
from crane_fem.io.xdmf import XDMFSeries, read_xdmf

__all__ = [
    "HistoryWriter",
    "XDMFSeries",
    "prepare_output_dir",
    "read_history",
    "read_xdmf",
    "write_summary",
]
