"""What ``sitcov map import`` prints and writes (the CLI only parses and calls these)."""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from sitcov.errors import ConfigError
from sitcov.roads._junction import junction_map_data, list_junctions, nearest_junction
from sitcov.roads._opendrive import read_opendrive


def junction_table(file: Path, *, as_json: bool = False) -> str:
    """Every junction of ``file`` with its legs: road, name, outward heading, lanes in/out."""
    rows = list_junctions(read_opendrive(file))
    if as_json:
        return json.dumps(rows, sort_keys=True) + "\n"
    lines = [f"{file}: {len(rows)} junctions (centre in file coordinates [m])"]
    for row in rows:
        legs = "; ".join(
            f"{leg['name']} road {leg['road']} {leg['heading_deg']:g} deg "
            f"in {leg['lanes_in']} out {leg['lanes_out']}"
            for leg in row["legs"]
        )
        lines.append(
            f"junction {row['id']} ({row['name'] or '-'}) at ({row['centre'][0]:g}, "
            f"{row['centre'][1]:g}), {len(row['legs'])} legs: {legs}"
        )
    return "\n".join(lines) + "\n"


def import_map(
    file: Path,
    junction: str | None,
    near: str | None,
    legs: list[str] | None,
    extension: float,
    mouth_crosswalks: bool = False,
) -> tuple[str, str]:
    """The map YAML of one junction and a one-line summary."""
    net = read_opendrive(file)
    if near is not None:
        try:
            x, y = (float(v) for v in near.split(","))
        except ValueError:
            raise ConfigError(field="--near", value=near, expected="X,Y in metres") from None
        junction = nearest_junction(net, x, y)
    if junction is None:
        ids = [row["id"] for row in list_junctions(net)]
        if len(ids) != 1:
            raise ConfigError(
                file=str(file),
                field="--junction",
                value=None,
                expected=f"one of its {len(ids)} junctions ({', '.join(ids[:20])}"
                f"{', ...' if len(ids) > 20 else ''}; --list shows them)",
            )
        junction = ids[0]
    data = junction_map_data(
        net, junction, extension=extension, legs=legs, mouth_crosswalks=mouth_crosswalks
    )
    head = (
        f"# sitcov map (layout: lanes), imported from {Path(file).name} junction {junction}\n"
        f"# by: sitcov map import {file} --junction {junction}"
        + (f" --legs {','.join(legs)}" if legs else "")
        + f" --extension {extension:g}"
        + (" --mouth-crosswalks" if mouth_crosswalks else "")
        + "\n# format: docs/roads.md\n"
    )
    text = head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    routes = data["lanes"]["routes"]
    summary = (
        f"junction {junction}, legs {', '.join(data['legs'])}, {len(routes)} movements, "
        f"{len(data['lanes']['crosswalks'])} crosswalks"
    )
    return text, summary
