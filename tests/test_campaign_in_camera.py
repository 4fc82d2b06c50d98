"""``benchmarks/campaign_in_camera.py``: the comparison it prints from a campaign's rows
(README and docs/pem.md quote it)."""

from __future__ import annotations

from benchmark_modules import load_benchmark


def _rows() -> list[dict]:
    """40 runs from the left failing 30 on the PEM and 20 in camera mode (the 20 among the
    30), 40 from the right failing 10 in both, 20 ahead failing none."""
    rows = []
    for i in range(40):
        rows.append({"index": i, "intsit": "IntSit-5", "side": "left",
                     "pem_failed": int(i < 30), "camera_failed": int(i < 20)})  # fmt: skip
    for i in range(40, 80):
        fail = int(i < 50)
        rows.append({"index": i, "intsit": "IntSit-7", "side": "right",
                     "pem_failed": fail, "camera_failed": fail})  # fmt: skip
    for i in range(80, 100):
        rows.append({"index": i, "intsit": "IntSit-11", "side": "ahead",
                     "pem_failed": 0, "camera_failed": 0})  # fmt: skip
    return rows


def test_the_report_counts_rates_sides_and_agreement() -> None:
    lines = load_benchmark("campaign_in_camera").report(_rows())
    text = "\n".join(lines)
    rows = {x.split()[0] if not x.startswith("from") else " ".join(x.split()[:2]): x.split()
            for x in lines[1:8]}  # fmt: skip
    assert rows["all"][1:6] == ["100", "40.0%", "[30.9,", "49.8]", "30.0%"]
    assert rows["from left"][2:7] == ["40", "75.0%", "[59.8,", "85.8]", "50.0%"]
    assert rows["from right"][3] == rows["from right"][6] == "25.0%"
    assert [x.split()[0] for x in lines[5:8]] == ["IntSit-5", "IntSit-7", "IntSit-11"]
    assert "verdicts agree on 90/100 runs; PEM only fails 10, camera only 0" in text
    pem = next(x for x in lines if x.startswith("pem: "))
    camera = next(x for x in lines if x.startswith("camera: "))
    assert float(pem.rsplit(" ", 1)[1]) < 1e-4  # 30 of 40 against 10 of 40
    assert 0.01 < float(camera.rsplit(" ", 1)[1]) < 0.05  # 20 of 40 against 10 of 40
