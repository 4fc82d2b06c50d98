"""The world/perception split of run-to-run disagreement: stream AB and the shared-world pairs.

Stream AB runs the world of run seed A (wind, road users' colours and drawn speeds) with the
perception draws of run seed B (the PEM's noise, the camera frames' rain streaks).
"""

from __future__ import annotations

import dataclasses
from dataclasses import asdict
from pathlib import Path

import pytest

from sitcov.campaign import _agreement as ag
from sitcov.errors import ConfigError
from sitcov.sim import WORLD_MODEL_VERSION

#: The fake's world part fails a run when its world seed's last two decimal digits are
#: below this; its perception part flips the verdict when the perception seed's two digits
#: before those are below FLIP (other digits: independent on a side with one run seed).
WORLD_FAILS, FLIP = 40, 15


def fake_run(job: ag.Job) -> dict:
    """A verdict from the world seed, flipped by the perception seed: so a pair that shares
    the world disagrees only through the flips, P = 2 * 0.15 * 0.85 = 0.255."""
    world = ag.stream_seed(job.stream, job.seed, job.index)
    sense = ag.perception_seed(job.stream, job.seed, job.index)
    failed = (world % 100 < WORLD_FAILS) != (sense // 100 % 100 < FLIP)
    return {
        **asdict(job), "situation_id": f"sit-{job.seed}-{job.index}", "run_seed": world,
        "status": "fail" if failed else "pass", "failed": failed, "aeb_time": None,
        "cpu_s": 0.5, "wall_s": 0.5, "world_model": WORLD_MODEL_VERSION,
    }  # fmt: skip


def test_split_pairs_are_named_explicitly_and_all_is_unchanged() -> None:
    assert ag.parse_pairs("all") == [
        "pem-camera", "camera-camera", "pem-pem", "pem-camera-shared-seed"
    ]  # fmt: skip
    assert ag.parse_pairs("camera-camera, camera-camera-shared-world") == [
        "camera-camera", "camera-camera-shared-world"
    ]  # fmt: skip
    with pytest.raises(ConfigError, match="pem-pem-shared-world"):  # the error lists them
        ag.parse_pairs("camera-camera-shared-wrld")
    jobs = ag.plan_jobs([2], 3, ["camera-camera-shared-world", "pem-pem-shared-world"])
    assert {(j.perception, j.stream) for j in jobs} == {
        ("camera", "A"), ("camera", "AB"), ("pem", "A"), ("pem", "AB")
    }  # fmt: skip
    for index in range(50):
        a, b = ag.stream_seed("A", 2, index), ag.stream_seed("B", 2, index)
        assert ag.stream_seed("AB", 2, index) == a  # the world (and the row's run seed): A's
        assert ag.perception_seed("AB", 2, index) == b  # the perception draws: B's
        assert ag.perception_seed("A", 2, index) == a and ag.perception_seed("B", 2, index) == b


def test_shared_world_pair_disagrees_only_through_perception(tmp_path: Path) -> None:
    """With the fake, every side fails with p = 0.4 * 0.85 + 0.6 * 0.15 = 0.43, so
    camera-camera (independent worlds and perceptions) disagrees at 2p(1 - p) = 0.49 and
    the shared-world pairs at 2 * 0.15 * 0.85 = 0.255, in expectation.

    2 x 1000 situations: the standard deviation of a disagreement of 0.255 is 0.0097, so
    ±0.04 is 4 σ; a side AB that took B's world (disagreement ~0.5) or A's perception
    (disagreement 0) fails for certain.
    """
    pairs = ["camera-camera", "camera-camera-shared-world", "pem-pem-shared-world"]
    summary = ag.run_agreement(
        seeds=[2, 4], situations=1000, out=tmp_path / "rows.csv", run_job=fake_run, pairs=pairs
    )
    rows = ag.read_rows(tmp_path / "rows.csv")
    assert {r["stream"] for r in rows} == {"A", "B", "AB"}
    assert all(r["run_seed"] == ag.stream_seed(r["stream"], r["seed"], r["index"]) for r in rows)
    for name in ("camera-camera-shared-world", "pem-pem-shared-world"):
        row = summary["pairs"][name]["pooled"]
        assert row["n"] == 2000 and abs((1 - row["agreement"]) - 0.255) < 0.04, row
    p_fail = WORLD_FAILS / 100 * (1 - FLIP / 100) + (1 - WORLD_FAILS / 100) * FLIP / 100
    expected = 2 * p_fail * (1 - p_fail)  # 0.4902
    row = summary["pairs"]["camera-camera"]["pooled"]
    assert abs((1 - row["agreement"]) - expected) < 0.05, row
    assert "camera-camera-shared-world" in "\n".join(ag.table_lines(summary))
    # which draws decide the flips: world (A's verdict kept at AB) with probability
    # P(Fa = Fb) P(Wa != Wb) = 0.745 * 0.48 = 0.358, perception 0.255 * 0.52 = 0.133
    split = summary["ceiling_split"]["camera"]
    assert split["world"] + split["perception"] == split["flips"] == 2000 - row["agree"]
    shared = summary["pairs"]["camera-camera-shared-world"]["pooled"]
    assert split["shared_world_flips"] == 2000 - shared["agree"] and split["n"] == 2000
    assert (
        abs(split["world"] / 2000 - 0.358) < 0.04 and abs(split["perception"] / 2000 - 0.133) < 0.03
    )
    assert "ceiling_split" not in ag.summarise(ag.read_rows(tmp_path / "rows.csv"), pairs[1:], [2])
    assert "the world's draws decide them" in "\n".join(ag.table_lines(summary))


#: docs/pem.md, "Where the ceiling comes from": (flips, shared-world flips, world,
#: perception) per stack and mode, as the rows files give them.
PUBLISHED = {
    "agreement-ceiling-seed8-50.csv": {
        ("reference", "camera"): (7, 3, 4, 3), ("reference", "pem"): (10, 6, 4, 6),
        ("examples.aeb_stacks:ThreeFrames", "camera"): (13, 1, 12, 1),
        ("examples.aeb_stacks:ThreeFrames", "pem"): (11, 8, 4, 7),
    },
    "agreement-ceiling-seed8-50-more.csv": {
        ("examples.aeb_stacks:Threshold07", "camera"): (11, 5, 8, 3),
        ("examples.aeb_stacks:Threshold07", "pem"): (9, 6, 4, 5),
        ("examples.aeb_stacks:RightBlind", "camera"): (1, 1, 0, 1),
        ("examples.aeb_stacks:RightBlind", "pem"): (6, 5, 1, 5),
    },
}  # fmt: skip


def test_published_ceiling_split_is_what_the_rows_files_hold() -> None:
    data = Path(__file__).resolve().parents[2] / "docs" / "data"
    for name, expected in PUBLISHED.items():
        rows = ag.read_rows(data / name)
        for (stack, mode), (flips, shared, world, perception) in expected.items():
            split = ag.ceiling_split([r for r in rows if r["stack"] == stack], mode)
            want = {"n": 50, "flips": flips, "shared_world_flips": shared, "world": world,
                    "perception": perception}  # fmt: skip
            assert split == want, (name, stack, mode)


def _with_colour(situation, colour: str):
    """``situation`` with a declared OV colour (then the run seed draws none)."""
    values = {**situation.values, "ov_color": colour}
    return dataclasses.replace(
        situation, values=values, bins={**situation.bins, "ov_color": colour}
    )


def test_pem_run_takes_its_world_from_the_seed_and_its_noise_from_the_perception_seed() -> None:
    """Real PEM runs of seed-8 situations (carla profile: the wind exerts no force).

    With the OV's colour declared, the run seed draws nothing that acts on the world, so
    the world of A with the perception of B is run B bit for bit (the PEM's noise stream
    is B's, from the same place in it); with the colour drawn, the OV has A's colour.
    ``perception_seed`` equal to the run seed is the plain run.
    """
    runner = ag.SideRunner(ag.SideSettings())
    backend, stack = runner._side("pem")
    from sitcov._seeding import ask_rng

    differs = other_colour = 0
    for index in range(20):
        situation = runner.generator.ask(ask_rng(8, index))
        a, b = ag.stream_seed("A", 8, index), ag.stream_seed("B", 8, index)
        plain_a = backend.run(situation, stack, a, record=True)
        same = backend.run(situation, stack, a, perception_seed=a, record=True)
        assert same.trace.ego == plain_a.trace.ego and same.metrics == plain_a.metrics
        mixed = backend.run(situation, stack, a, perception_seed=b, record=True)
        colour = plain_a.trace.meta["actors"]["ov"]["color"]
        assert mixed.trace.meta["actors"]["ov"]["color"] == colour  # the world's colour: A's
        other = backend.run(situation, stack, b, record=True).trace.meta["actors"]["ov"]["color"]
        other_colour += other != colour
        declared = _with_colour(situation, "white")
        mixed = backend.run(declared, stack, a, perception_seed=b, record=True)
        plain_b = backend.run(declared, stack, b, record=True)
        assert mixed.trace.ego == plain_b.trace.ego and mixed.trace.ov == plain_b.trace.ov
        assert mixed.aeb_time == plain_b.aeb_time and mixed.status == plain_b.status
        differs += backend.run(declared, stack, a, record=True).trace.ego != mixed.trace.ego
    # the test can fail: B's colour differs from A's (13 of 20 here), and the PEM's noise
    # changes the ego's drive (20 of 20)
    assert other_colour >= 10 and differs >= 18, (other_colour, differs)


def test_side_runner_runs_stream_ab_as_world_a_perception_b() -> None:
    """The rows of stream AB are the backend's runs with ``perception_seed`` = B's seed."""
    from sitcov._seeding import ask_rng

    runner = ag.SideRunner(ag.SideSettings())
    backend, stack = runner._side("pem")
    for index in range(6):
        row = runner(ag.Job(8, index, "pem", "AB"))
        situation = runner.generator.ask(ask_rng(8, index))
        a, b = ag.stream_seed("A", 8, index), ag.stream_seed("B", 8, index)
        direct = backend.run(situation, stack, a, perception_seed=b)
        assert row["run_seed"] == a and row["stream"] == "AB"
        assert (row["failed"], row["aeb_time"]) == (
            direct.failed, None if direct.aeb_time is None else round(direct.aeb_time, 4)
        )  # fmt: skip


@pytest.mark.slow
def test_camera_shared_world_is_the_same_run_when_no_rain_falls(ssd_model) -> None:
    """Camera mode draws only the rain streaks' positions per frame: in a situation
    without rain, the world of A with the perception of B renders the same frames and
    drives exactly as run A; in rain its first frame (the same pose) differs from A's."""
    import hashlib

    from sitcov._seeding import ask_rng

    runner = ag.SideRunner(ag.SideSettings(model=str(ssd_model)))
    backend, stack = runner._side("camera")
    frames: list[str] = []
    render = backend._frame

    def recording(*args):
        image = render(*args)
        frames.append(hashlib.sha256(image.tobytes()).hexdigest())
        return image

    backend._frame = recording  # the instance's, for this runner only
    runs = {}
    for label, index in (("dry", _dry_braking_index()), ("rain", _rainy_index())):
        situation = runner.generator.ask(ask_rng(8, index))
        a, b = ag.stream_seed("A", 8, index), ag.stream_seed("B", 8, index)
        for side, seeds in (("A", {}), ("AB", {"perception_seed": b})):
            frames.clear()
            runs[label, side] = (backend.run(situation, stack, a, record=True, **seeds), frames[:])
    (plain, frames_a), (mixed, frames_ab) = runs["dry", "A"], runs["dry", "AB"]
    assert plain.aeb_time is not None and frames_a  # the frames decided something
    assert frames_ab == frames_a
    assert mixed.trace.ego == plain.trace.ego and mixed.aeb_time == plain.aeb_time
    assert mixed.trace.meta["actors"] == plain.trace.meta["actors"]  # A's colour
    (plain, frames_a), (mixed, frames_ab) = runs["rain", "A"], runs["rain", "AB"]
    assert frames_a[0] != frames_ab[0]  # the same scene, other rain streaks
    assert mixed.trace.meta["actors"] == plain.trace.meta["actors"]


def _dry_braking_index() -> int:
    """A seed-8 situation without rain whose stored camera run at A braked (from the
    published camera rows, docs/data/agreement-stacks-seed8-100-camera.csv)."""
    data = Path(__file__).resolve().parents[2] / "docs" / "data"
    rows = ag.read_rows(data / "agreement-stacks-seed8-100-camera.csv")
    bins = ag.situation_bins([8], 100)
    for r in rows:
        dry = bins[8, r["index"]]["precipitation"] == "0"
        if r["stack"] == "reference" and r["stream"] == "A" and dry and r["aeb_time"]:
            return r["index"]
    raise AssertionError("no dry seed-8 situation in which the camera run braked")


def _rainy_index() -> int:
    """The first seed-8 situation with precipitation 100."""
    bins = ag.situation_bins([8], 100)
    return next(i for i in range(100) if bins[8, i]["precipitation"] == "100")


def test_published_colour_split_of_the_stored_camera_rows() -> None:
    """docs/pem.md: on the 100 stored situations of seed 8 (four stacks, camera at A and
    B), situations whose OV draws the same colour at both run seeds flip in 2 of 64
    stack-situations, both in rain; those with different colours in 58 of 336."""
    from sitcov._seeding import ask_rng
    from sitcov.generation import make_generator
    from sitcov.perception._colors import ov_color

    data = Path(__file__).resolve().parents[2] / "docs" / "data"
    rows = ag.read_rows(data / "agreement-stacks-seed8-100-camera.csv")
    by = {(r["stack"], r["index"], r["stream"]): r for r in rows}
    generator = make_generator("random", ag._hyperspace(None))
    counts = {True: [0, 0], False: [0, 0]}  # same colour -> [flips, stack-situations]
    for index in range(100):
        values = generator.ask(ask_rng(8, index)).values
        same = ov_color(values, ag.stream_seed("A", 8, index)) == ov_color(
            values, ag.stream_seed("B", 8, index)
        )
        for stack in {r["stack"] for r in rows}:
            flip = by[stack, index, "A"]["failed"] != by[stack, index, "B"]["failed"]
            counts[same][0] += flip
            counts[same][1] += 1
            assert not (flip and same and values["precipitation"] == 0)  # dry: deterministic
    assert counts == {True: [2, 64], False: [58, 336]}
