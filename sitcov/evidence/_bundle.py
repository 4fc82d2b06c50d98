"""``sitcov evidence``: one folder of safety evidence from a stored campaign.

Orchestrates the parts below it (store, analysis, report) and the evidence modules: ODD
attributes of every run, in-ODD coverage and failure rates, test-case records with their
OpenLABEL tags, the triggering-condition catalogue, the residual-risk verdicts, the HTML
report and a manifest of hashes. docs/evidence.md explains each artefact and the clause of
the standard it serves.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sitcov.analysis import wilson_interval
from sitcov.errors import ConfigError
from sitcov.evidence._manifest import runs_hash, stack_files, write_manifest
from sitcov.evidence._odd import Odd, load_odd
from sitcov.evidence._records import (
    judge_kinds,
    openlabel_tags,
    platform_of,
    stack_identity,
    test_case_record,
)
from sitcov.evidence._risk import Criterion, RiskVerdict, residual_risk
from sitcov.evidence._taxonomy import AttributeValue, Taxonomy
from sitcov.evidence._triggering import triggering_conditions

#: statuses that count as judged, and those that count as failures (a time-out is no
#: evidence that the stack coped, so it counts against it; an error is excluded, counted)
JUDGED = ("pass", "fail", "timeout")
FAILED = ("fail", "timeout")


@dataclass(frozen=True)
class _Run:
    """A stored run with its ODD attributes and ODD membership."""

    record: Any
    attributes: list[AttributeValue]
    inside: bool
    reasons: list[str]


def _rate(runs: Sequence[_Run]) -> dict[str, Any]:
    judged = [r for r in runs if r.record.status in JUDGED]
    k = sum(r.record.status in FAILED for r in judged)
    n = len(judged)
    ci = wilson_interval(k, n)
    return {
        "runs": n,
        "failures": k,
        "failure_rate": k / n if n else None,
        "ci95": list(ci) if ci else None,
    }


def odd_coverage(runs: Sequence[_Run], odd: Odd) -> dict[str, Any]:
    """Per attribute and class: runs, failures, rate with Wilson interval, inside and
    outside the ODD apart; plus the classes the ODD allows that no run exercised."""
    table: dict[str, dict[str, dict[str, list[_Run]]]] = {}
    for run in runs:
        for a in run.attributes:
            cell = table.setdefault(a.attribute, {}).setdefault(a.category, {"in": [], "out": []})
            cell["in" if run.inside else "out"].append(run)
    attributes = {}
    for attribute, classes in sorted(table.items()):
        attributes[attribute] = {
            category: {"in_odd": _rate(cell["in"]), "out_of_odd": _rate(cell["out"])}
            for category, cell in classes.items()
        }
    gaps = []
    for attribute, limit in odd.spec.attributes.items():
        for category in limit.in_ or []:
            if not table.get(attribute, {}).get(category, {}).get("in"):
                gaps.append(f"{attribute} = {category}")
    inside = [r for r in runs if r.inside]
    return {
        "odd": odd.spec.name,
        "approach": odd.spec.approach,
        "in_odd": _rate(inside),
        "out_of_odd": _rate([r for r in runs if not r.inside]),
        "errors_excluded": sum(r.record.status == "error" for r in runs),
        "attributes": attributes,
        "never_exercised_in_odd": gaps,
        "unused_odd_attributes": odd.unused(set(table)),
    }


def risk_verdicts(runs: Sequence[_Run], criterion: Criterion) -> list[RiskVerdict]:
    """The whole ODD, then each attribute class inside it."""
    inside = [r for r in runs if r.inside]
    verdicts = [_verdict("whole ODD", inside, criterion)]
    regions: dict[str, list[_Run]] = {}
    for run in inside:
        for a in run.attributes:
            regions.setdefault(f"{a.attribute} = {a.category}", []).append(run)
    verdicts += [_verdict(name, rs, criterion) for name, rs in sorted(regions.items())]
    return verdicts


def _verdict(region: str, runs: Sequence[_Run], criterion: Criterion) -> RiskVerdict:
    rate = _rate(runs)
    return residual_risk(region, rate["failures"], rate["runs"], criterion)


def _campaign_name(store: Any, campaign: str | None) -> str:
    names = [c.name for c in store.campaigns()]
    if campaign is not None:
        store.campaign(campaign)  # raises with the known names
        return campaign
    if len(names) != 1:
        raise ConfigError(
            field="--campaign",
            value=None,
            expected=f"one of {', '.join(names)} (the store holds {len(names)})",
        )
    return names[0]


def _prepare(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise ConfigError(field="--out", value=str(out), expected="a folder (a file is there)")
    out.mkdir(parents=True, exist_ok=True)
    for name in ("openlabel", "report"):
        shutil.rmtree(out / name, ignore_errors=True)  # no stale files from an earlier build
    (out / "openlabel").mkdir()


def build_evidence(
    db: str | Path,
    out: str | Path,
    *,
    campaign: str | None = None,
    odd: str | Path | None = None,
    criterion: str = "rate<0.01@0.95",
    seed: int = 0,
    report: bool = True,
) -> dict[str, Any]:
    """Write the evidence folder of one campaign and return its summary.

    Args:
        db: the campaign database.
        out: the folder (created; its sitcov-written parts are replaced).
        campaign: the campaign (needed when the store holds several).
        odd: an ODD YAML file (None: the whole hyperspace is the ODD).
        criterion: the acceptance criterion, ``rate<TARGET[@CONFIDENCE]``.
        seed: seed of the held-out split of the triggering conditions.
        report: also write the HTML report (``report/index.html``).

    Raises:
        ConfigError: bad ODD file, criterion, campaign or output folder.
        StoreError: no such database.
    """
    from sitcov.campaign import EXECUTION_ONLY
    from sitcov.campaign._console import existing_store
    from sitcov.campaign._summary import FINISHED, campaign_hyperspace

    crit = Criterion.parse(criterion)
    the_odd = load_odd(odd)
    out = Path(out)
    with existing_store(Path(db)) as store:
        name = _campaign_name(store, campaign)
        info = store.campaign(name)
        hyperspace = campaign_hyperspace(store, name)
        records = list(store.runs(name, FINISHED))
    _prepare(out)
    taxonomy = Taxonomy(hyperspace)
    config = dict(info.config)
    platform = platform_of(config, info.sitcov_version, info.world_version)
    kinds = judge_kinds(config)
    runs = []
    with open(out / "records.jsonl", "w") as f:
        for rec in records:
            attrs = taxonomy.attributes(rec.situation)
            inside, reasons = the_odd.contains(attrs)
            runs.append(_Run(rec, attrs, inside, reasons))
            row = test_case_record(
                rec,
                attrs,
                platform=platform,
                kinds=kinds,
                in_odd=inside,
                odd_reasons=reasons,
                db=str(db),
            )
            f.write(json.dumps(row, sort_keys=True) + "\n")
            tags = openlabel_tags(row, attrs)
            (out / "openlabel" / f"{row['id']}.json").write_text(json.dumps(tags, indent=1))
    coverage = odd_coverage(runs, the_odd)
    coverage["unmapped_elements"] = taxonomy.unmapped
    verdicts = risk_verdicts(runs, crit)
    catalogue = triggering_conditions(taxonomy, records, db=str(db), seed=seed)
    _write_json(out / "odd_coverage.json", coverage)
    _write_json(
        out / "residual_risk.json",
        {"criterion": crit.text(), "verdicts": [v.to_dict() for v in verdicts]},
    )
    _write_json(out / "triggering_conditions.json", catalogue)
    if report:
        from sitcov.report import build_report

        build_report(db, out / "report", campaigns=[name])
    stack = stack_identity(config)
    inputs = {
        "stack": {**stack, "files": stack_files(stack)},
        "configuration": {k: v for k, v in config.items() if k not in EXECUTION_ONLY},
        "hyperspace": dict(info.hyperspace),
        "runs": runs_hash(records),
        "odd": the_odd.spec.model_dump(mode="json", by_alias=True),
        "criterion": {"target": crit.target, "confidence": crit.confidence},
        "sitcov_version": {"campaign": info.sitcov_version, "evidence": _version()},
        "world_model_version": info.world_version,
    }
    manifest = write_manifest(out, inputs)
    return {
        "campaign": name,
        "out": str(out),
        "runs": len(runs),
        "in_odd": coverage["in_odd"],
        "out_of_odd": coverage["out_of_odd"],
        "criterion": crit.text(),
        "verdict": verdicts[0].to_dict(),
        "known_unsafe": sum(c["classification"] == "known unsafe" for c in catalogue["conditions"]),
        "conditions": len(catalogue["conditions"]),
        "never_exercised_in_odd": coverage["never_exercised_in_odd"],
        "inputs_sha256": manifest["inputs_sha256"],
    }


def evidence_lines(summary: Mapping[str, Any]) -> list[str]:
    """The console text of ``sitcov evidence``."""
    inside, outside = summary["in_odd"], summary["out_of_odd"]
    v = summary["verdict"]
    lines = [
        f"evidence for campaign {summary['campaign']} written to {summary['out']}",
        f"runs: {summary['runs']} ({inside['runs']} judged inside the ODD, "
        f"{outside['runs']} outside)",
        f"criterion: {summary['criterion']}",
        f"verdict (whole ODD): {v['verdict']} — {v['failures']}/{v['judged']} failures, exact "
        f"upper bound {100 * v['upper']:.2f} %"
        + (f"; {v['runs_needed']} more failure-free runs needed" if v["runs_needed"] else ""),
        f"triggering conditions: {summary['conditions']} "
        f"({summary['known_unsafe']} known unsafe on held-out runs)",
    ]
    if summary["never_exercised_in_odd"]:
        lines.append(
            "never exercised inside the ODD: " + ", ".join(summary["never_exercised_in_odd"])
        )
    lines.append(f"manifest inputs sha256: {summary['inputs_sha256']}")
    return lines


def _write_json(path: Path, data: Any) -> None:
    path.write_text(json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")


def _version() -> str:
    from sitcov._version import __version__

    return __version__
