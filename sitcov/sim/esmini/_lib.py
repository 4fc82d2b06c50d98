"""esmini's C library (``libesminiLib.so``) through ctypes: where it is, and its SE_* calls.

The library is located, in this order, from ``SITCOV_ESMINI_LIB`` (the ``.so`` itself),
``SITCOV_ESMINI`` (the ``esmini`` player; the library is in ``../lib`` next to its
``bin/``), or an ``esmini`` on ``PATH`` (the same layout). esmini keeps one scenario in
global state per process: :func:`library` loads it once, and :data:`LOCK` is held by
whoever has a scenario open (``_session.Session``), so two runs in one process never
interleave (the campaign's executors run one backend per worker process).
"""

from __future__ import annotations

import ctypes
import os
import shutil
import threading
from pathlib import Path

from sitcov.errors import SetupError

#: Environment variables naming the library or the player.
ENV_LIB = "SITCOV_ESMINI_LIB"
ENV_BIN = "SITCOV_ESMINI"
LIB_NAME = "libesminiLib.so"
#: Held while a scenario is open in this process (esmini's state is global).
LOCK = threading.RLock()

_LIB: ctypes.CDLL | None = None


class ObjectState(ctypes.Structure):
    """``SE_ScenarioObjectState`` (esminiLib.hpp): one object's pose, speed and box."""

    _fields_ = [
        ("id", ctypes.c_int),
        ("model_id", ctypes.c_int),
        ("ctrl_type", ctypes.c_int),
        ("timestamp", ctypes.c_double),
        ("x", ctypes.c_double),
        ("y", ctypes.c_double),
        ("z", ctypes.c_double),
        ("h", ctypes.c_double),
        ("p", ctypes.c_double),
        ("r", ctypes.c_double),
        ("roadId", ctypes.c_uint32),
        ("junctionId", ctypes.c_uint32),
        ("t", ctypes.c_double),
        ("laneId", ctypes.c_int),
        ("laneOffset", ctypes.c_double),
        ("s", ctypes.c_double),
        ("speed", ctypes.c_double),
        ("centerOffsetX", ctypes.c_double),
        ("centerOffsetY", ctypes.c_double),
        ("centerOffsetZ", ctypes.c_double),
        ("width", ctypes.c_double),
        ("length", ctypes.c_double),
        ("height", ctypes.c_double),
        ("objectType", ctypes.c_int),
        ("objectCategory", ctypes.c_int),
        ("wheel_angle", ctypes.c_double),
        ("wheel_rot", ctypes.c_double),
        ("visibilityMask", ctypes.c_int),
    ]


class RoadInfo(ctypes.Structure):
    """``SE_RoadInfo`` (esminiLib.hpp): a point ahead along the road or route."""

    _fields_ = [
        ("global_pos_x", ctypes.c_double),
        ("global_pos_y", ctypes.c_double),
        ("global_pos_z", ctypes.c_double),
        ("local_pos_x", ctypes.c_double),
        ("local_pos_y", ctypes.c_double),
        ("local_pos_z", ctypes.c_double),
        ("angle", ctypes.c_double),
        ("road_heading", ctypes.c_double),
        ("road_pitch", ctypes.c_double),
        ("road_roll", ctypes.c_double),
        ("trail_heading", ctypes.c_double),
        ("curvature", ctypes.c_double),
        ("speed_limit", ctypes.c_double),
        ("roadId", ctypes.c_uint32),
        ("junctionId", ctypes.c_uint32),
        ("laneId", ctypes.c_int),
        ("laneOffset", ctypes.c_double),
        ("s", ctypes.c_double),
        ("t", ctypes.c_double),
        ("road_type", ctypes.c_int),
        ("road_rule", ctypes.c_int),
        ("lane_type", ctypes.c_int),
        ("trail_wheel_angle", ctypes.c_double),
    ]


_D, _I, _S, _B = ctypes.c_double, ctypes.c_int, ctypes.c_char_p, ctypes.c_bool
#: name -> (restype, argtypes) of every call used.
_SIGNATURES: dict[str, tuple[object, list[object]]] = {
    "SE_AddPath": (_I, [_S]),
    "SE_ClearPaths": (None, []),
    "SE_SetOption": (_I, [_S]),
    "SE_SetOptionPersistent": (_I, [_S]),
    "SE_UnsetOption": (_I, [_S]),
    "SE_GetODRFilename": (_S, []),
    "SE_GetRouteTotalLength": (_D, [_I]),
    "SE_SetOptionValue": (_I, [_S, _S]),
    "SE_SetSeed": (None, [ctypes.c_uint]),
    "SE_SetLogFilePath": (None, [_S]),
    "SE_Init": (_I, [_S, _I, _I, _I, _I]),
    "SE_InitWithString": (_I, [_S, _I, _I, _I, _I]),
    "SE_StepDT": (_I, [_D]),
    "SE_Close": (None, []),
    "SE_CollisionDetection": (None, [_B]),
    "SE_GetSimulationTime": (_D, []),
    "SE_GetQuitFlag": (_I, []),
    "SE_GetNumberOfObjects": (_I, []),
    "SE_GetId": (_I, [_I]),
    "SE_GetIdByName": (_I, [_S]),
    "SE_GetObjectName": (_S, [_I]),
    "SE_GetObjectState": (_I, [_I, ctypes.POINTER(ObjectState)]),
    "SE_GetObjectInLaneType": (_I, [_I]),
    "SE_GetObjectNumberOfCollisions": (_I, [_I]),
    "SE_GetObjectCollision": (_I, [_I, _I]),
    "SE_ReportObjectPosXYH": (_I, [_I, _D, _D, _D]),
    "SE_ReportObjectSpeed": (_I, [_I, _D]),
    "SE_ReportObjectLateralLanePosition": (_I, [_I, _I, _D]),
    "SE_GetRoadInfoAlongRoute": (_I, [_I, _D, ctypes.POINTER(RoadInfo), _I, _B]),
    "SE_GetRoadInfoAtDistance": (_I, [_I, _D, ctypes.POINTER(RoadInfo), _I, _B]),
    "SE_GetNumberOfRoutePoints": (_I, [_I]),
    "SE_GetNumberOfParameters": (_I, []),
    "SE_GetParameterName": (_S, [_I, ctypes.POINTER(_I)]),
    "SE_GetParameterDouble": (_I, [_S, ctypes.POINTER(_D)]),
    "SE_SetParameterDouble": (_I, [_S, _D]),
    "SE_SetParameterInt": (_I, [_S, _I]),
    "SE_SetParameterString": (_I, [_S, _S]),
    "SE_SetParameterBool": (_I, [_S, _B]),
    "SE_RegisterParameterDeclarationCallback": (
        None,
        [ctypes.CFUNCTYPE(None, ctypes.c_void_p), ctypes.c_void_p],
    ),
}
#: The parameter-declaration callback's C type.
PARAM_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p)


def find_library() -> Path:
    """The path of ``libesminiLib.so`` (module docstring: where it is looked for).

    Raises:
        SetupError: not found (one line naming the variables to set).
    """
    candidates: list[Path] = []
    if os.environ.get(ENV_LIB):
        candidates.append(Path(os.environ[ENV_LIB]))
    players = [os.environ.get(ENV_BIN), shutil.which("esmini")]
    for player in players:
        if player:
            p = Path(player).resolve()
            candidates += [p.parent.parent / "lib" / LIB_NAME, p.parent / LIB_NAME]
    for path in candidates:
        if path.is_file():
            return path
    tried = ", ".join(str(p) for p in candidates) or "nothing set"
    raise SetupError(
        f"esmini not found: set {ENV_BIN} to the esmini player (its lib/{LIB_NAME} next "
        f"to bin/), {ENV_LIB} to {LIB_NAME}, or put esmini on PATH (tried: {tried})"
    )


def library() -> ctypes.CDLL:
    """esmini's library, loaded once per process with every used call's signature set.

    Raises:
        SetupError: not found, or it cannot be loaded.
    """
    global _LIB
    if _LIB is None:
        path = find_library()
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:
            raise SetupError(f"esmini library {path} cannot be loaded: {exc}") from None
        for name, (restype, argtypes) in _SIGNATURES.items():
            fn = getattr(lib, name)
            fn.restype = restype
            fn.argtypes = argtypes
        _LIB = lib
    return _LIB


def available() -> bool:
    """True when the library can be found (no loading)."""
    try:
        find_library()
    except SetupError:
        return False
    return True


_RM: ctypes.CDLL | None = None
RM_LIB_NAME = "libesminiRMLib.so"


class RMPositionData(ctypes.Structure):
    """``RM_PositionData`` (esminiRMLib.hpp): a position on the road."""

    _fields_ = [
        ("x", ctypes.c_double),
        ("y", ctypes.c_double),
        ("z", ctypes.c_double),
        ("h", ctypes.c_double),
        ("p", ctypes.c_double),
        ("r", ctypes.c_double),
        ("hRelative", ctypes.c_double),
        ("roadId", ctypes.c_uint32),
        ("junctionId", ctypes.c_uint32),
        ("laneId", ctypes.c_int),
        ("laneOffset", ctypes.c_double),
        ("s", ctypes.c_double),
    ]


def rm_library() -> ctypes.CDLL:
    """esmini's RoadManager library (``libesminiRMLib.so``, next to ``libesminiLib.so``):
    lane types at arbitrary points (the ego's box corners). Its road state is its own,
    separate from the player's.

    Raises:
        SetupError: not found next to the player library.
    """
    global _RM
    if _RM is None:
        path = find_library().with_name(RM_LIB_NAME)
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:
            raise SetupError(f"esmini RoadManager library {path} cannot be loaded: {exc}") from None
        for name, restype, argtypes in (
            ("RM_Init", _I, [_S]),
            ("RM_Close", _I, []),
            ("RM_SetOptionPersistent", _I, [_S]),
            ("RM_CreatePosition", _I, []),
            ("RM_DeletePosition", _I, [_I]),
            ("RM_GetNumberOfRoadsOverlapping", _I, [_I]),
            ("RM_SetWorldXYHPosition", _I, [_I, _D, _D, _D]),
            ("RM_GetInLaneType", _I, [_I]),
            ("RM_GetPositionData", _I, [_I, ctypes.POINTER(RMPositionData)]),
            ("RM_GetLaneWidth", _I, [_I, _I, ctypes.POINTER(_D)]),
        ):
            fn = getattr(lib, name)
            fn.restype = restype
            fn.argtypes = argtypes
        _RM = lib
    return _RM
