"""Failure rates broken down by actor kind and by conflict type.

Which road users a run had, and how each met the ego, are read from the run's bins through
the hyperspace: the ``intsit`` element's value is the primary actor (``kind``, default
``car``; ``type``, the conflict type) and each ``actor2``, ``actor3``, ... element's value
is ``"none"`` or ``{kind, route, behaviour?, conflict?}``. A run counts in the row of every
kind (and type) among its actors, so rows overlap when a run mixes kinds: each row is the
failure rate of the runs *involving* that kind, with a Wilson 95% interval, as the per-bin
tables.

An ``intsit`` value without a ``type`` is a paper situation: the paper calls all twelve
cross-collisions, so it counts as ``crossing`` (as ``pedestrian_crossing`` /
``cyclist_crossing`` for those kinds). An actor slot without ``conflict`` gets its type
from ``slot_types`` (``(ego route, kind, route) -> type``, what the map's geometry says;
see ``sitcov.campaign._breakdown``) and is left out of the type rows if that does not know.

Only the kinds and types the hyperspace can produce get rows, so the paper's hyperspace
gives one row each (car, crossing).

A third table, ``hit_kind``, says which road user the ego actually hit: per kind, the
collisions with a road user of that kind (``metrics["collision_kind"]`` of the run), their
rate among the judged runs involving that kind (Wilson 95%) and their share of all
collisions. A run that collided without storing the kind (the paper's two-car scene, whose
only other road user is its car OV, and databases from before actors) hit its primary
actor: the ``intsit`` value's kind.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sitcov.analysis._statuses import STATUSES
from sitcov.hyperspace import Hyperspace

#: Kinds in the order rows are shown (others after them, alphabetically).
KIND_ORDER = ("car", "truck", "cyclist", "pedestrian")
#: Conflict types in the order rows are shown: ``sitcov.sim.embedded._conflicts.CONFLICT_TYPES``,
#: repeated to keep analysis free of simulator imports (a test keeps the two equal).
TYPE_ORDER = (
    "crossing",
    "merging",
    "diverging",
    "following",
    "pedestrian_crossing",
    "cyclist_crossing",
    "cyclist_merging",
    "cyclist_diverging",
    "cyclist_following",
    "cyclist_right_hook",
)
#: A collision whose run stores no kind of road user hit (see :func:`run_hit`).
HIT_UNSTORED = "?"
#: (ego route, actor kind, actor route) -> conflict type.
SlotTypes = Mapping[tuple[str, str, str], str]
_SLOT = re.compile(r"actor\d+$")
#: A paper intsit value (no ``type``) of each kind.
_UNTYPED = {"pedestrian": "pedestrian_crossing", "cyclist": "cyclist_crossing"}


def actor_elements(hs: Hyperspace) -> list[str]:
    """The elements that describe actors: ``intsit`` and the ``actorN`` slots."""
    return [n for n in hs.element_names if n == "intsit" or _SLOT.match(n)]


def _intsit_role(value: Any) -> tuple[str | None, str | None, str | None]:
    """(kind, type, ego route) of an intsit value (all None when it is not a mapping)."""
    if not isinstance(value, Mapping):
        return None, None, None
    kind = str(value.get("kind") or "car")
    typ = value.get("type") or _UNTYPED.get(kind, "crossing")
    ego = value.get("ego")
    return kind, str(typ), None if ego is None else str(ego)


def _slot_role(value: Any) -> tuple[str | None, str | None, str | None]:
    """(kind, explicit conflict type, route) of an actor slot's value (None for "none")."""
    if not isinstance(value, Mapping) or "kind" not in value:
        return None, None, None
    conflict = value.get("conflict")
    route = value.get("route")
    return str(value["kind"]), None if conflict is None else str(conflict), str(route)


def _ordered(seen: set[str], order: tuple[str, ...]) -> list[str]:
    return [k for k in order if k in seen] + sorted(seen - set(order))


class Roles:
    """Per actor element and bin: kind and conflict-type codes, for counting with numpy.

    ``kind_codes[e]`` maps a bin index of element ``e`` to a kind index (-1: no actor);
    ``type_codes[e]`` is a 2-D table (intsit bin, slot bin) -> type index (-1: unknown),
    since a slot's conflict type depends on the ego's route.
    """

    def __init__(self, hs: Hyperspace, slot_types: SlotTypes | None = None) -> None:
        self.columns = [hs.element_names.index(n) for n in actor_elements(hs)]
        intsit = hs.element_names.index("intsit") if "intsit" in hs.element_names else None
        self.intsit = intsit
        egos = self._egos(hs)
        roles = {e: self._roles(hs, e, egos, slot_types or {}) for e in self.columns}
        kinds = {k for r in roles.values() for k, _ in r.values() if k}
        types = {t for r in roles.values() for _, ts in r.values() for t in ts if t}
        self.kinds = _ordered(kinds, KIND_ORDER)
        self.types = _ordered(types, TYPE_ORDER)
        n_ego = len(egos) or 1
        self.kind_codes: dict[int, np.ndarray] = {}
        self.type_codes: dict[int, np.ndarray] = {}
        for e, per_bin in roles.items():
            self.kind_codes[e] = np.array(
                [self.kinds.index(k) if k else -1 for k, _ in per_bin.values()], dtype=np.int64
            ).reshape(-1)
            table = np.full((n_ego, len(per_bin)), -1, dtype=np.int64)
            for b, (_, ts) in per_bin.items():
                for i, t in enumerate(ts):
                    table[i, b] = self.types.index(t) if t else -1
            self.type_codes[e] = table

    @staticmethod
    def _egos(hs: Hyperspace) -> list[str | None]:
        """The ego route of each intsit bin (empty without intsit)."""
        if "intsit" not in hs.element_names:
            return []
        element = hs.elements[hs.element_names.index("intsit")]
        return [_intsit_role(b.value)[2] for b in element.bins]

    def _roles(
        self, hs: Hyperspace, e: int, egos: list[str | None], slot_types: SlotTypes
    ) -> dict[int, tuple[str | None, list[str | None]]]:
        """Bin index -> (kind, type per intsit bin) of element ``e``."""
        element = hs.elements[e]
        n_ego = len(egos) or 1
        out = {}
        for b, bin_ in enumerate(element.bins):
            if e == self.intsit:
                kind, typ, _ = _intsit_role(bin_.value)
                types: list[str | None] = [typ] * n_ego
            else:
                kind, typ, route = _slot_role(bin_.value)
                types = [
                    typ or (slot_types.get((ego, kind, route)) if kind and ego else None)
                    for ego in (egos or [None])
                ]
            out[b] = (kind, types)
        return out

    @property
    def empty(self) -> bool:
        """True when the hyperspace has no actor elements (nothing to break down)."""
        return not self.columns

    def masks(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Boolean (runs x kinds) and (runs x types): which kinds / types each run involves."""
        n = idx.shape[0]
        kinds = np.zeros((n, len(self.kinds)), dtype=bool)
        types = np.zeros((n, len(self.types)), dtype=bool)
        rows = np.arange(n)
        ego = idx[:, self.intsit] if self.intsit is not None else np.zeros(n, dtype=np.int64)
        for e in self.columns:
            k = self.kind_codes[e][idx[:, e]]
            kinds[rows[k >= 0], k[k >= 0]] = True
            t = self.type_codes[e][ego, idx[:, e]]
            types[rows[t >= 0], t[t >= 0]] = True
        return kinds, types


def breakdown_rows(
    mask: np.ndarray, codes: np.ndarray, names: list[str], row: Any
) -> dict[str, dict[str, Any]]:
    """Per column of ``mask`` (runs x names): ``row`` of its runs' status counts.

    Args:
        codes: each run's status index into ``sitcov.analysis._statuses.STATUSES``
            (pass, fail, error, timeout; -1: not tallied).
        row: builds a row from ``{status: count}`` (``_summary._bin_row``).
    """
    onehot = np.zeros((len(codes), len(STATUSES)), dtype=np.int64)
    tallied = codes >= 0
    onehot[np.flatnonzero(tallied), codes[tallied]] = 1
    counts = mask.T.astype(np.int64) @ onehot
    return {
        name: row(dict(zip(STATUSES, map(int, counts[i]), strict=True)))
        for i, name in enumerate(names)
    }


def breakdowns_of(
    roles: Roles,
    idx: np.ndarray,
    codes: np.ndarray,
    row: Any,
    hits: Sequence[str | None] = (),
    rate: Any = None,
) -> dict[str, dict[str, dict[str, Any]]]:
    """``{"actor_kind": {kind: row}, "conflict_type": {type: row}}`` ({} without actors),
    and ``"hit_kind"`` (:func:`hit_rows`) when each run's ``hits`` and ``rate`` are given."""
    if roles.empty:
        return {}
    kinds, types = roles.masks(idx)
    out = {
        "actor_kind": breakdown_rows(kinds, codes, roles.kinds, row),
        "conflict_type": breakdown_rows(types, codes, roles.types, row),
    }
    if rate is not None and len(hits) == len(codes):
        out["hit_kind"] = hit_rows(roles, idx, kinds, codes, hits, rate)
    return out


def run_hit(run: Any, collided: bool) -> str | None:
    """The kind of road user the ego hit in ``run``: a fact's ``hit`` or a record's
    ``metrics["collision_kind"]``; :data:`HIT_UNSTORED` if the run ``collided`` without
    storing it; None without a collision."""
    if type(run) is dict or isinstance(run, Mapping):
        hit = run.get("hit")
    elif hasattr(run, "hit"):
        hit = run.hit
    else:
        outcome = getattr(run, "outcome", None)
        hit = None if outcome is None else outcome.metrics.get("collision_kind")
    if hit is None:
        return HIT_UNSTORED if collided else None
    return str(hit)


def hit_rows(
    roles: Roles,
    idx: np.ndarray,
    involved: np.ndarray,
    codes: np.ndarray,
    hits: Sequence[str | None],
    rate: Any,
) -> dict[str, dict[str, Any]]:
    """Per kind of road user the ego hit: ``collisions`` (runs in which it hit one),
    ``generated`` and ``judged`` (runs involving the kind), ``collision_rate`` and ``ci95``
    (collisions in judged runs / judged, Wilson) and ``share`` of all collisions.

    Args:
        involved: (runs x ``roles.kinds``) which kinds each run involves (``Roles.masks``).
        hits: each run's :func:`run_hit`.
        rate: ``(count, judged) -> (rate, ci95)``.
    """
    primary = (
        roles.kind_codes[roles.intsit][idx[:, roles.intsit]]
        if roles.intsit is not None
        else np.full(len(hits), -1, dtype=np.int64)
    )
    names = list(roles.kinds)
    for h in hits:
        if h not in (None, HIT_UNSTORED) and h not in names:
            names.append(h)
    hit = np.array(
        [
            (int(primary[i]) if h == HIT_UNSTORED else names.index(h)) if h is not None else -1
            for i, h in enumerate(hits)
        ],
        dtype=np.int64,
    ).reshape(-1)
    judged = (codes == 0) | (codes == 1)  # pass, fail (sitcov.analysis._statuses.STATUSES)
    total = int((hit >= 0).sum())
    out = {}
    for k, name in enumerate(names):
        mine = hit == k
        runs = involved[:, k] | mine if k < involved.shape[1] else mine
        n, n_judged = int((mine & judged).sum()), int((runs & judged).sum())
        r, ci = rate(n, n_judged)
        out[name] = {
            "collisions": int(mine.sum()),
            "generated": int(runs.sum()),
            "judged": n_judged,
            "collision_rate": r,
            "ci95": ci,
            "share": int(mine.sum()) / total if total else None,
        }
    return out


def run_roles(
    values: Mapping[str, Any], slot_types: SlotTypes | None = None
) -> tuple[list[str], list[str]]:
    """The actor kinds and conflict types of one situation's values (sorted as the rows
    of :func:`breakdowns`, each once): what an export writes per run."""
    kinds: set[str] = set()
    types: set[str] = set()
    kind, typ, ego = _intsit_role(values.get("intsit"))
    if kind:
        kinds.add(kind)
        types.add(str(typ))
    for name, value in values.items():
        if not _SLOT.match(str(name)):
            continue
        kind, typ, route = _slot_role(value)
        if kind:
            kinds.add(kind)
            typ = typ or (slot_types or {}).get((str(ego), kind, str(route)))
            if typ:
                types.add(typ)
    return _ordered(kinds, KIND_ORDER), _ordered(types, TYPE_ORDER)
