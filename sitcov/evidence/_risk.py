"""Residual risk against an acceptance criterion (ISO 21448 / SOTIF clause 6 and 11).

A criterion reads ``rate<0.01@0.95``: the failure rate must be below 1 % with 95 %
confidence. With ``k`` failures in ``n`` judged runs, the exact (Clopper-Pearson)
one-sided bounds decide:

- **met**: the upper bound is below the target (the rate is below it with that confidence);
- **not met**: the lower bound is above the target (the rate is above it with that
  confidence);
- **not yet decidable**: neither; ``runs_needed`` is the fewest further runs that would
  meet the criterion if none of them failed (the zero-failure bound; with ``k = 0`` it is
  the classic "rule of three" at 95 %).

Exact bounds, not Wilson's: a safety argument must not rest on an approximation that is
anti-conservative for rates near 0.
"""

from __future__ import annotations

import re
from dataclasses import asdict, dataclass
from typing import Any

from scipy.stats import beta

from sitcov.errors import ConfigError

MET, NOT_MET, UNDECIDED = "met", "not met", "not yet decidable"
_CRITERION = re.compile(r"^\s*rate\s*<\s*([0-9.eE+-]+)\s*(?:@\s*([0-9.eE+-]+))?\s*$")


@dataclass(frozen=True)
class Criterion:
    """An acceptance criterion: failure rate below ``target`` with ``confidence``."""

    target: float
    confidence: float = 0.95

    def __post_init__(self) -> None:
        if not 0.0 < self.target < 1.0:
            raise ConfigError(
                field="--criterion",
                value=self.target,
                expected="a target rate strictly between 0 and 1",
            )
        if not 0.5 <= self.confidence < 1.0:
            raise ConfigError(
                field="--criterion", value=self.confidence, expected="a confidence in [0.5, 1)"
            )

    @classmethod
    def parse(cls, text: str) -> Criterion:
        """``rate<0.01@0.95`` (confidence defaults to 0.95)."""
        m = _CRITERION.match(text)
        if m is None:
            raise ConfigError(
                field="--criterion",
                value=text,
                expected="rate<TARGET[@CONFIDENCE], e.g. rate<0.01@0.95",
            )
        try:
            target = float(m.group(1))
            confidence = float(m.group(2)) if m.group(2) else 0.95
        except ValueError:
            raise ConfigError(
                field="--criterion", value=text, expected="numbers, e.g. rate<0.01@0.95"
            ) from None
        return cls(target, confidence)

    def text(self) -> str:
        return f"failure rate < {self.target:g} at {100 * self.confidence:g} % confidence"


def upper_bound(k: int, n: int, confidence: float) -> float:
    """Exact one-sided upper confidence bound of a binomial rate (1.0 when ``n = 0``)."""
    _check(k, n)
    if k >= n:
        return 1.0
    return float(beta.ppf(confidence, k + 1, n - k))


def lower_bound(k: int, n: int, confidence: float) -> float:
    """Exact one-sided lower confidence bound of a binomial rate (0.0 when ``k = 0``)."""
    _check(k, n)
    if k == 0:
        return 0.0
    return float(beta.ppf(1.0 - confidence, k, n - k + 1))


def _check(k: int, n: int) -> None:
    if n < 0 or not 0 <= k <= max(n, 0):
        raise ValueError(f"need 0 <= k <= n, got k={k}, n={n}")


def runs_to_meet(k: int, n: int, criterion: Criterion) -> int:
    """Fewest further runs, all passing, after which the upper bound is below the target."""
    if upper_bound(k, n, criterion.confidence) < criterion.target:
        return 0
    # the bound falls monotonically as failure-free runs are added: double, then bisect
    hi = 1
    while upper_bound(k, n + hi, criterion.confidence) >= criterion.target:
        hi *= 2
    lo = hi // 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if upper_bound(k, n + mid, criterion.confidence) < criterion.target:
            hi = mid
        else:
            lo = mid
    return hi


@dataclass(frozen=True)
class RiskVerdict:
    """The residual-risk verdict of one region of the ODD."""

    region: str
    judged: int
    failures: int
    rate: float | None
    lower: float
    upper: float
    verdict: str
    runs_needed: int | None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def line(self) -> str:
        rate = "-" if self.rate is None else f"{100 * self.rate:.2f} %"
        need = "" if not self.runs_needed else f"; {self.runs_needed} more failure-free runs"
        return (
            f"{self.region}: {self.failures}/{self.judged} ({rate}, exact bounds "
            f"[{100 * self.lower:.2f}, {100 * self.upper:.2f}] %): {self.verdict}{need}"
        )


def residual_risk(region: str, failures: int, judged: int, criterion: Criterion) -> RiskVerdict:
    """The verdict of ``failures`` in ``judged`` runs against ``criterion``."""
    upper = upper_bound(failures, judged, criterion.confidence)
    lower = lower_bound(failures, judged, criterion.confidence)
    if upper < criterion.target:
        verdict, needed = MET, 0
    elif lower > criterion.target:
        verdict, needed = NOT_MET, None
    else:
        verdict, needed = UNDECIDED, runs_to_meet(failures, judged, criterion)
    rate = failures / judged if judged else None
    return RiskVerdict(region, judged, failures, rate, lower, upper, verdict, needed)


def zero_failure_runs(criterion: Criterion) -> int:
    """Failure-free runs needed from nothing (``sitcov runs-needed --below``'s count)."""
    from sitcov.analysis._flaky import zero_failure_runs as runs_below

    return runs_below(criterion.target, criterion.confidence)
