# ruff: noqa: E501 - XML templates read best one element a line
"""Writes the two test OpenDRIVE files of tests/roads (run from the repository root:
``python tests/roads/data/make_xodr.py``; the files are committed, this is how they were made).

- ``geometries.xodr``: one road made of every plan-view record type (line, arc, two
  spirals, poly3, paramPoly3 with arcLength and normalized pRange), lane offsets, two lane
  sections with cubic widths and driving, biking, shoulder, sidewalk lanes. Each record's
  start pose is the previous one's end as sitcov evaluates it; esmini's ``odrplot`` of the
  file is the reference the tests compare against, record by record.
- ``t-junction.xodr``: a T-junction (stem S to the south, arms W and E), one 3.5 m driving
  lane each way and a 2 m sidewalk each side on every leg, mouths 10 m from the centre,
  six connecting roads (lines and arcs) with lane links, and a crosswalk object on every
  leg (an outline in road coordinates, an outline in local coordinates, a plain rectangle).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from sitcov.roads._geometry import Arc, Line, ParamPoly3, Spiral, poly3  # noqa: E402

HERE = Path(__file__).parent
HEADER = '<?xml version="1.0" encoding="UTF-8"?>\n<OpenDRIVE>\n  <header revMajor="1" revMinor="6" name="{name}" version="1" vendor="sitcov tests"/>\n'


def _f(v: float) -> str:
    return repr(round(float(v), 12))


def geometries() -> str:
    records = [
        ("line", 20.0, {}),
        ("arc", 25.0, {"curvature": 0.02}),
        ("spiral", 30.0, {"curvStart": 0.02, "curvEnd": -0.015}),
        ("spiral", 20.0, {"curvStart": 0.0, "curvEnd": 0.03}),
        ("poly3", 10.0, {"a": 0.0, "b": 0.0, "c": 0.01, "d": -0.0005}),
        (
            "paramPoly3",
            30.0,
            {
                "aU": 0.0,
                "bU": 29.5,
                "cU": 0.0,
                "dU": 0.0,
                "aV": 0.0,
                "bV": 0.0,
                "cV": 3.0,
                "dV": -1.0,
                "pRange": "normalized",
            },
        ),
        (
            "paramPoly3",
            25.0,
            {
                "aU": 0.0,
                "bU": 1.0,
                "cU": -0.001,
                "dU": 0.0,
                "aV": 0.0,
                "bV": 0.0,
                "cV": -0.004,
                "dV": 0.0001,
                "pRange": "arcLength",
            },
        ),
    ]
    x, y, h, s = 0.0, 0.0, 0.3, 0.0
    out = []
    for kind, length, attrs in records:
        pose = (s, x, y, h, length)
        if kind == "line":
            g = Line(*pose)
        elif kind == "arc":
            g = Arc(*pose, curvature=attrs["curvature"])
        elif kind == "spiral":
            g = Spiral(*pose, curv_start=attrs["curvStart"], curv_end=attrs["curvEnd"])
        elif kind == "poly3":
            g = poly3(*pose, attrs["a"], attrs["b"], attrs["c"], attrs["d"])
        else:
            g = ParamPoly3(
                *pose,
                u_coef=tuple(attrs[k + "U"] for k in "abcd"),
                v_coef=tuple(attrs[k + "V"] for k in "abcd"),
                p_max=1.0 if attrs["pRange"] == "normalized" else length,
            )
        body = " ".join(f'{k}="{v}"' for k, v in attrs.items())
        out.append(
            f'      <geometry s="{_f(s)}" x="{_f(x)}" y="{_f(y)}" hdg="{_f(h)}" length="{_f(length)}">'
            f"<{kind} {body}/></geometry>"
        )
        ex, ey, eh = g.evaluate(np.array([length]))
        x, y, h, s = float(ex[0]), float(ey[0]), float(eh[0]), s + length
    total = s

    def lane(lid: int, kind: str, widths: list[tuple[float, ...]]) -> str:
        w = "".join(
            f'<width sOffset="{o}" a="{a}" b="{b}" c="{c}" d="{d}"/>' for o, a, b, c, d in widths
        )
        return f'          <lane id="{lid}" type="{kind}" level="false">{w}</lane>\n'

    sec0 = (
        '      <laneSection s="0">\n        <left>\n'
        + lane(3, "sidewalk", [(0, 2.0, 0, 0, 0)])
        + lane(2, "shoulder", [(0, 0.5, 0.005, 0, 0), (40, 0.7, 0, 0, 0)])
        + lane(1, "driving", [(0, 3.25, 0, 0, 0)])
        + '        </left>\n        <center><lane id="0" type="none" level="false"/></center>\n        <right>\n'
        + lane(-1, "driving", [(0, 3.5, 0.002, 0, 0), (50, 3.6, 0, 0, 0)])
        + lane(-2, "biking", [(0, 1.5, 0, 0, 0)])
        + lane(-3, "sidewalk", [(0, 2.0, 0, 0, 0)])
        + "        </right>\n      </laneSection>\n"
    )
    sec1 = (
        '      <laneSection s="95">\n        <left>\n'
        + lane(2, "sidewalk", [(0, 2.0, 0, 0.0004, -0.000005)])
        + lane(1, "driving", [(0, 3.25, 0, 0.0002, -0.000002)])
        + '        </left>\n        <center><lane id="0" type="none" level="false"/></center>\n        <right>\n'
        + lane(-1, "driving", [(0, 3.6, 0, -0.0003, 0.000003)])
        + lane(-2, "sidewalk", [(0, 2.0, 0, 0, 0)])
        + "        </right>\n      </laneSection>\n"
    )
    return (
        HEADER.format(name="geometries")
        + f'  <road name="all geometries" length="{_f(total)}" id="1" junction="-1">\n'
        + "    <link/>\n    <planView>\n"
        + "\n".join(out)
        + "\n    </planView>\n"
        + '    <elevationProfile><elevation s="0" a="0" b="0.01" c="0" d="0"/></elevationProfile>\n'
        + "    <lanes>\n"
        + '      <laneOffset s="0" a="0.2" b="0.004" c="0" d="0"/>\n'
        + '      <laneOffset s="60" a="0.44" b="0" c="-0.0002" d="0"/>\n'
        + sec0
        + sec1
        + "    </lanes>\n  </road>\n</OpenDRIVE>\n"
    )


def _leg_lanes(left_sidewalk: bool = True) -> str:
    return (
        '    <lanes>\n      <laneSection s="0">\n        <left>\n'
        '          <lane id="2" type="sidewalk" level="false"><link><predecessor id="2"/><successor id="2"/></link><width sOffset="0" a="2.0" b="0" c="0" d="0"/></lane>\n'
        '          <lane id="1" type="driving" level="false"><link><predecessor id="1"/><successor id="1"/></link><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>\n'
        '        </left>\n        <center><lane id="0" type="none" level="false"/></center>\n        <right>\n'
        '          <lane id="-1" type="driving" level="false"><link><predecessor id="-1"/><successor id="-1"/></link><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>\n'
        '          <lane id="-2" type="sidewalk" level="false"><link><predecessor id="-2"/><successor id="-2"/></link><width sOffset="0" a="2.0" b="0" c="0" d="0"/></lane>\n'
        "        </right>\n      </laneSection>\n    </lanes>\n"
    )


def t_junction() -> str:
    mouth, leg = 10.0, 100.0
    legs = [
        # id, name, x, y, hdg, link
        ("1", "W", -mouth - leg, 0.0, 0.0, '<successor elementType="junction" elementId="100"/>'),
        ("2", "E", mouth, 0.0, 0.0, '<predecessor elementType="junction" elementId="100"/>'),
        (
            "3",
            "S",
            0.0,
            -mouth,
            -math.pi / 2,
            '<predecessor elementType="junction" elementId="100"/>',
        ),
    ]
    objects = {
        "1": '<object id="901" type="crosswalk" name="crosswalk" s="96.5" t="0" zOffset="0" hdg="0" '
        'length="3.0" width="11.0" orientation="none"/>',
        "2": '<object id="902" type="crosswalk" name="crosswalk" s="3.5" t="0" zOffset="0" hdg="0" '
        'orientation="none"><outline id="0" closed="true">'
        '<cornerRoad s="2.0" t="-5.5" dz="0" height="0"/><cornerRoad s="5.0" t="-5.5" dz="0" height="0"/>'
        '<cornerRoad s="5.0" t="5.5" dz="0" height="0"/><cornerRoad s="2.0" t="5.5" dz="0" height="0"/>'
        "</outline></object>",
        "3": '<object id="903" type="crosswalk" name="crosswalk" s="3.5" t="0" zOffset="0" hdg="0" '
        'orientation="none"><outline id="0" closed="true">'
        '<cornerLocal u="-1.5" v="-5.5" z="0" height="0"/><cornerLocal u="1.5" v="-5.5" z="0" height="0"/>'
        '<cornerLocal u="1.5" v="5.5" z="0" height="0"/><cornerLocal u="-1.5" v="5.5" z="0" height="0"/>'
        "</outline></object>",
    }
    roads = []
    for rid, name, x, y, h, link in legs:
        roads.append(
            f'  <road name="{name}" length="{_f(leg)}" id="{rid}" junction="-1">\n    <link>{link}</link>\n'
            f'    <planView><geometry s="0" x="{_f(x)}" y="{_f(y)}" hdg="{_f(h)}" length="{_f(leg)}"><line/></geometry></planView>\n'
            + _leg_lanes()
            + f"    <objects>{objects[rid]}</objects>\n  </road>\n"
        )
    q = math.pi / 2
    arc = mouth * q  # quarter circle of radius ``mouth`` about a corner
    # id, x, y, hdg, geometry, length, (in road, contact, in lane), (out road, contact, out lane)
    conns = [
        ("10", -mouth, 0.0, 0.0, "<line/>", 2 * mouth, ("1", "end", -1), ("2", "start", -1)),
        (
            "11",
            -mouth,
            0.0,
            0.0,
            '<arc curvature="-0.1"/>',
            arc,
            ("1", "end", -1),
            ("3", "start", -1),
        ),
        ("12", mouth, 0.0, math.pi, "<line/>", 2 * mouth, ("2", "start", 1), ("1", "end", 1)),
        (
            "13",
            mouth,
            0.0,
            math.pi,
            '<arc curvature="0.1"/>',
            arc,
            ("2", "start", 1),
            ("3", "start", -1),
        ),
        ("14", 0.0, -mouth, q, '<arc curvature="0.1"/>', arc, ("3", "start", 1), ("1", "end", 1)),
        (
            "15",
            0.0,
            -mouth,
            q,
            '<arc curvature="-0.1"/>',
            arc,
            ("3", "start", 1),
            ("2", "start", -1),
        ),
    ]
    junction = ['  <junction id="100" name="T">\n']
    for cid, x, y, h, geo, length, (ri, ci, li), (ro, co, lo) in conns:
        roads.append(
            f'  <road name="c{cid}" length="{_f(length)}" id="{cid}" junction="100">\n'
            f'    <link><predecessor elementType="road" elementId="{ri}" contactPoint="{ci}"/>'
            f'<successor elementType="road" elementId="{ro}" contactPoint="{co}"/></link>\n'
            f'    <planView><geometry s="0" x="{_f(x)}" y="{_f(y)}" hdg="{_f(h)}" length="{_f(length)}">{geo}</geometry></planView>\n'
            '    <lanes>\n      <laneSection s="0">\n'
            '        <center><lane id="0" type="none" level="false"/></center>\n        <right>\n'
            f'          <lane id="-1" type="driving" level="false"><link><predecessor id="{li}"/><successor id="{lo}"/></link>'
            '<width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>\n'
            "        </right>\n      </laneSection>\n    </lanes>\n  </road>\n"
        )
        junction.append(
            f'    <connection id="{cid}" incomingRoad="{ri}" connectingRoad="{cid}" contactPoint="start">'
            f'<laneLink from="{li}" to="-1"/></connection>\n'
        )
    junction.append("  </junction>\n")
    return HEADER.format(name="t-junction") + "".join(roads) + "".join(junction) + "</OpenDRIVE>\n"


if __name__ == "__main__":
    (HERE / "geometries.xodr").write_text(geometries(), encoding="utf-8")
    (HERE / "t-junction.xodr").write_text(t_junction(), encoding="utf-8")
