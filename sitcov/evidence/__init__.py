"""Safety evidence in the standards' terms: ODD attributes (ISO 34503 / PAS 1883), test-case
records (ISO 34505) with ASAM OpenLABEL tags, triggering conditions and residual risk
(ISO 21448), tied to stack and configuration by a manifest of hashes (UL 4600).

It sits above campaign, analysis and report: it reads a stored campaign and writes files.
"""

from sitcov.evidence._bundle import build_evidence, evidence_lines
from sitcov.evidence._odd import Odd, load_odd
from sitcov.evidence._risk import Criterion, lower_bound, residual_risk, runs_to_meet, upper_bound
from sitcov.evidence._taxonomy import AttributeValue, Taxonomy

__all__ = [
    "AttributeValue",
    "Criterion",
    "Odd",
    "Taxonomy",
    "build_evidence",
    "evidence_lines",
    "load_odd",
    "lower_bound",
    "residual_risk",
    "runs_to_meet",
    "upper_bound",
]
