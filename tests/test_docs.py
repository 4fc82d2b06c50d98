"""The docs stand on their own and quote what the code does."""

from __future__ import annotations

import re
from pathlib import Path

from sitcov.av import make_stack

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def project_text_files() -> list[Path]:
    files = [ROOT / "README.md", *DOCS.rglob("*.md")]
    for folder in ("sitcov", "tests", "benchmarks", "examples"):
        files += [p for p in (ROOT / folder).rglob("*") if p.suffix in (".py", ".md", ".yaml")]
    return [p for p in files if p.is_file()]


def test_no_reference_to_a_design_document_outside_the_repository():
    """The project's docs must stand on their own (the design brief is not shipped)."""
    needles = ("DESIGN" + ".md", "DESIGN" + " §")  # split: this file must not match itself
    offenders = [
        str(p.relative_to(ROOT))
        for p in project_text_files()
        if any(n in p.read_text(errors="replace") for n in needles)
    ]
    assert offenders == []


def test_camera_md_quotes_the_reference_stack_s_minimum_boxes():
    text = " ".join((DOCS / "camera.md").read_text().split())
    plain = make_stack("reference").min_box_width
    f3 = make_stack("reference", fault="f3").min_box_width
    found = re.search(r"needs r > ([\d.]+), i\.e\. (\d+) px of the 800 px image", text)
    assert found and float(found[1]) == round(plain, 3) and int(found[2]) == round(plain * 800)
    found = re.search(r"f3 \([\d.]+\) it is ([\d.]+) \((\d+) px\)", text)
    assert found and float(found[1]) == round(f3, 3) and int(found[2]) == round(f3 * 800)


def test_readme_and_experiments_md_quote_the_same_table_2_timing():
    readme = " ".join((ROOT / "README.md").read_text().split())
    experiments = " ".join((DOCS / "experiments.md").read_text().split())
    quoted = re.search(r"800 runs in about (\d+) s of CPU time", readme)
    measured = re.search(r"ran 800 runs .*? in (\d+) s of CPU time", experiments)
    assert quoted and measured and quoted[1] == measured[1]
