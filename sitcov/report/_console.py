"""Table 2 as a rich table for the terminal (``sitcov experiment faults``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

_FAULTS = ("NF", "F1", "F2", "F3")


def table2_rich(table: Mapping[str, Any]) -> Any:
    """A :class:`rich.table.Table` of :func:`sitcov.campaign.fault_table` output.

    One row per (generator, fault): failures out of runs, the rate with its Wilson 95 %
    interval, and for faults the paper's ``triggered`` (F − NF) beside the paired counts.
    """
    from rich.table import Table

    out = Table(title="Seeded faults (Table 2)", title_justify="left")
    out.add_column("generator")
    out.add_column("fault")
    out.add_column("failures", justify="right")
    out.add_column("rate [95% CI]", justify="right")
    out.add_column("triggered", justify="right")
    out.add_column("newly failing", justify="right")
    out.add_column("cured", justify="right")
    out.add_column("errors + timeouts", justify="right")
    for gen, row in table["generators"].items():
        runs = row["runs"]
        for fault in _FAULTS:
            k, ci = row[fault], row["ci95"].get(fault)
            rate = f"{100 * k / runs:.0f}% [{100 * ci[0]:.0f}–{100 * ci[1]:.0f}]" if ci else "–"
            extra = (
                ("", "", "")
                if fault == "NF"
                else (
                    f"{row['triggered'][fault]:+d}",
                    str(row["newly_failing"][fault]),
                    str(row["cured"][fault]),
                )
            )
            name = gen if fault == "NF" else ""
            if fault == "NF" and not row.get("complete", True):
                name += " [yellow](incomplete)[/]"
            errors = str(row.get("errors", {}).get(fault, 0))
            out.add_row(name, fault, f"{k}/{runs}", rate, *extra, errors, end_section=fault == "F3")
    out.caption = (
        "triggered = F − NF (the paper's measure); newly failing / cured = runs that fail with "
        "the fault and pass without it / the reverse (same situations and seeds; runs that "
        "errored or timed out are neither)"
    )
    return out
