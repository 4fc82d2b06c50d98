"""Python plug-in stacks: ``package.module:Class`` paths and ``sitcov.av`` entry points."""

from __future__ import annotations

import importlib
import sys
import textwrap
from pathlib import Path

import pytest

from sitcov.av import AVStack, EgoState, Observation, RunInfo, make_stack
from sitcov.errors import ConfigError, UnknownPluginError
from sitcov.perception import CameraSpec, Detection

ROOT = Path(__file__).resolve().parents[2]

PLUGIN_MODULE = textwrap.dedent(
    """
    from sitcov.av import AVStack, Control

    class Creeper(AVStack):
        name = "creeper"
        def reset(self, info):
            self.dt = info.dt
        def step(self, observation):
            return Control(throttle=0.1)

    class Half(AVStack):  # forgets step
        def reset(self, info):
            pass

    class NotAStack:
        pass
    """
)


@pytest.fixture
def plugin_dist(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An installed-looking distribution on sys.path declaring ``sitcov.av`` entry points."""
    (tmp_path / "creeper_pkg.py").write_text(PLUGIN_MODULE)
    info = tmp_path / "creeper_pkg-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: creeper-pkg\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(
        "[sitcov.av]\n"
        "creeper = creeper_pkg:Creeper\n"
        "half = creeper_pkg:Half\n"
        "not-a-stack = creeper_pkg:NotAStack\n"
        "broken = creeper_pkg_missing:Thing\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    yield tmp_path
    sys.modules.pop("creeper_pkg", None)


def run_info() -> RunInfo:
    route = tuple((float(i), 0.0) for i in range(30))
    return RunInfo(0.05, route, route[-1], "t-junction", CameraSpec(), 0)


def test_entry_point_stack_is_found_and_listed(plugin_dist: Path) -> None:
    from sitcov._plugins import available

    assert "creeper" in available("av")
    stack = make_stack("creeper")
    stack.reset(run_info())
    assert type(stack).__name__ == "Creeper" and stack.step(None).throttle == 0.1


@pytest.mark.parametrize(
    ("spec", "words"),
    [
        ("half", ["'half'", "step", "AVStack", "sitcov.av"]),
        ("not-a-stack", ["'not-a-stack'", "NotAStack", "AVStack", "sitcov.av"]),
        ("broken", ["'broken'", "creeper_pkg_missing:Thing", "sitcov.av", "cannot be loaded"]),
        ("creeper_pkg:Half", ["creeper_pkg:Half", "step", "AVStack"]),
        ("creeper_pkg:Nope", ["creeper_pkg:Nope", "has no 'Nope'"]),
        ("no_such_module_xyz:Stack", ["no_such_module_xyz", "cannot import"]),
    ],
)
def test_bad_plugins_name_the_plugin_group_and_expectation(
    plugin_dist: Path, spec: str, words: list[str]
) -> None:
    with pytest.raises(ConfigError) as caught:
        make_stack(spec)
    for word in words:
        assert word in str(caught.value)


def test_unknown_name_lists_what_exists(plugin_dist: Path) -> None:
    with pytest.raises(UnknownPluginError) as caught:
        make_stack("no-such-stack")
    assert "'no-such-stack'" in str(caught.value)
    assert "creeper" in str(caught.value) and "reference" in str(caught.value)


def test_module_class_path_loads_the_example_plugin(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(ROOT))
    stack = make_stack("examples.plugin_stack:PluginStack")
    assert isinstance(stack, AVStack) and stack.config()["name"] == "plugin-example"
    stack.reset(run_info())
    drive = stack.step(Observation(0.0, EgoState(0.0, -1.0, 0.0, 0.0, 0.0), ()))
    assert drive.throttle > 0.5 and drive.steer > 0.0  # right of the route: steer left
    close_car = Detection((300.0, 150.0, 420.0, 300.0), 0.8)  # 15 % of the width
    stop = stack.step(Observation(0.05, EgoState(0.1, -1.0, 0.0, 6.0, 0.05), (close_car,)))
    assert (stop.throttle, stop.brake) == (0.0, 1.0)


def test_reference_stack_through_the_plugin_path() -> None:
    stack = make_stack("sitcov.av:ReferenceStack", fault="f2")
    assert stack.config()["fault"] == "f2"


def test_weak_stack_ignores_the_left_half_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(ROOT))
    stack = make_stack("examples.weak_stack:WeakStack")
    reference = make_stack("reference")
    left = Detection((200.0, 150.0, 380.0, 300.0), 0.9)  # centre 290 < 400, wide: close
    right = Detection((420.0, 150.0, 600.0, 300.0), 0.9)
    for det, weak_brakes in ((left, False), (right, True)):
        for s in (stack, reference):
            s.reset(run_info())
        ego = EgoState(0.0, 0.0, 0.0, 6.0, 0.0)
        weak = stack.step(Observation(0.0, ego, (det,)))
        ref = reference.step(Observation(0.0, ego, (det,)))
        assert ref.brake == 1.0  # the reference stack brakes for both
        assert (weak.brake == 1.0) is weak_brakes


#: From the T-junction geometry (legs B = stem, L and R): approaching from B, leg L lies on
#: the ego's left; approaching from L, leg B lies on its right; approaching from R, leg B
#: lies on its left. So the OV comes from the ego's left in IntSit-5 (ego B, OV L),
#: -8 (B, L), -9 (R, B), -10 (R, B), and from its right in IntSit-3 (L, B), -4 (L, B),
#: -6 (B, R), -7 (B, R). In the other four the OV comes from straight ahead.
OV_FROM_LEFT = ("IntSit-5", "IntSit-8", "IntSit-9", "IntSit-10")
OV_FROM_RIGHT = ("IntSit-3", "IntSit-4", "IntSit-6", "IntSit-7")


def test_left_and_right_intsits_match_the_hyperspace_routes() -> None:
    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace()
    on_left = {"B": "L", "L": None, "R": "B"}  # entry leg -> the leg on the ego's left
    on_right = {"B": "R", "L": "B", "R": None}
    for label in OV_FROM_LEFT + OV_FROM_RIGHT:
        routes = hs.element("intsit").bin(label).draw()
        ego_entry, ov_entry = routes["ego"][0], routes["ov"][0]
        side = on_left if label in OV_FROM_LEFT else on_right
        assert side[ego_entry] == ov_entry, label


@pytest.mark.slow
def test_weak_stack_weakness_shows_in_the_per_bin_failure_rates(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A campaign finds the weak stack's blind left: the intervals do not overlap."""
    from sitcov.analysis import summarize, wilson_interval
    from sitcov.campaign import CampaignConfig, open_store, run_campaign
    from sitcov.hyperspace import load_hyperspace

    monkeypatch.syspath_prepend(str(ROOT))
    config = CampaignConfig(
        name="weak", av="examples.weak_stack:WeakStack", runs=240, seed=11, executor="serial"
    )
    with open_store(tmp_path / "weak.db") as store:
        run_campaign(config, store)
        summary = summarize(load_hyperspace(), store.runs("weak"))
    intsit = summary["elements"]["intsit"]
    assert summary["runs"] == 240 and summary["errors"] == 0
    left = [intsit[label] for label in OV_FROM_LEFT]
    right = [intsit[label] for label in OV_FROM_RIGHT]
    assert all(b["generated"] >= 8 for b in left + right)
    # every left bin fails more often than every right bin ...
    assert min(b["failure_rate"] for b in left) > max(b["failure_rate"] for b in right)
    # ... and, pooled per side, the 95 % Wilson intervals are far apart
    pooled = {}
    for side, bins in (("left", left), ("right", right)):
        k, n = sum(b["failures"] for b in bins), sum(b["generated"] for b in bins)
        pooled[side] = wilson_interval(k, n)
    assert pooled["left"][0] > pooled["right"][1] + 0.2, pooled
