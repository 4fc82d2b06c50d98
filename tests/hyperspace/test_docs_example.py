"""The YAML example in docs/hyperspace.md loads and has the count the text states."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from sitcov.hyperspace import load_hyperspace

DOC = Path(__file__).resolve().parents[2] / "docs" / "hyperspace.md"


def test_documented_example(tmp_path):
    block = re.search(r"```yaml\n(.*?)```", DOC.read_text(), re.S).group(1)
    path = tmp_path / "example.yaml"
    path.write_text(block)
    hs = load_hyperspace(path)
    assert hs.n_situations == 16
    assert "16 distinct situations" in DOC.read_text()
    s = hs.situation_from_bins(
        {"friction": "0.6", "fog_density": "light", "intsit": "IntSit-3"}, np.random.default_rng(0)
    )
    assert 10 <= s.values["fog_density"] < 40
    assert not hs.is_allowed({"friction": "0.2", "fog_density": "dense", "intsit": "IntSit-1"})
