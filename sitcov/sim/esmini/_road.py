"""The part of a large OpenDRIVE road a run can reach, so esmini loads less per run.

esmini parses the whole OpenDRIVE file at every scenario load (``SE_InitWithString``
resets its road manager first) and cannot keep it between runs. On CARLA's Town03
(2.3 MB, 279 roads) that load is most of a run. :func:`cropped_road` writes, once per
process and region, a copy that keeps the roads within ``margin`` of the run's paths (the
entities' driven routes) and the junction connections among them: the kept roads are
byte for byte the original's, so every lane, junction and route the run uses is the same;
links to removed roads are dropped (they lead out of the region).
"""

from __future__ import annotations

import math
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path

from sitcov.errors import ConfigError

#: Sample spacing along a road's reference line when testing its distance [m].
SAMPLE = 5.0
#: Roads farther than this from every point of the run's paths are left out [m].
MARGIN = 60.0

_CROPS: dict[tuple[str, tuple[tuple[int, int], ...]], Path] = {}
_DIR: tempfile.TemporaryDirectory | None = None


def _samples(geometry: ET.Element) -> Iterable[tuple[float, float]]:
    """Points every :data:`SAMPLE` metres along a ``line`` or ``arc`` geometry (the
    start point only for spirals and polynomials, which are kept if it is near)."""
    x, y = float(geometry.get("x", 0)), float(geometry.get("y", 0))
    h, length = float(geometry.get("hdg", 0)), float(geometry.get("length", 0))
    arc = geometry.find("arc")
    n = max(1, math.ceil(length / SAMPLE))
    if geometry.find("line") is None and arc is None:
        yield x, y
        return
    k = float(arc.get("curvature", 0)) if arc is not None else 0.0
    for i in range(n + 1):
        s = length * i / n
        if abs(k) < 1e-12:
            yield x + s * math.cos(h), y + s * math.sin(h)
        else:
            yield (
                x + (math.sin(h + k * s) - math.sin(h)) / k,
                y - (math.cos(h + k * s) - math.cos(h)) / k,
            )


def _near(points: list[tuple[float, float]], margin: float):  # noqa: ANN202
    cell = margin
    grid: dict[tuple[int, int], list[tuple[float, float]]] = {}
    for p in points:
        grid.setdefault((int(p[0] // cell), int(p[1] // cell)), []).append(p)

    def near(x: float, y: float) -> bool:
        cx, cy = int(x // cell), int(y // cell)
        for gx in (cx - 1, cx, cx + 1):
            for gy in (cy - 1, cy, cy + 1):
                for px, py in grid.get((gx, gy), ()):
                    if math.hypot(px - x, py - y) <= margin:
                        return True
        return False

    return near


def crop(text: str, points: list[tuple[float, float]], margin: float = MARGIN) -> str:
    """The OpenDRIVE document ``text`` with only the roads that come within ``margin``
    [m] of ``points`` (and the junctions and connections among them)."""
    root = ET.fromstring(text)  # noqa: S314 - the user's own road file
    near = _near(points, margin)
    keep: set[str] = set()
    for road in root.findall("road"):
        if any(near(x, y) for g in road.iterfind("planView/geometry") for x, y in _samples(g)):
            keep.add(road.get("id", ""))
        else:
            root.remove(road)
    junctions: set[str] = set()
    for junction in root.findall("junction"):
        for conn in junction.findall("connection"):
            if conn.get("incomingRoad") not in keep or conn.get("connectingRoad") not in keep:
                junction.remove(conn)
        if junction.find("connection") is None:
            root.remove(junction)
        else:
            junctions.add(junction.get("id", ""))
    for road in root.iterfind("road"):
        if road.get("junction", "-1") not in ("-1", *junctions):
            road.set("junction", "-1")
        link = road.find("link")
        for end in list(link if link is not None else ()):
            kind, ref = end.get("elementType"), end.get("elementId")
            gone = ref not in (keep if kind == "road" else junctions)
            if kind in ("road", "junction") and gone:
                link.remove(end)  # type: ignore[union-attr]
    return ET.tostring(root, encoding="unicode")


def cropped_road(road: Path, points: list[tuple[float, float]], margin: float = MARGIN) -> Path:
    """A file with :func:`crop` of ``road`` around ``points``, written once per process
    for each road and region (the points rounded to 10 m)."""
    global _DIR
    key = (str(road), tuple(sorted({(int(x // 10), int(y // 10)) for x, y in points})))
    found = _CROPS.get(key)
    if found is not None and found.is_file():
        return found
    try:
        text = road.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{road}: cannot read the road: {exc.strerror or exc}") from None
    if _DIR is None:
        _DIR = tempfile.TemporaryDirectory(prefix="sitcov-esmini-roads-")
    path = Path(_DIR.name) / f"{road.stem}-{len(_CROPS)}.xodr"
    path.write_text(crop(text, points, margin), encoding="utf-8")
    _CROPS[key] = path
    return path
