"""Test-case records (ISO 34505 style) and scenario tags (ASAM OpenLABEL 1.0.0) of runs.

A record says, for one stored run, what a test-case description must (ISO 34505 clause 8:
identifier, objective, inputs, platform, expected and actual result, evaluation): the id
is stable (a hash of the situation id and the run seed, so a re-run of the same campaign
gives the same ids), the platform names backend, perception, physics, world model and
sitcov version, the expected result is the campaign's judge.
"""

from __future__ import annotations

import hashlib
import math
import shlex
from collections.abc import Mapping
from typing import Any

from sitcov.evidence._taxonomy import AttributeValue

#: OpenLABEL schema version written and validated against
OPENLABEL_VERSION = "1.0.0"
OPENLABEL_ONTOLOGY = "https://openlabel.asam.net/V1-0-0/ontologies/"
#: metrics copied into a record's evaluation (criticality, ISO 34505 clause 9)
EVALUATION_METRICS = ("min_distance", "min_ttc", "pet", "collision_speed", "collision_time")


def test_case_id(situation_id: str, seed: int) -> str:
    """Stable identifier of a run: ``TC-`` and 16 hex digits of sha256(situation id, seed)."""
    digest = hashlib.sha256(f"{situation_id}:{seed}".encode()).hexdigest()
    return f"TC-{digest[:16]}"


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def platform_of(config: Mapping[str, Any], sitcov_version: str, world_version: Any) -> dict:
    """The platform a run was made on (ISO 34505: test environment / tool chain)."""
    options = dict(config.get("backend_options") or {})
    return {
        "backend": config.get("backend", "embedded"),
        "perception": options.get("perception", "pem"),
        "physics": config.get("physics", "carla"),
        "world_model_version": world_version,
        "sitcov_version": sitcov_version,
        "stack": stack_identity(config),
    }


def stack_identity(config: Mapping[str, Any]) -> dict[str, Any]:
    """The stack under test as configured: name or class, external command, fault, params."""
    options = dict(config.get("backend_options") or {})
    return {
        "av": config.get("av", "reference"),
        "av_cmd": options.get("av_cmd"),
        "fault": config.get("fault"),
        "av_params": config.get("av_params"),
    }


def judge_kinds(config: Mapping[str, Any]) -> list[str]:
    """The failure kinds the campaign's judge counts."""
    from sitcov.sim import JUDGES, normalize_judge

    spec = normalize_judge(config.get("judge", "default"))
    return list(JUDGES[spec]) if isinstance(spec, str) else list(spec)


def objective(attributes: list[AttributeValue], kinds: list[str]) -> str:
    """One sentence: what the test case checks."""
    junction = next(
        (a.category for a in attributes if a.attribute.startswith("scenery.junc")), "the junction"
    )
    users = sorted({a.category for a in attributes if a.attribute.endswith("agent_type")})
    who = ", ".join(users) if users else "no other road user"
    return (
        f"The stack under test drives its route through a {junction.replace('_', '-')} "
        f"with {who} in conflict, without {' or '.join(k.replace('_', ' ') for k in kinds)}."
    )


def test_case_record(
    run: Any,
    attributes: list[AttributeValue],
    *,
    platform: Mapping[str, Any],
    kinds: list[str],
    in_odd: bool,
    odd_reasons: list[str],
    db: str,
) -> dict[str, Any]:
    """The ISO 34505-style record of one stored run (``RunRecord``)."""
    outcome = run.outcome
    metrics = {} if outcome is None else outcome.to_dict()
    evaluation = {m: _finite(metrics.get(m)) for m in EVALUATION_METRICS}
    situation = run.situation.to_dict()
    return {
        "id": test_case_id(run.situation.id, run.seed),
        "objective": objective(attributes, kinds),
        "inputs": {
            "situation_id": run.situation.id,
            "bins": situation["bins"],
            "values": {k: _finite(v) for k, v in situation["values"].items()},
            "seed": run.seed,
            "odd_attributes": [a.to_dict() for a in attributes],
        },
        "platform": dict(platform),
        "expected_result": {
            "judge": kinds,
            "pass_if": f"none of {', '.join(kinds)} within the run",
        },
        "actual_result": {
            "status": run.status,
            "failure_kind": run.failure_kind,
            "end_reason": None if outcome is None else outcome.end_reason,
            "sim_time": None if outcome is None else outcome.sim_time,
        },
        "evaluation": evaluation,
        "odd": {"inside": in_odd, "outside_because": odd_reasons},
        "source": {"campaign": run.campaign, "index": run.index},
        "replay": f"sitcov replay --db {shlex.quote(db)} {shlex.quote(run.campaign)}:{run.index}",
    }


def openlabel_tags(record: Mapping[str, Any], attributes: list[AttributeValue]) -> dict:
    """The run's scenario tags as an ASAM OpenLABEL 1.0.0 document (``{"openlabel": ...}``).

    One tag per ODD attribute whose OpenLABEL class is known, with the quantity as a
    ``num`` and the class as a ``text``; an administration tag carries the test case id,
    verdict and source run.
    """
    tags: dict[str, Any] = {}
    for a in attributes:
        if not a.openlabel:
            continue
        data: dict[str, list[dict[str, Any]]] = {
            "text": [
                {"name": "category", "val": a.category},
                {"name": "attribute", "val": a.attribute},
            ],
        }
        if a.quantity is not None and math.isfinite(a.quantity):
            data["num"] = [{"name": "value", "val": float(a.quantity), "type": "value"}]
        if a.unit:
            data["text"].append({"name": "unit", "val": a.unit})
        tags[str(len(tags))] = {"type": a.openlabel, "ontology_uid": "0", "tag_data": data}
    result = record["actual_result"]
    tags[str(len(tags))] = {
        "type": "AdminTag",
        "ontology_uid": "0",
        "tag_data": {
            "text": [
                {"name": "test_case_id", "val": record["id"]},
                {"name": "status", "val": str(result["status"])},
                {"name": "failure_kind", "val": str(result["failure_kind"])},
                {
                    "name": "source_run",
                    "val": f"{record['source']['campaign']}:{record['source']['index']}",
                },
            ],
            "boolean": [{"name": "inside_odd", "val": bool(record["odd"]["inside"])}],
        },
    }
    return {
        "openlabel": {
            "metadata": {
                "schema_version": OPENLABEL_VERSION,
                "name": record["id"],
                "annotator": f"sitcov {record['platform']['sitcov_version']}",
                "comment": record["objective"],
            },
            "ontologies": {"0": OPENLABEL_ONTOLOGY},
            "tags": tags,
        }
    }
