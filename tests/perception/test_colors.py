"""The OV's colour: palette shares, a seeded draw on its own stream, the ov_color element."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from sitcov.errors import ConfigError
from sitcov.perception._colors import (
    PALETTE,
    body_contrast,
    chroma_features,
    color_rng,
    detail_contrast,
    draw_color,
    ov_color,
    resolve_color,
)
from sitcov.sim import conditions_from_values


def test_palette_shares_are_a_distribution_of_valid_colours() -> None:
    shares = [share for _, share in PALETTE.values()]
    assert sum(shares) == pytest.approx(1.0)
    assert all(share > 0 for share in shares)
    assert len({rgb for rgb, _ in PALETTE.values()}) == len(PALETTE)
    assert all(0 <= c <= 255 for rgb, _ in PALETTE.values() for c in rgb)


def test_the_draw_is_deterministic_per_run_seed() -> None:
    seeds = range(50)
    first = [ov_color({}, s) for s in seeds]
    assert first == [ov_color({}, s) for s in seeds]
    assert len(set(first)) >= 4  # and it does vary between runs


def test_the_draws_follow_the_palette_shares() -> None:
    """Chi-square goodness of fit over 20,000 run seeds (smallest expected count 200).

    The threshold is the 1 - 1e-6 quantile of chi-square with 11 degrees of freedom: a
    correct draw fails this test with probability 1e-6 (the seeds are fixed, so it
    either always passes or always fails).
    """
    names = list(PALETTE)
    n = 20_000
    counts = dict.fromkeys(names, 0)
    for seed in range(n):
        counts[draw_color(color_rng(seed))] += 1
    expected = np.asarray([PALETTE[k][1] * n for k in names])
    observed = np.asarray([counts[k] for k in names])
    stat = float(((observed - expected) ** 2 / expected).sum())
    assert stat < chi2.ppf(1 - 1e-6, len(names) - 1), dict(zip(names, observed, strict=True))


def test_the_colour_stream_is_not_any_existing_stream_of_the_run() -> None:
    """The run's own rng (default_rng(seed)) and its per-frame rngs (default_rng([seed, k]))
    are left as they were, and none of them equals the colour stream."""
    for seed in (0, 1, 12345, 2**40 + 7):
        colour = color_rng(seed).integers(0, 2**63, 4).tolist()
        assert colour != np.random.default_rng(seed).integers(0, 2**63, 4).tolist()
        for k in range(200):
            assert colour != np.random.default_rng([seed, k]).integers(0, 2**63, 4).tolist()


def test_a_declared_ov_color_element_wins() -> None:
    assert ov_color({"ov_color": "white"}, 3) == PALETTE["white"][0]
    assert ov_color({"ov_color": "Gray"}, 3) == PALETTE["grey"][0]
    assert ov_color({"ov_color": [10, 20, 30]}, 3) == (10, 20, 30)
    for bad in ("mauve", [1, 2], [0, 0, 300], 7):
        with pytest.raises(ConfigError, match="ov_color"):
            resolve_color(bad)


def test_colour_features_have_the_documented_ranges_and_order() -> None:
    clear = conditions_from_values({})
    for rgb, _ in PALETTE.values():
        assert 0.0 <= body_contrast(rgb, clear) <= 1.0
        assert -1.0 <= detail_contrast(rgb) <= 1.0
    # a black body loses the outline of its dark glass and tyres; a white one keeps it
    assert detail_contrast(PALETTE["black"][0]) < 0 < detail_contrast(PALETTE["white"][0])
    # a dark body stands out against a bright sky more than a silver one does
    assert body_contrast(PALETTE["black"][0], clear) > body_contrast(PALETTE["silver"][0], clear)


def test_hue_features_separate_hues_and_vanish_for_greys() -> None:
    """Greys have no hue; the opponent axes point the documented ways; any RGB colour (a
    custom ov_color) gets features, close to those of the palette colour it is close to."""
    for name in ("white", "black", "grey", "silver"):
        assert max(abs(v) for v in chroma_features(PALETTE[name][0])) < 0.05, name
    red, blue = chroma_features(PALETTE["red"][0]), chroma_features(PALETTE["blue"][0])
    gold, yellow = chroma_features(PALETTE["gold"][0]), chroma_features(PALETTE["yellow"][0])
    assert red[1] > 0.3 and blue[2] < -0.3 < 0.3 < gold[2] < yellow[2]
    for c, a, b in (red, blue, gold, chroma_features((0, 255, 0))):
        assert c == pytest.approx(np.hypot(a, b)) and 0.0 <= c <= 1.5
    near_red = chroma_features(tuple(v + 4 for v in PALETTE["red"][0]))
    assert np.allclose(near_red, red, atol=0.03)
    assert chroma_features(None) == red  # the default body colour is the old red


def test_the_embedded_backend_gives_the_colour_to_the_sensor() -> None:
    from sitcov.av import ReferenceStack
    from sitcov.hyperspace import Situation
    from sitcov.sim.embedded import EmbeddedBackend

    seen: list = []

    class Spy:
        camera = None

        def reset(self, frame_dt=None) -> None:
            pass

        def detect(self, ego, actors, conditions, rng):
            seen.extend(a.color for a in actors)
            return ()

    def situation(**values) -> Situation:
        values["intsit"] = {"ego": "B-L", "ov": "L-R", "conflict": "c1"}
        return Situation(dict.fromkeys(values, "x"), values)

    backend = EmbeddedBackend(perception="pem", sensor=Spy())
    backend.run(situation(ov_color="blue"), ReferenceStack(), seed=4)
    assert seen and set(seen) == {PALETTE["blue"][0]}
    seen.clear()
    backend.run(situation(), ReferenceStack(), seed=4)
    assert set(seen) == {ov_color({}, 4)}


def test_the_renderer_paints_the_actor_in_its_colour(tjunction_geometry) -> None:
    import math

    from sitcov.perception import ActorView, CameraSpec, Pose, project_box, render_frame

    geometry, ego = tjunction_geometry
    cam = CameraSpec()
    cx = ego.x + cam.mount_x * math.cos(ego.yaw)
    cy = ego.y + cam.mount_x * math.sin(ego.yaw)
    pose = Pose(cx + 10 * math.cos(ego.yaw), cy + 10 * math.sin(ego.yaw), ego.yaw + 1.57)

    def box_mean(name: str) -> np.ndarray:
        actor = ActorView(pose, 4.5, 1.9, 1.5, 0.0, PALETTE[name][0])
        img = render_frame(cam, ego, (actor,), None, geometry, np.random.default_rng(0))
        x0, y0, x1, y1 = (int(v) for v in project_box(cam, ego, actor).box)
        return img[y0:y1, x0:x1].reshape(-1, 3).mean(0)

    white, black, red = box_mean("white"), box_mean("black"), box_mean("red")
    assert white.mean() > black.mean() + 20  # box mean: body, glass, wheels, background
    assert red[0] - red[1] > white[0] - white[1] + 8  # the red body shows as red


def test_a_pem_file_without_the_hue_names_loads_with_no_hue_term(tmp_path) -> None:
    """Files written before the hue term (no chroma_gain, red_green_gain,
    yellow_blue_gain) still load; the missing gains are 0, so hue changes no score."""
    import yaml

    from sitcov.perception import PEMFeatures, load_pem_params, pem_logit

    old = {n: v for n, v in load_pem_params().to_dict().items() if "green" not in n
           and "blue" not in n and n != "chroma_gain"}  # fmt: skip
    path = tmp_path / "pem.yaml"
    path.write_text(yaml.safe_dump({"meta": {"source": "test"}, "params": old}))
    params = load_pem_params(path)
    assert (params.chroma_gain, params.red_green_gain, params.yellow_blue_gain) == (0, 0, 0)
    base = PEMFeatures(40.0, 0.3, 0.0, width_px=70.0)
    logits = {pem_logit(base._replace(chroma=c, red_green=a, yellow_blue=b), params)
              for c, a, b in (chroma_features(rgb) for rgb, _ in PALETTE.values())}  # fmt: skip
    assert len(logits) == 1


def test_draw_color_is_the_generators_weighted_choice() -> None:
    """The palette draw equals ``Generator.choice`` with the palette's shares, seed by
    seed, and leaves the generator where that call leaves it."""
    names = list(PALETTE)
    shares = np.asarray([PALETTE[n][1] for n in names])
    for seed in range(3000):
        a, b = color_rng(seed), color_rng(seed)
        assert draw_color(a) == names[int(b.choice(len(names), p=shares / shares.sum()))]
        assert a.random() == b.random()
