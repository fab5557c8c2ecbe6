"""Running generated trees: the runner, the collector of results and their reports."""

from .collector import Collector
from .report import EntryResult, OracleResult, Report
from .runner import create_system, run, run_tree

__all__ = ["run", "run_tree", "create_system", "Collector", "Report", "EntryResult", "OracleResult"]
