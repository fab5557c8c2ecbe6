"""Running generated trees: the virtual-clock simulator and its reports."""

from .report import EntryResult, OracleResult, Report
from .runner import run, run_tree

__all__ = ["run", "run_tree", "Report", "EntryResult", "OracleResult"]
