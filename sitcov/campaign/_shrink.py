"""Minimal failing situation: which of a failing run's bins are necessary for it to fail.

Starting from a stored failing run, elements are moved to their *benign* bin and the
situation re-run (the stack and backend rebuilt from the stored config, as a replay):

- benign bin of an element = what physics calls mild, not what happened to fail least:
  the bin an element's hyperspace metadata names (``benign: LABEL``); else for the
  weather elements clear and dry (the lowest cloudiness, rain, puddles, wetness, wind and
  fog density; the highest friction and fog start distance); else ``none`` for an actor
  element that has it; only elements with no such meaning (the intersection situation, a
  user's categories) fall back to the bin with the lowest add-one-smoothed failure rate
  ``(failures + 1) / (judged + 2)`` among the judged runs (ties: the earlier bin);
- "still fails" = fails in at least ``min_rate`` of ``repeats`` runs and then also of
  ``2 * repeats`` runs (the second batch is run only when the first passes: a cheap
  two-stage test that halves the chance of accepting a set near the threshold by luck);
  the seeds are the stored run's seed plus seeds derived from it;
- delta debugging (ddmin, Zeller & Hildebrandt 2002) over the set of elements not already
  in their benign bin: first halves (jointly), then smaller chunks and complements, down
  to single elements, so the result is 1-minimal: moving any one remaining element to its
  benign bin stops the failure (the test shows it);
- the shrunk situation is then re-run on ``confirm`` fresh derived seeds (disjoint from
  the decision seeds) and its failure rate given with a Wilson interval.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import ValidationError

from sitcov.analysis import wilson_interval
from sitcov.campaign._build import build_backend, build_stack
from sitcov.campaign._config import CampaignConfig, _config_error
from sitcov.campaign._executors import execute
from sitcov.campaign._runner import judge_of
from sitcov.campaign._store import Store
from sitcov.errors import ConfigError
from sitcov.hyperspace import Hyperspace, Situation
from sitcov.sim import Judge

_DECIDE_STREAM, _CONFIRM_STREAM = 2, 3  # seed streams, apart from the campaign's 0 and 1

#: default repetitions per "still fails" decision, and the share of them that must fail
REPEATS, MIN_RATE, CONFIRM = 10, 0.6, 20


def derived_seeds(seed: int, stream: int, n: int) -> list[int]:
    """``n`` 32-bit simulation seeds derived from a run's seed (stream 2: decisions, 3:
    confirmation), independent of the campaign's own seed streams."""
    state = np.random.SeedSequence([stream, int(seed)]).generate_state(n, dtype=np.uint32)
    return [int(s) for s in state]


#: weather elements whose mildest bin is the lowest value, and those whose is the highest
MILD_LOW = frozenset(
    {"cloudiness", "precipitation", "precipitation_deposits", "wetness", "wind_intensity",
     "fog_density"}
)  # fmt: skip
MILD_HIGH = frozenset({"friction", "fog_distance"})


def _numeric(label: str, value: Any) -> float | None:
    try:
        return float(value if value is not None else label)
    except (TypeError, ValueError):
        return None


def physical_benign(el: Any) -> tuple[str, str] | None:
    """(bin, basis) of an element's mildest bin by meaning, or None when it has none."""
    named = el.metadata.get("benign")
    if named is not None and str(named) in el.labels:
        return str(named), "hyperspace"
    if el.name in MILD_LOW | MILD_HIGH:
        values = {b.label: _numeric(b.label, b.value) for b in el.bins}
        if all(v is not None for v in values.values()):
            pick = min if el.name in MILD_LOW else max
            return pick(el.labels, key=lambda lab: values[lab]), "physics"
    if "none" in el.labels:
        return "none", "no actor"
    return None


def benign_basis(hs: Hyperspace) -> dict[str, str]:
    """Per element, why its benign bin is benign: ``physics``, ``hyperspace`` (its
    metadata), ``no actor`` or ``observed`` (lowest smoothed failure rate)."""
    return {el.name: (physical_benign(el) or ("", "observed"))[1] for el in hs.elements}


def benign_bins(hs: Hyperspace, runs: Sequence[Any]) -> dict[str, str]:
    """Per element, its mildest bin by meaning (:func:`physical_benign`), else the bin
    with the lowest add-one-smoothed failure rate in ``runs``."""
    out = {}
    for el in hs.elements:
        known = physical_benign(el)
        if known is not None:
            out[el.name] = known[0]
            continue
        tallies = {label: [0, 0] for label in el.labels}
        for r in runs:
            if r.status in ("pass", "fail") and r.bins.get(el.name) in tallies:
                t = tallies[r.bins[el.name]]
                t[0] += r.status == "fail"
                t[1] += 1
        out[el.name] = min(el.labels, key=lambda lab: (tallies[lab][0] + 1) / (tallies[lab][1] + 2))
    return out


def ddmin(items: Sequence[str], fails: Callable[[frozenset[str]], bool]) -> frozenset[str]:
    """A 1-minimal subset of ``items`` for which ``fails`` holds (``fails(items)`` must).

    ``fails(S)`` runs the situation with the elements of S at their failing bins and the
    others at their benign bins.
    """
    current = list(items)
    if fails(frozenset()):
        return frozenset()
    n = 2
    while len(current) >= 2:
        size = math.ceil(len(current) / n)
        chunks = [current[i : i + size] for i in range(0, len(current), size)]
        reduced = False
        for chunk in chunks:
            if fails(frozenset(chunk)):
                current, n, reduced = chunk, 2, True
                break
        if not reduced:
            for chunk in chunks:
                rest = [x for x in current if x not in chunk]
                if len(chunks) > 2 and fails(frozenset(rest)):
                    current, n, reduced = rest, max(n - 1, 2), True
                    break
        if not reduced:
            if n >= len(current):
                break
            n = min(len(current), 2 * n)
    return frozenset(current)


@dataclass
class ShrinkResult:
    """What ``shrink_run`` found (JSON-ready through :meth:`to_dict`)."""

    campaign: str
    index: int
    seed: int
    original_bins: dict[str, str]
    benign: dict[str, str]
    candidates: list[str]
    necessary: list[str]
    shrunk_bins: dict[str, str]
    repeats: int
    min_rate: float
    min_failures: int
    original_failures: int
    trials: list[dict[str, Any]] = field(default_factory=list)
    confirm: dict[str, Any] = field(default_factory=dict)
    message: str | None = None
    basis: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """All fields as a dict."""
        return dict(self.__dict__)


class _Trial:
    """Runs a situation on the decision seeds, caching results by the kept set."""

    def __init__(self, hs: Hyperspace, run: Any, benign: Mapping[str, str], sim: Any, stack: Any,
                 seeds: list[int], min_rate: float, config: CampaignConfig,
                 config_data: Mapping[str, Any]) -> None:  # fmt: skip
        self.hs, self.run, self.benign = hs, run, benign
        self.sim, self.stack = sim, stack
        self.seeds, self.min_rate = seeds, min_rate
        self.cache: dict[frozenset[str], bool] = {}
        # verdicts as the campaign stored them (see _replay): its judge, legacy = collision;
        # or the judge given on the command line
        self.judge = judge_of(config) if "judge" in config_data else Judge.from_spec("paper")
        self.log: list[dict[str, Any]] = []

    def situation(self, kept: frozenset[str]) -> Situation | None:
        bins, values = {}, {}
        rng = np.random.default_rng(self.run.seed)
        for el in self.hs.elements:
            if el.name in kept or self.run.bins[el.name] == self.benign[el.name]:
                bins[el.name], values[el.name] = (
                    self.run.bins[el.name],
                    self.run.situation.values[el.name],
                )
            else:
                bins[el.name] = self.benign[el.name]
                values[el.name] = el.bin(bins[el.name]).draw(rng)
        if not self.hs.is_allowed(bins):
            return None
        return Situation(bins, {k: _plain(v) for k, v in values.items()})

    def failures(self, kept: frozenset[str], seeds: Sequence[int]) -> int | None:
        sit = self.situation(kept)
        if sit is None:
            return None
        task_sit = sit.to_dict()
        return sum(
            self.judge(execute(self.sim, self.stack, (0, task_sit, s), False)[1]).status == "fail"
            for s in seeds
        )

    def __call__(self, kept: frozenset[str]) -> bool:
        """Still fails: >= min_rate of the first seeds, then also of twice as many."""
        if kept not in self.cache:
            half = len(self.seeds) // 2
            k = self.failures(kept, self.seeds[:half])
            runs = half
            if k is not None and k >= math.ceil(self.min_rate * half):
                k += self.failures(kept, self.seeds[half:]) or 0
                runs = len(self.seeds)
            passed = k is not None and k >= math.ceil(self.min_rate * runs)
            self.cache[kept] = passed and runs == len(self.seeds)
            self.log.append({"kept": sorted(kept), "failures": k, "runs": runs})
        return self.cache[kept]


def _rate(failures: int | None, runs: int) -> dict[str, Any]:
    ci = wilson_interval(failures or 0, runs)
    return {"runs": runs, "failures": failures, "rate": (failures or 0) / runs,
            "ci95": list(ci) if ci else None}  # fmt: skip


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def _stack_config(run: Any, overrides: Mapping[str, Any] | None) -> CampaignConfig:
    data = {k: v for k, v in run.config.items() if k != "workers"}
    for key, value in (overrides or {}).items():
        if value is None:
            continue
        if key in ("backend_options", "av_params"):
            data[key] = {**(data.get(key) or {}), **value}
        else:
            data[key] = value
    try:
        return CampaignConfig(**data)
    except ValidationError as exc:
        raise _config_error(exc, None) from None


def shrink_run(
    store: Store,
    campaign: str,
    index: int,
    *,
    overrides: Mapping[str, Any] | None = None,
    repeats: int = REPEATS,
    min_rate: float = MIN_RATE,
    confirm: int = CONFIRM,
    keep: Sequence[str] | None = None,
) -> ShrinkResult:
    """Shrink the failing run ``campaign:index`` to the bins necessary for its failure.

    Args:
        store: the campaign store holding the run.
        overrides: stack/backend settings replacing the stored ones (``sitcov run`` flags).
        repeats: runs of each stage of a "still fails" decision (the run's seed + derived
            seeds; a set that passes the first stage is run ``repeats`` more times).
        min_rate: share of ``repeats`` that must fail.
        confirm: runs of the shrunk situation on fresh seeds for its failure rate.
        keep: skip the search and only confirm: these elements keep their failing bins,
            the others move to benign (the replay of an earlier shrink).

    Raises:
        StoreError: no such run. ConfigError: the run did not fail, or bad arguments.
    """
    if repeats < 1 or not 0 < min_rate <= 1 or confirm < 0:
        raise ConfigError(field="repeats/min-rate/confirm", value=(repeats, min_rate, confirm),
                          expected="repeats >= 1, 0 < min-rate <= 1, confirm >= 0")  # fmt: skip
    run = store.get_run(campaign, index, with_trace=False)
    if run.status != "fail":
        raise ConfigError(f"{store.location}: run {campaign}:{index} has status {run.status!r}: "
                          "only a failing run can be shrunk")  # fmt: skip
    hs = Hyperspace.from_dict(store.campaign(campaign).hyperspace)
    benign = benign_bins(hs, store.runs(campaign, ("pass", "fail")))
    candidates = [e for e in hs.element_names if run.bins[e] != benign[e]]
    if keep is not None:
        unknown = [e for e in keep if e not in hs.element_names]
        if unknown:
            raise ConfigError(field="--keep", value=unknown[0],
                              expected=" | ".join(hs.element_names))  # fmt: skip
    config = _stack_config(run, overrides)
    sim, stack = build_backend(config), build_stack(config)
    min_failures = math.ceil(min_rate * 2 * repeats)
    seeds = [run.seed, *derived_seeds(run.seed, _DECIDE_STREAM, 2 * repeats - 1)]
    given = {**run.config, **{k: v for k, v in (overrides or {}).items() if v is not None}}
    trial = _Trial(hs, run, benign, sim, stack, seeds, min_rate, config, given)
    try:
        result = ShrinkResult(campaign, index, run.seed, dict(run.bins), benign, candidates,
                              [], {}, repeats, min_rate, min_failures, 0,
                              basis=benign_basis(hs))  # fmt: skip
        result.original_failures = trial.failures(frozenset(candidates), seeds) or 0
        if keep is not None:
            kept = frozenset(e for e in keep if e in candidates)
        elif result.original_failures < min_failures:
            result.message = (
                f"the run fails in {result.original_failures} of {2 * repeats} seeds (needs "
                f"{min_failures}): its failure depends on the seed more than on the bins"
            )
            kept = frozenset(candidates)
        else:
            kept = ddmin(candidates, trial)
        result.necessary = [e for e in hs.element_names if e in kept]
        sit = trial.situation(kept)
        result.shrunk_bins = dict(sit.bins) if sit is not None else {}
        result.trials = trial.log
        if confirm:
            fresh = derived_seeds(run.seed, _CONFIRM_STREAM, confirm)
            result.confirm = _rate(trial.failures(kept, fresh), confirm)
            result.confirm["original"] = _rate(
                trial.failures(frozenset(candidates), fresh), confirm
            )
    finally:
        stack.close()
        sim.close()
    return result


def shrink_lines(result: ShrinkResult, db: Any) -> list[str]:
    """The console text of ``sitcov shrink``: conditions, evidence, rate, replay line."""
    run_id = f"{result.campaign}:{result.index}"
    n = 2 * result.repeats
    lines = [f"run {run_id} (seed {result.seed}) fails in {result.original_failures} of "
             f"{n} seeds; 'still fails' = >= {result.min_failures} of {n} (stopping at "
             f"{result.repeats} if fewer than {result.min_rate:.0%} of them fail)"]  # fmt: skip
    if result.message:
        lines.append(result.message)
    by_kept = {tuple(t["kept"]): t for t in result.trials}
    lines.append(f"necessary conditions ({len(result.necessary)} of "
                 f"{len(result.candidates)} non-benign elements):")  # fmt: skip
    for e in result.necessary:
        without = tuple(sorted(x for x in result.necessary if x != e))
        t = by_kept.get(without)
        evidence = (f"; at benign {result.benign[e]} it fails {t['failures']}/{t['runs']}"
                    if t and t["failures"] is not None else "")  # fmt: skip
        lines.append(f"  {e} = {result.original_bins[e]}{evidence}")
    if not result.necessary and not result.message:
        lines.append("  none: it fails with every element at its benign bin")
    moved = [f"{e}={result.benign[e]}" for e in result.candidates if e not in result.necessary]
    lines.append("moved to benign bins: " + (", ".join(moved) or "none"))
    basis = result.basis or {}
    observed = [e for e in result.candidates if basis.get(e) == "observed"]
    lines.append(
        "benign = clear, dry, friction 1 and no extra actor by physics"
        + (f"; by lowest observed failure rate: {', '.join(observed)}" if observed else "")
    )
    c = result.confirm
    if c:
        lo, hi = c["ci95"]
        o = c["original"]
        lines.append(
            f"on {c['runs']} fresh seeds the shrunk situation fails {c['failures']}/"
            f"{c['runs']} = {100 * c['rate']:.0f}% [{100 * lo:.0f}, {100 * hi:.0f}], "
            f"the original {o['failures']}/{o['runs']} = {100 * o['rate']:.0f}%"
        )
    keep = ",".join(result.necessary) or '""'
    lines.append(f"replay: sitcov shrink --db {db} {run_id} --keep {keep}")
    lines.append(f"original: sitcov replay --db {db} {run_id}")
    return lines
