"""Reports: the self-contained HTML report of a campaign store, animations of runs, and
Table 2 for the terminal."""

from sitcov.report._animate import animate_outcome, animate_run
from sitcov.report._build import build_report
from sitcov.report._console import table2_rich

__all__ = ["animate_outcome", "animate_run", "build_report", "table2_rich"]
