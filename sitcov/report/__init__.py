"""Reports: the self-contained HTML report of a campaign store, and Table 2 for the terminal."""

from sitcov.report._build import build_report
from sitcov.report._console import table2_rich

__all__ = ["build_report", "table2_rich"]
