"""One scenario open in esmini: init from XML text, step, read objects, report the ego.

esmini's state is global to the process, so a :class:`Session` holds ``_lib.LOCK`` from
``__enter__`` to ``__exit__`` and always closes the scenario (also when the run raises or
a wall-time alarm interrupts it), so the next run starts clean.
"""

from __future__ import annotations

import ctypes
import math
import os
import tempfile
from pathlib import Path
from typing import Any

from sitcov.errors import SitcovError
from sitcov.sim.esmini._lib import (
    LOCK,
    ObjectState,
    RMPositionData,
    RoadInfo,
    library,
    rm_library,
)

#: esmini's object types (``Object::Type``) and vehicle categories (``Vehicle::Category``)
#: as sitcov's actor kinds.
PEDESTRIAN_TYPE = 2
VEHICLE_CATEGORY_KIND = {2: "truck", 3: "truck", 5: "truck", 6: "cyclist", 7: "cyclist"}
#: Lane types a car may drive on (esminiLib.hpp: "any drivable lane" mask).
DRIVABLE_LANES = 1966594
#: Lane type of a point outside every lane of the road it is matched to.
NO_LANE = 1
#: Return codes of the road look-ahead that end a route or road.
_END_CODES = (-4, -3, -2, -1)


class EsminiError(SitcovError):
    """esmini refused a scenario (the run is stored as ``error`` with this message)."""


class Session:
    """A scenario played by esmini's library (a context manager; see the module docstring).

    Args:
        xml: the OpenSCENARIO text (``ScenarioFile.render``).
        seed: esmini's seed (its own stochastic elements).
        paths: extra search paths for roads and catalogs.
    """

    def __init__(self, xml: str, seed: int, paths: tuple[str, ...] = ()) -> None:
        self.xml, self.seed, self.paths = xml, int(seed) & 0xFFFFFFFF, paths
        self.lib = library()
        self._states: dict[int, ObjectState] = {}

    def __enter__(self) -> Session:
        LOCK.acquire()
        try:
            self._init()
        except BaseException:
            LOCK.release()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self.lib.SE_Close()
        finally:
            LOCK.release()

    def _init(self, log: str | None = None) -> None:
        lib = self.lib
        lib.SE_SetOptionPersistent(b"disable_stdout")
        lib.SE_ClearPaths()
        for path in self.paths:
            lib.SE_AddPath(path.encode())
        if log is None:
            lib.SE_SetOptionPersistent(b"disable_log")
        else:
            lib.SE_UnsetOption(b"disable_log")
            lib.SE_SetLogFilePath(log.encode())
        lib.SE_SetSeed(self.seed)
        if lib.SE_InitWithString(self.xml.encode(), 0, 0, 0, 0) == 0:
            return
        if log is not None:
            lib.SE_Close()  # flushes the log
            raise EsminiError(_log_errors(log))
        lib.SE_Close()
        fd, name = tempfile.mkstemp(prefix="sitcov-esmini-", suffix=".log")
        os.close(fd)
        try:
            self._init(name)  # again with a log, for esmini's reason
        finally:
            Path(name).unlink(missing_ok=True)

    # --- objects ------------------------------------------------------------------------------

    def objects(self) -> list[tuple[int, str]]:
        """(id, name) of every object, in esmini's order."""
        lib = self.lib
        out = []
        for i in range(lib.SE_GetNumberOfObjects()):
            oid = lib.SE_GetId(i)
            out.append((oid, (lib.SE_GetObjectName(oid) or b"").decode()))
        return out

    def state(self, oid: int) -> ObjectState:
        """The object's current state (one struct per object, refreshed in place)."""
        st = self._states.get(oid)
        if st is None:
            st = self._states[oid] = ObjectState()
        self.lib.SE_GetObjectState(oid, ctypes.byref(st))
        return st

    def report(self, oid: int, x: float, y: float, h: float, speed: float) -> None:
        """Set an externally controlled object's reference point, heading and speed."""
        self.lib.SE_ReportObjectPosXYH(oid, x, y, h)
        self.lib.SE_ReportObjectSpeed(oid, speed)

    def report_speed(self, oid: int, speed: float) -> None:
        """Set an object's speed [m/s]; one esmini's default controller drives moves that far
        along its lane or route in the next step (no storyboard action may set it then)."""
        self.lib.SE_ReportObjectSpeed(oid, speed)

    def step(self, dt: float) -> None:
        """Advance the storyboard and every other object by ``dt`` [s]."""
        if self.lib.SE_StepDT(dt) != 0:
            raise EsminiError(f"esmini failed to step at t={self.time():.2f} s")

    def time(self) -> float:
        """Simulation time [s]."""
        return float(self.lib.SE_GetSimulationTime())

    def ended(self) -> bool:
        """True once the storyboard's stop trigger fired."""
        return self.lib.SE_GetQuitFlag() != 0

    def road_file(self) -> str:
        """The OpenDRIVE file esmini loaded."""
        return (self.lib.SE_GetODRFilename() or b"").decode()

    def lane_points(self, oid: int, spacing: float, max_length: float) -> list[tuple[float, float]]:
        """Points [m] every ``spacing`` metres along the object's assigned route (lane
        centre), or along its lane ahead when it has no route, up to ``max_length``."""
        lib = self.lib
        routed = lib.SE_GetNumberOfRoutePoints(oid) > 0
        length = max_length
        if routed:
            length = min(length, float(lib.SE_GetRouteTotalLength(oid)) or max_length)
        look = lib.SE_GetRoadInfoAlongRoute if routed else lib.SE_GetRoadInfoAtDistance
        info = RoadInfo()
        points: list[tuple[float, float]] = []
        n = int(length / spacing)
        for i in range(n + 1):
            rc = look(oid, i * spacing, ctypes.byref(info), 0, not routed)
            if rc in _END_CODES and i > 0:
                break
            p = (info.global_pos_x, info.global_pos_y)
            if not points or math.dist(points[-1], p) > 1e-6:
                points.append(p)
        return points


def route_paths(
    xml: str, names: tuple[str, ...], spacing: float, max_length: float
) -> dict[str, list[tuple[float, float]]]:
    """The paths [m] esmini's default controller drives the named entities along their
    assigned routes, one point every ``spacing`` metres up to the route's length (or
    ``max_length``), on the centre line of the lane each starts in: a dry run of ``xml``
    (``ScenarioFile.render(..., external=False)``: no story, no stop trigger) that moves
    each entity ``spacing`` per step.

    Why: esmini's route look-ahead (``SE_GetRoadInfoAlongRoute``) stops in some junction
    connecting roads of Town03 (END_OF_ROAD after the OV's left turn from the stem) where
    its default controller drives on; this is the path the object really takes.
    """
    dt = 0.05
    with Session(xml, 0) as session:
        lib = session.lib
        ids = {name: oid for oid, name in session.objects() if name in names}
        limit = {
            name: min(max_length, float(lib.SE_GetRouteTotalLength(oid)) or max_length)
            for name, oid in ids.items()
        }
        paths: dict[str, list[tuple[float, float]]] = {name: [] for name in ids}
        for oid in ids.values():  # the lane's centre line, as the look-ahead gives it
            lib.SE_ReportObjectLateralLanePosition(oid, session.state(oid).laneId, 0.0)
        for _ in range(int(max(limit.values(), default=0.0) / spacing) + 1):
            for name, oid in ids.items():
                path = paths[name]
                if len(path) * spacing > limit[name]:
                    session.report_speed(oid, 0.0)
                    continue
                st = session.state(oid)
                p = (st.x, st.y)
                if path and math.dist(path[-1], p) < 1e-6:
                    if len(path) > 1:  # stuck: no road ahead
                        limit[name] = 0.0
                        continue
                else:
                    path.append(p)
                session.report_speed(oid, spacing / dt)
            session.step(dt)
    return paths


def kind_of(st: ObjectState) -> str:
    """sitcov's actor kind of an esmini object."""
    if st.objectType == PEDESTRIAN_TYPE:
        return "pedestrian"
    return VEHICLE_CATEGORY_KIND.get(st.objectCategory, "car")


def _log_errors(log: str) -> str:
    try:
        lines = Path(log).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        lines = []
    errors = [ln.rsplit("] [error]", 1)[-1].strip() for ln in lines if "[error]" in ln]
    reason = "; ".join(dict.fromkeys(errors)) or "no reason logged"
    return f"esmini could not load the scenario: {reason}"


class RoadProbe:
    """Lane types under points of one OpenDRIVE file (esmini's RoadManager library),
    loaded once per process and file."""

    _loaded: str | None = None
    _handles: list[int] = []

    def __init__(self, odr: str) -> None:
        self.lib: Any = rm_library()
        cls = type(self)
        if cls._loaded != odr:
            lib = self.lib
            if cls._loaded is not None:
                lib.RM_Close()
            lib.RM_SetOptionPersistent(b"disable_stdout")
            lib.RM_SetOptionPersistent(b"disable_log")
            if lib.RM_Init(odr.encode()) != 0:
                raise EsminiError(f"{odr}: esmini's RoadManager cannot load this road")
            cls._handles = [lib.RM_CreatePosition() for _ in range(4)]
            cls._loaded = odr

    def lane_widths(self, points: list[tuple[float, float]]) -> list[float]:
        """The width [m] of the lane under each route point (heading towards the next
        point), NaN where no lane is found."""
        lib = self.lib
        handle = self._handles[0]
        data = RMPositionData()
        width = ctypes.c_double()
        out = []
        for i, (x, y) in enumerate(points):
            nx, ny = points[min(i + 1, len(points) - 1)]
            px, py = points[max(i - 1, 0)] if i + 1 >= len(points) else (x, y)
            lib.RM_SetWorldXYHPosition(handle, x, y, math.atan2(ny - py, nx - px))
            lib.RM_GetPositionData(handle, ctypes.byref(data))
            ok = lib.RM_GetLaneWidth(handle, data.laneId, ctypes.byref(width)) == 0
            out.append(width.value if ok and width.value > 0 else math.nan)
        return out

    def off_road(self, corners: list[tuple[float, float]], h: float) -> bool:
        """True if a corner is on no drivable lane.

        A position handle keeps to the road it was on (esmini searches near it first), so
        in a junction a corner can be placed outside the lanes of the connecting road it
        came from while it is on another one: a corner found off a drivable lane is looked
        up again from scratch before it counts. Junctions also have gaps between their
        connecting roads' lanes (Town03): a point in no lane (type 1) but within some
        road's extent (``RM_GetNumberOfRoadsOverlapping`` > 0) counts as on the road; a
        sidewalk, border, shoulder (any lane type not drivable), or no road at all, as off.
        """
        lib = self.lib
        for handle, (x, y) in zip(self._handles, corners, strict=False):
            lib.RM_SetWorldXYHPosition(handle, x, y, h)
            if lib.RM_GetInLaneType(handle) & DRIVABLE_LANES:
                continue
            fresh = lib.RM_CreatePosition()
            try:
                lib.RM_SetWorldXYHPosition(fresh, x, y, h)
                kind = lib.RM_GetInLaneType(fresh)
                if kind & DRIVABLE_LANES:
                    continue
                if kind != NO_LANE or lib.RM_GetNumberOfRoadsOverlapping(fresh) == 0:
                    return True
            finally:
                lib.RM_DeletePosition(fresh)
        return False
