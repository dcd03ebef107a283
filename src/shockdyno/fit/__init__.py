"""Error measures, objective, optimisers, calibration of globals, trends (docs/fit.md)."""

from shockdyno.fit.metrics import error_metrics, objective
from shockdyno.fit.result import ClickFit, FitResult
from shockdyno.fit.sweep import fit_sweep
from shockdyno.fit.validate import Table4Row, table4, table4_rows, table4_table

__all__ = [
    "ClickFit",
    "FitResult",
    "Table4Row",
    "error_metrics",
    "fit_sweep",
    "objective",
    "table4",
    "table4_rows",
    "table4_table",
]
