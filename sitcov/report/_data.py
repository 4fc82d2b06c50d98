"""What a report shows, gathered from a campaign store: campaigns, their runs and labels.

Everything the report prints is computed from the stored runs gathered here; nothing is
carried over from the process that ran the campaigns.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from sitcov.campaign._facts import RunFacts, iter_run_facts
from sitcov.campaign._summary import FINISHED
from sitcov.errors import ConfigError

#: Fault label shown for runs without a seeded fault (the paper's "NF").
NO_FAULT = "NF"


def fault_label(fault: Any) -> str:
    """``None``/``"none"``/``"NF"`` -> ``"NF"``; ``"f1"`` -> ``"F1"``; other names unchanged."""
    if fault is None or str(fault).lower() in ("", "none", "nf", "null"):
        return NO_FAULT
    text = str(fault)
    return text.upper() if text.lower() in ("f1", "f2", "f3") else text


def _get(obj: Any, name: str, default: Any = None) -> Any:
    if isinstance(obj, Mapping):
        return obj.get(name, default)
    return getattr(obj, name, default)


def _as_dict(value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if isinstance(value, Mapping):
        return dict(value)
    if hasattr(value, "model_dump"):
        return dict(value.model_dump())
    return {}


@dataclass
class CampaignView:
    """One stored campaign as the report sees it.

    Attributes:
        name: campaign name (user-provided: always escaped when shown).
        config: the campaign configuration as stored (JSON-like).
        tags: free tags, e.g. ``{"experiment": "faults", "generator": "random", "seed": 0,
            "fault": "f1"}`` for fault-experiment campaigns.
        hyperspace: the stored hyperspace as a dict (``Hyperspace.to_dict()``), if any.
        runs: the campaign's runs in index order (pending runs excluded).
        sitcov_version: the sitcov version that created the campaign.
        created: when the campaign was created (ISO 8601).
        setup: ``physics``, ``judge`` and ``world_model`` it was made with (``legacy`` for
            a campaign stored before these existed; see ``sitcov.campaign._summary``).
    """

    name: str
    config: dict[str, Any]
    tags: dict[str, Any]
    hyperspace: dict[str, Any] | None
    runs: list[RunFacts] = field(default_factory=list)
    sitcov_version: str = "?"
    created: str = "?"
    setup: dict[str, Any] = field(default_factory=dict)

    @property
    def generator(self) -> str:
        """The generator that chose the situations (for fault replays: the replayed one)."""
        return str(self.tags.get("generator") or self.config.get("generator") or "?")

    @property
    def fault(self) -> str:
        """``NF`` or the fault label (``F1``, ``F2``, ``F3``)."""
        if "fault" in self.tags:
            return fault_label(self.tags["fault"])
        return fault_label(self.config.get("fault"))

    @property
    def seed(self) -> Any:
        """The campaign seed."""
        return self.config.get("seed", self.tags.get("seed"))

    @property
    def is_fault_experiment(self) -> bool:
        """True for campaigns written by ``sitcov experiment faults``."""
        return self.tags.get("experiment") == "faults"


def _campaign_config(info: Any, runs: Sequence[RunFacts]) -> dict[str, Any]:
    config = _as_dict(_get(info, "config"))
    if not config and runs:
        config = _as_dict(runs[0].config)
    return config


def _setup(info: Any) -> dict[str, Any]:
    """Physics, judge and world model of a stored campaign (empty if it cannot say)."""
    from sitcov.campaign._store import CampaignInfo
    from sitcov.campaign._summary import campaign_setup

    return campaign_setup(info) if isinstance(info, CampaignInfo) else {}


def _ordered(infos: list[Any]) -> list[Any]:
    """Store order, except that fault-experiment campaigns (written in parallel, so in no
    fixed order) are sorted by generator (first seen), seed and fault."""
    gens: dict[str, int] = {}
    faults = list(("NF", "F1", "F2", "F3"))

    def key(item: tuple[int, Any]) -> tuple:
        position, info = item
        tags = _as_dict(_get(info, "tags"))
        if tags.get("experiment") != "faults":
            return (0, position)
        gen = gens.setdefault(str(tags.get("generator")), len(gens))
        label = fault_label(tags.get("fault"))
        rank = faults.index(label) if label in faults else len(faults)
        return (1, gen, str(tags.get("seed")).zfill(12), rank, position)

    return [info for _, info in sorted(enumerate(infos), key=key)]


def load_campaigns(store: Any, names: Sequence[str] | None = None) -> list[CampaignView]:
    """The campaigns of ``store`` (all, or those named, in the order given) with their runs.

    Raises:
        ConfigError: a named campaign is not in the store.
    """
    infos = list(store.campaigns())
    by_name = {str(_get(info, "name")): info for info in infos}
    if names:
        missing = [n for n in names if n not in by_name]
        if missing:
            known = ", ".join(sorted(by_name))
            raise ConfigError(
                field="campaign",
                value=missing[0],
                expected=f"one of: {known}" if known else "a stored campaign",
            )
        chosen = [by_name[n] for n in names]
    else:
        chosen = infos
    views = []
    for info in _ordered(chosen) if not names else chosen:
        name = str(_get(info, "name"))
        runs = list(iter_run_facts(store, name, FINISHED))  # slim: 100k runs fit
        hyperspace = _get(info, "hyperspace")
        views.append(
            CampaignView(
                name=name,
                config=_campaign_config(info, runs),
                tags=_as_dict(_get(info, "tags")),
                hyperspace=_as_dict(hyperspace) or None,
                runs=runs,
                sitcov_version=str(_get(info, "sitcov_version", "?")),
                created=str(_get(info, "created", "?")),
                setup=_setup(info),
            )
        )
    return views


def series_key(view: CampaignView) -> tuple[str, str]:
    """(generator, fault): the runs the report compares side by side."""
    return view.generator, view.fault


def group_runs(views: Sequence[CampaignView]) -> dict[tuple[str, str], list[RunFacts]]:
    """Runs pooled by (generator, fault), NF first, then faults, generators in first-seen order."""
    groups: dict[tuple[str, str], list[RunFacts]] = {}
    for view in views:
        groups.setdefault(series_key(view), []).extend(view.runs)

    generators = list(dict.fromkeys(g for g, _ in groups))
    faults = sorted({f for _, f in groups}, key=lambda f: (f != NO_FAULT, f))
    return {(g, f): groups[(g, f)] for f in faults for g in generators if (g, f) in groups}
