"""The report's "Why it fails" section: findings and rules, or a one-line reason why not."""

from __future__ import annotations

import numpy as np

from sitcov.hyperspace import load_hyperspace
from sitcov.report._explain_section import explain_section

HS = load_hyperspace(None)


def runs(n: int, seed: int = 0) -> list[dict]:
    """Random situations failing 90 % in IntSit-2 and 10 % elsewhere."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        bins = {el.name: el.labels[int(rng.integers(len(el.labels)))] for el in HS.elements}
        p = 0.9 if bins["intsit"] == "IntSit-2" else 0.1
        out.append({"bins": bins, "status": "fail" if rng.random() < p else "pass"})
    return out


def test_section_names_the_failing_bin_and_measures_rules_on_held_out_runs():
    section = explain_section(HS, runs(300), scope="")["explain"]
    assert section["findings"][0].startswith("intsit IntSit-2 fails")
    assert section["rules"][0]["text"] == "intsit in {IntSit-2}"
    assert "held-out" in section["validation"]


def test_small_campaign_says_so():
    section = explain_section(HS, runs(20), scope="")["explain"]
    assert section["note"].startswith("not enough runs") and section["rules"] == []
