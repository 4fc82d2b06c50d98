"""``sitcov explain``: interaction tests recover planted structure, rules are measured on
held-out runs, and small or broken campaigns get a plain answer instead of statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitcov.analysis import explain, explain_lines, failure_regions, interaction_analysis
from sitcov.analysis._logit import fit_logit, holm, newcombe_difference, odds_ratio
from sitcov.hyperspace import Hyperspace

HS = Hyperspace.from_dict(
    {
        "name": "toy",
        "axes": [
            {
                "name": "x",
                "elements": [
                    {"name": "a", "bins": [{"value": 0}, {"value": 1}, {"value": 2}]},
                    {"name": "b", "bins": [{"value": 0}, {"value": 1}, {"value": 2}]},
                    {
                        "name": "c",
                        "bins": [{"label": f"C{i}", "value": {"k": i}} for i in range(4)],
                    },
                ],
            }
        ],
    }
)


def synthetic_runs(n: int, logit, seed: int) -> list[dict]:
    """``n`` runs with uniform bins; fail with probability sigmoid(logit(a, b, c))."""
    rng = np.random.default_rng(seed)
    runs = []
    for _ in range(n):
        idx = [int(rng.integers(size)) for size in HS.sizes]
        p = 1 / (1 + math.exp(-logit(*idx)))
        bins = {el.name: el.labels[i] for el, i in zip(HS.elements, idx, strict=True)}
        runs.append({"bins": bins, "status": "fail" if rng.random() < p else "pass"})
    return runs


def pair(result: dict, a: str, b: str) -> dict:
    return next(t for t in result["pairs"] if t["elements"] == [a, b])


# alpha = 1e-3 with B = 1999 bootstrap replicates: the smallest adjusted p is 1/2000 = 5e-4,
# so a planted interaction can reach significance, and under no interaction the single-step
# min-p procedure calls a pair significant with probability <= 5e-4 < 1e-3 (family-wise).
STRICT = {"alpha": 1e-3, "bootstrap": 1999, "seed": 0}


@pytest.mark.slow
def test_planted_interaction_is_significant_and_others_are_not():
    # only the cell a=2, b=2 fails often (85 % vs 15 %): an interaction without main effects
    # beyond the cell. 600 runs put ~67 runs in the cell; the LR statistic then exceeds 60
    # with probability > 1 - 1e-6 (binomial tail of the cell's failures), p < 1e-12, far
    # beyond any bootstrap replicate's minimum: the miss probability is < 1e-3.
    runs = synthetic_runs(600, lambda a, b, c: 1.7 if a == 2 and b == 2 else -1.7, seed=1)
    result = interaction_analysis(HS, runs, **STRICT)
    assert pair(result, "a", "b")["significant"]
    assert not pair(result, "a", "c")["significant"]
    assert not pair(result, "b", "c")["significant"]
    top = result["findings"][0]
    cell = pair(result, "a", "b")["top_cell"]
    assert cell["cell"] == {"a": "2", "b": "2"}
    assert cell["failures"] / cell["judged"] > 0.6  # data behind the claim: counts per cell
    assert any(f["kind"] == "interaction" for f in result["findings"])
    assert top["importance"] >= max(f["importance"] for f in result["findings"])


@pytest.mark.slow
def test_additive_effects_give_no_interaction():
    # strong main effects of a and b, additive on the logit scale: no pair may be called
    # significant (probability <= 5e-4, see STRICT); a and b themselves are (chi-square LR
    # on ~200 runs per bin with a 1.2 logit effect: miss probability < 1e-6).
    runs = synthetic_runs(600, lambda a, b, c: -1.7 + 1.2 * (a == 2) + 1.2 * (b == 2), seed=2)
    result = interaction_analysis(HS, runs, **STRICT)
    assert not any(t["significant"] for t in result["pairs"])
    significant = {t["element"] for t in result["elements"] if t["significant"]}
    assert {"a", "b"} <= significant
    texts = [f["text"] for f in result["findings"]]
    assert any(t.startswith("a 2 fails") for t in texts), texts


def test_bin_effects_carry_counts_and_intervals():
    runs = synthetic_runs(400, lambda a, b, c: 1.5 if a == 0 else -1.5, seed=3)
    result = interaction_analysis(HS, runs, bootstrap=19)
    a = next(t for t in result["elements"] if t["element"] == "a")
    for row in a["bins"]:
        assert row["bin"]["judged"] + row["rest"]["judged"] == result["judged"]
        lo, hi = row["risk_difference_ci95"]
        assert lo <= row["risk_difference"] <= hi
        olo, ohi = row["odds_ratio_ci95"]
        assert olo <= row["odds_ratio"] <= ohi


def test_small_campaign_says_not_enough_runs():
    runs = synthetic_runs(30, lambda a, b, c: 0.0, seed=4)
    result = explain(HS, runs, bootstrap=19)
    assert result["message"].startswith("not enough runs: 30 judged runs")
    assert result["findings"] == [] and result["regions"]["rules"] == []
    assert explain_lines(result)[-1].startswith("not enough runs")


def test_error_runs_are_excluded_and_counted():
    runs = synthetic_runs(200, lambda a, b, c: 0.0, seed=5)
    for r in runs[:7]:
        r["status"] = "error"
    runs[7]["status"] = "timeout"
    result = interaction_analysis(HS, runs, bootstrap=19)
    assert result["judged"] == 192
    assert result["excluded"] == {"error": 7, "timeout": 1, "pending": 0, "unmatched": 0}


def test_rules_are_measured_on_runs_not_used_to_fit():
    # flipping the outcomes of the held-out runs must leave the fitted rules unchanged
    # and turn each rule's held-out failures into its held-out passes.
    runs = synthetic_runs(450, lambda a, b, c: 2.0 if c in (1, 3) and a >= 1 else -2.0, seed=6)
    first = failure_regions(HS, runs, seed=11)
    order = np.random.default_rng(11).permutation(len(runs))
    held = set(order[: first["holdout_runs"]].tolist())
    flipped = [
        {**r, "status": {"fail": "pass", "pass": "fail"}[r["status"]]} if i in held else r
        for i, r in enumerate(runs)
    ]
    second = failure_regions(HS, flipped, seed=11)
    assert first["rules"], "the planted region must give at least one rule"
    # the fitted rules are the same; kept or dropped is decided on the held-out runs
    fitted1 = sorted(first["rules"] + first["dropped"], key=lambda r: r["text"])
    fitted2 = sorted(second["rules"] + second["dropped"], key=lambda r: r["text"])
    assert [r["text"] for r in fitted1] == [r["text"] for r in fitted2]
    assert not second["rules"], "flipped held-out outcomes cannot confirm a failure region"
    for r1, r2 in zip(fitted1, fitted2, strict=True):
        assert r1["fit"] == r2["fit"]
        h1, h2 = r1["holdout"], r2["holdout"]
        assert h1["support"] == h2["support"]
        assert h1["failures"] + h2["failures"] == h1["support"]


def test_a_rule_that_only_matches_the_base_rate_held_out_is_dropped():
    # no region at all: any rule the tree finds on the fitting part is noise, and its
    # held-out precision does not beat the base rate beyond sampling error
    for seed in range(5):
        runs = synthetic_runs(450, lambda a, b, c: 0.0, seed=20 + seed)
        regions = failure_regions(HS, runs, seed=seed)
        assert regions["rules"] == []
        for rule in regions["dropped"]:
            assert rule["holdout"]["precision_ci95"][0] <= regions["holdout_base_rate"]


def test_long_categorical_conditions_are_grouped_by_road_user_and_conflict():
    from importlib import resources

    from sitcov.analysis._regions import grouped_text
    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace(str(resources.files("sitcov.hyperspace") / "data/derived/t-junction.yaml"))
    el = hs.element("intsit")
    peds = [b.label for b in el.bins if b.value.get("kind") == "pedestrian"]
    text = grouped_text(el, [*peds, el.labels[0]])
    assert f"every pedestrian crossing bin ({len(peds)})" in text
    assert text.startswith(f"intsit: {len(peds) + 1} of {len(el.bins)} bins")
    assert len(text) < 200


def test_planted_region_is_the_top_rule_with_high_held_out_precision():
    # fails 88 % inside "c in {C1, C3} and a >= 1", 12 % outside; 450 runs, 150 held out
    # (~50 inside): held-out precision below 0.7 has probability < 1e-4 (binomial tail).
    runs = synthetic_runs(450, lambda a, b, c: 2.0 if c in (1, 3) and a >= 1 else -2.0, seed=7)
    top = failure_regions(HS, runs, seed=0)["rules"][0]
    conds = {c["element"]: set(c["bins"]) for c in top["conditions"]}
    assert conds == {"a": {"1", "2"}, "c": {"C1", "C3"}}, top["text"]
    assert top["text"] == "a >= 1 and c in {C1, C3}"
    assert top["holdout"]["precision"] > 0.7


def test_holm_and_intervals():
    assert holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    assert all(a >= p for a, p in zip(holm([0.2, 0.001, 0.5]), [0.2, 0.001, 0.5], strict=True))
    d, lo, hi = newcombe_difference(9, 10, 1, 10)
    assert d == pytest.approx(0.8)
    assert -1 <= lo < d < hi <= 1
    assert newcombe_difference(0, 0, 1, 2) is None
    ratio, olo, ohi = odds_ratio(0, 10, 5, 10)  # an empty cell still gives finite numbers
    assert 0 < olo < ratio < ohi < math.inf and ratio == pytest.approx(0.5 * 5.5 / (10.5 * 5.5))


def test_separated_fit_stays_finite():
    x = np.column_stack([np.ones(40), np.r_[np.ones(20), np.zeros(20)]])
    y = np.r_[np.ones(20), np.zeros(20)]  # the column predicts y perfectly
    fit = fit_logit(x, y)
    assert np.all(np.isfinite(fit.coef)) and fit.deviance < 2.0


def test_a_bin_that_never_fails_gets_the_penalised_finite_estimate():
    """The ridge penalty (0.01, documented in _logit) is what keeps a never-failing bin's
    coefficient finite: the fit is the penalised optimum, where the gradient of the
    penalised likelihood vanishes. Without the penalty (a surviving mutant of issue 26) the
    coefficient runs off towards the clip and that gradient is far from zero."""
    rng = np.random.default_rng(3)
    n = 60
    ref = (rng.random(n) < 0.4).astype(float)  # the reference bin: fails ~40 %
    x = np.column_stack([np.ones(2 * n), np.r_[np.zeros(n), np.ones(n)]])
    y = np.r_[ref, np.zeros(n)]  # the second bin never fails
    fit = fit_logit(x, y)
    penalty = np.array([0.0, 0.01])
    grad = x.T @ (fit.prob - y) + penalty * fit.coef
    assert np.abs(grad).max() < 1e-4
    # the estimate itself, from the stationarity conditions written out: the intercept's
    # n sigmoid(a) + n sigmoid(a + b) = failures, the bin's n sigmoid(a + b) = -0.01 b
    a, b = fit.coef
    p0, p1 = 1 / (1 + math.exp(-a)), 1 / (1 + math.exp(-(a + b)))
    assert n * (p0 + p1) == pytest.approx(ref.sum(), rel=1e-4)
    assert -9.0 < b < -4.0 and n * p1 == pytest.approx(-0.01 * b, rel=1e-3)


def test_explain_reports_its_progress_stage_by_stage():
    """``sitcov explain`` shows a bar (issue 26: 90-134 s without output): every stage is
    announced, the bootstrap counts each replicate up to its total, and the progress
    callback changes nothing in the result."""
    runs = synthetic_runs(400, lambda a, b, c: -1.0 + 1.5 * (a == 2), seed=5)
    seen: list[tuple[str, int, int]] = []
    told = explain(HS, runs, seed=1, bootstrap=19, progress=lambda *t: seen.append(t))
    assert told == explain(HS, runs, seed=1, bootstrap=19)
    stages = list(dict.fromkeys(s for s, _, _ in seen))
    assert stages == ["element tests", "pair tests (bootstrap)", "failure regions"]
    boot = [(d, t) for s, d, t in seen if s == "pair tests (bootstrap)"]
    assert boot == [(i, 19) for i in range(20)]


def default_campaign(n: int, seed: int, friction_effect: float = 4.0) -> list[dict]:
    """``n`` runs of the default hyperspace with uniform bins, failing by a main-effects
    truth: friction 0.1 and 0.2 fail with ``friction_effect`` logits more; no other
    element has an effect and no pair interacts."""
    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace()
    rng = np.random.default_rng(seed)
    f = hs.element_names.index("friction")
    runs = []
    for _ in range(n):
        idx = [int(rng.integers(size)) for size in hs.sizes]
        p = 1 / (1 + math.exp(-(-0.3 + (friction_effect if idx[f] <= 1 else 0.0))))
        bins = {el.name: el.labels[i] for el, i in zip(hs.elements, idx, strict=True)}
        runs.append({"bins": bins, "status": "fail" if rng.random() < p else "pass"})
    return runs


def test_too_few_runs_per_parameter_fall_back_on_exact_bin_tests():
    """200 runs of the default hyperspace (52 main-effects parameters, fewer than 6 runs
    each): no likelihood-ratio test and no pair test, which called null elements and pairs
    significant in 49 % and 73 % of such campaigns; each element's p is its smallest
    Fisher exact bin p times its bins, and friction's real effect is still found."""
    from sitcov.hyperspace import load_hyperspace

    result = interaction_analysis(load_hyperspace(), default_campaign(200, seed=1), bootstrap=19)
    assert result["method"].startswith("too few runs for the model-based tests (>= 6 ")
    assert "312 here" in result["method"] and result["method"].endswith("pairs not tested")
    assert result["pairs"] == [] and result["element_lr_scale"] is None
    friction = next(t for t in result["elements"] if t["element"] == "friction")
    assert friction["p"] == pytest.approx(
        len(friction["bins"]) * min(b["p"] for b in friction["bins"])
    )
    assert friction["significant"]
    assert [f["element"] for f in result["findings"]] == ["friction"]


def test_the_element_tests_are_divided_by_a_measured_bartlett_factor():
    """From 6 runs per parameter the element LR statistics are divided by their measured
    null mean over df (at 400 runs of the default hyperspace 1.09-1.35 over 30 campaigns,
    1.25 in this one: the chi-square alone is anti-conservative there), which only raises
    their p-values; the factor is
    the same for the same seed, and from 40 runs per parameter it is 1 (not measured)."""
    from sitcov.hyperspace import load_hyperspace

    hs, runs = load_hyperspace(), default_campaign(400, seed=2)
    scaled = interaction_analysis(hs, runs, bootstrap=0, seed=3)
    plain = interaction_analysis(hs, runs, bootstrap=0, seed=3, element_bootstrap=0)
    assert 1.1 < scaled["element_lr_scale"] < 1.6
    assert plain["element_lr_scale"] == 1.0
    assert "Bartlett factor from a 39-replicate" in scaled["method"]
    for a, b in zip(scaled["elements"], plain["elements"], strict=True):
        assert a["lr"] == b["lr"] and a["p"] >= b["p"]
    again = interaction_analysis(hs, runs, bootstrap=0, seed=3)
    assert again["element_lr_scale"] == scaled["element_lr_scale"]
    big = interaction_analysis(HS, synthetic_runs(400, lambda a, b, c: 0.0, seed=6), bootstrap=0)
    assert big["element_lr_scale"] == 1.0  # 400 runs for the toy's 8 parameters


@pytest.mark.slow
def test_null_elements_keep_the_family_wise_level_on_a_few_hundred_runs():
    """30 campaigns of 400 runs of the default hyperspace in which only friction matters:
    some null element is significant (Holm, alpha 0.05) in at most 5 of them with the
    Bartlett factor (expected 1.5: P(>= 6) < 0.003; 2 measured), where the plain
    chi-square calls one in about a quarter of them (7 of these 30)."""
    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace()
    false = {"scaled": 0, "plain": 0}
    for c in range(30):
        runs = default_campaign(400, seed=100 + c)
        for name, boot in (("scaled", 39), ("plain", 0)):
            res = interaction_analysis(hs, runs, bootstrap=0, seed=c, element_bootstrap=boot)
            false[name] += any(
                t["significant"] and t["element"] != "friction" for t in res["elements"]
            )
    assert false["scaled"] <= 5, false
    assert false["plain"] > false["scaled"], false
