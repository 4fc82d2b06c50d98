"""Playing exported scenarios in esmini and comparing with sitcov's stored verdict.

The check behind "the export plays in a real engine": esmini runs each file headless at
sitcov's control period with its global collision detection on (``--collision``); its log
says whether the file and its road loaded, whether a route was rejected ("not valid") or
anything else went wrong (``[error]`` lines), and which road user the ``hero`` hit when
("Collision between hero and ov" at [t]). :meth:`Played.agrees`: the same road user as the
file's stored ``sitcov_collision_actor`` (none for a run without a collision), within
:data:`TIME_TOLERANCE` of ``sitcov_collision_time``.
"""

from __future__ import annotations

import re
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sitcov.errors import ConfigError
from sitcov.sim.xosc._esmini import find_esmini

#: Largest difference between esmini's and sitcov's collision time that agrees [s].
TIME_TOLERANCE = 0.5
#: esmini's step [s]: sitcov's control period.
TIMESTEP = 0.05
#: Wall-time limit of one esmini run [s].
WALL_TIMEOUT = 120.0

_COLLISION = re.compile(r"^\[(?P<t>[0-9.]+)\] \[\w+\] Collision between (?P<a>\S+) and (?P<b>\S+)")
_PROBLEM = re.compile(r"not valid|\[error\]|failed to load|can't|cannot", re.IGNORECASE)
#: esmini's notes on a road file's own quirks, not on the scenario: CARLA's Town03 has
#: zero-length roads whose road marks esmini ignores.
_ROAD_NOTE = re.compile(r"Roadmark sOffset .* beyond road length")


@dataclass(frozen=True)
class Played:
    """What esmini made of one scenario file.

    Attributes:
        path: the scenario file.
        loaded: esmini loaded scenario and road and ran to the end (exit status 0).
        problems: log lines about rejected routes or errors.
        collisions: (time [s], entity, entity) in the order esmini reported them.
        expected_actor: the road user sitcov's ego hit ("" for none), from the file.
        expected_time: when [s] (None without a collision).
    """

    path: Path
    loaded: bool
    problems: tuple[str, ...]
    collisions: tuple[tuple[float, str, str], ...]
    expected_actor: str
    expected_time: float | None
    params: dict[str, str] = field(default_factory=dict)
    kinds: dict[str, str] = field(default_factory=dict)

    @property
    def hero_hit(self) -> tuple[str, float] | None:
        """The first road user esmini's hero collided with, and when."""
        for t, a, b in self.collisions:
            if "hero" in (a, b):
                return (b if a == "hero" else a), t
        return None

    @property
    def clean(self) -> bool:
        """Loaded, and no rejected route nor error in the log."""
        return self.loaded and not self.problems

    def agrees(self, tolerance: float = TIME_TOLERANCE) -> bool:
        """esmini's hero hit the road user sitcov's ego hit, within ``tolerance`` [s]; or
        neither hit anything."""
        hit = self.hero_hit
        if not self.expected_actor:
            return hit is None
        if hit is None or hit[0] != self.expected_actor or self.expected_time is None:
            return False
        return abs(hit[1] - self.expected_time) <= tolerance


def parameters(path: str | Path) -> dict[str, str]:
    """The ``ParameterDeclarations`` of a scenario file: name -> value."""
    root = ET.parse(path).getroot()
    decls = root.find("ParameterDeclarations")
    if decls is None:
        return {}
    return {d.get("name", ""): d.get("value", "") for d in decls}


def road_users(path: str | Path) -> dict[str, str]:
    """Entity name -> sitcov kind (``car``, ``cyclist``, ``pedestrian``) of a scenario file's
    road users other than the hero (``sitcov_kind`` properties)."""
    root = ET.parse(path).getroot()
    out: dict[str, str] = {}
    for obj in root.iter("ScenarioObject"):
        name = obj.get("name", "")
        for prop in obj.iter("Property"):
            if prop.get("name") == "sitcov_kind" and name != "hero":
                out[name] = prop.get("value", "")
    return out


def distribution_sets(path: str | Path) -> list[dict[str, str]]:
    """The parameter values of each run of a ``ParameterValueDistribution`` file (its
    ``ValueSetDistribution``), in permutation order."""
    root = ET.parse(path).getroot()
    return [
        {a.get("parameterRef", ""): a.get("value", "") for a in value_set}
        for value_set in root.iter("ParameterValueSet")
    ]


def distribution_template(path: str | Path) -> Path:
    """The template scenario a distribution file names (relative to the file)."""
    node = ET.parse(path).getroot().find("ParameterValueDistribution/ScenarioFile")
    if node is None:
        raise ConfigError(file=str(path), field="ScenarioFile", expected="a distribution file")
    return Path(path).parent / node.get("filepath", "")


def play_distribution(path: str | Path, esmini: Path | None = None) -> list[Played]:
    """Play every permutation of a distribution file (:func:`play` of its template)."""
    template = distribution_template(path)
    return [
        play(template, esmini, distribution=Path(path), permutation=i)
        for i in range(len(distribution_sets(path)))
    ]


def play(
    path: str | Path,
    esmini: Path | None = None,
    *,
    timestep: float = TIMESTEP,
    distribution: Path | None = None,
    permutation: int = 0,
) -> Played:
    """Run one scenario in esmini (headless, fixed step, collision detection on); with
    ``distribution``, the template ``path`` with that file's run ``permutation``.

    Raises:
        ConfigError: esmini cannot be found.
    """
    esmini = esmini or find_esmini()
    if esmini is None:
        raise ConfigError(
            field="esmini", value=None,
            expected="the esmini program (set SITCOV_ESMINI or put it on PATH)",
        )  # fmt: skip
    path = Path(path)
    params = parameters(path)
    extra: list[str] = []
    if distribution is not None:
        params.update(distribution_sets(distribution)[permutation])
        dist = str(Path(distribution).resolve())
        extra = ["--param_dist", dist, "--param_permutation", str(permutation)]
    with tempfile.TemporaryDirectory(prefix="sitcov-esmini-") as tmp:
        log = Path(tmp) / "log.txt"
        try:
            proc = subprocess.run(
                [
                    str(esmini), "--headless", "--osc", str(path.resolve()),
                    "--fixed_timestep", f"{timestep:g}", "--collision",
                    "--logfile_path", str(log), "--disable_stdout", *extra,
                ],
                cwd=tmp, capture_output=True, text=True, timeout=WALL_TIMEOUT, check=False,
            )  # fmt: skip
            # with --param_dist esmini names the log log_<i+1>_of_<n>.txt
            logs = sorted(Path(tmp).glob("log*.txt"))
            text = logs[0].read_text(errors="replace") if logs else proc.stdout
            ok = proc.returncode == 0
        except subprocess.TimeoutExpired:
            text, ok = "", False
    lines = text.splitlines()
    loaded = ok and any("Loaded OpenDRIVE" in line for line in lines)
    problems = tuple(
        line for line in lines if _PROBLEM.search(line) and not _ROAD_NOTE.search(line)
    )
    collisions = tuple(
        (float(m["t"]), m["a"], m["b"]) for m in map(_COLLISION.match, lines) if m is not None
    )
    actor = params.get("sitcov_collision_actor", "")
    t = float(params.get("sitcov_collision_time", "-1") or -1)
    kinds = road_users(path) if distribution is None else {}
    shown = path if distribution is None else Path(f"{Path(distribution).name}#{permutation}")
    return Played(shown, loaded, problems, collisions, actor, t if t >= 0 else None, params, kinds)


@dataclass(frozen=True)
class PlaySummary:
    """Counts over a set of played files (see :func:`summarise`)."""

    files: int
    clean: int
    agree: int
    expected_collisions: int
    disagreeing: tuple[str, ...]

    @property
    def clean_rate(self) -> float:
        """Share of files that loaded without a rejected route or error."""
        return self.clean / self.files if self.files else 0.0

    @property
    def agree_rate(self) -> float:
        """Share of files whose esmini collision agrees with sitcov's verdict."""
        return self.agree / self.files if self.files else 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {
            "files": self.files,
            "clean": self.clean,
            "clean_rate": round(self.clean_rate, 4),
            "agree": self.agree,
            "agree_rate": round(self.agree_rate, 4),
            "expected_collisions": self.expected_collisions,
            "disagreeing": list(self.disagreeing),
        }


def summarise(played: Iterable[Played]) -> PlaySummary:
    """How many loaded cleanly and how many agree with sitcov (file names of the rest)."""
    items = list(played)
    return PlaySummary(
        files=len(items),
        clean=sum(p.clean for p in items),
        agree=sum(p.agrees() for p in items),
        expected_collisions=sum(bool(p.expected_actor) for p in items),
        disagreeing=tuple(p.path.name for p in items if not (p.clean and p.agrees())),
    )
