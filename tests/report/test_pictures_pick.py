"""Which failing runs the report pictures: failure kinds in proportion, hit actor named."""

from __future__ import annotations

from types import SimpleNamespace

from hypothesis import given
from hypothesis import strategies as st

from sitcov.report._pictures import _pick, _proportional, _what_happened
from sitcov.sim import Outcome, Trace


@given(
    st.dictionaries(
        st.sampled_from(["collision", "road_departure", "lane_departure"]),
        st.integers(1, 300),
        min_size=1,
    ),
    st.integers(0, 12),
)
def test_slots_add_up_and_never_exceed_a_kind(counts, n):
    n = min(n, sum(counts.values()))
    slots = _proportional(counts, n)
    assert sum(slots.values()) == n
    assert all(0 <= slots[k] <= counts[k] for k in counts)
    if n >= len(counts):
        assert all(slots[k] >= 1 for k in counts)


def _run(i, kind, intsit):
    return SimpleNamespace(status="fail", failure_kind=kind, bins={"intsit": intsit}, index=i)


def test_pictured_kinds_follow_the_campaign_s_proportions():
    runs = [_run(i, "collision", f"S{i % 5}") for i in range(91)]
    runs += [_run(100 + i, "road_departure", f"S{i % 3}") for i in range(27)]
    picked = _pick(runs, 4)
    assert [r.failure_kind for r in picked].count("road_departure") == 1
    assert len({r.bins["intsit"] for r in picked if r.failure_kind == "collision"}) == 3


def test_caption_names_the_road_user_hit():
    trace = Trace(
        ego=[(0, 0, 0, 0, 1)],
        ov=[(0, 5, 0, 0, 1)],
        meta={"actors": {"ov": {"kind": "car"}, "actor2": {"kind": "pedestrian"}}},
        actors={"ov": [(0, 5, 0, 0, 1)], "actor2": [(0, 1, 1, 0, 1)]},
    )
    hit = Outcome(
        status="fail",
        end_reason="collision",
        collision=True,
        trace=trace,
        metrics={"collision_actor": "actor2", "collision_kind": "pedestrian"},
        failure_kind="collision",
    )
    assert _what_happened(hit) == "collision with actor2 (pedestrian)"
    two_cars = Outcome(
        status="fail",
        end_reason="collision",
        collision=True,
        failure_kind="collision",
        trace=Trace(ego=[(0, 0, 0, 0, 1)], ov=[(0, 5, 0, 0, 1)]),
    )
    assert _what_happened(two_cars) == "collision with the OV (car)"
