"""The reference stack's parameters, its seeded faults (paper's Table 2) as data, and validation.

A fault is nothing but a set of parameter overrides, so a fault is reproducible from the
configuration stored with every run; user ``params`` override both defaults and fault.

F1 is defined relative to the detector in use (:mod:`sitcov.av._fault_map`): its threshold
is computed from the shipped PEM, which describes our SSD, so that it rejects the same share
of true positives as the paper's 0.95 did for its detector; ``f1-raw`` keeps the paper's
number. F2 and F3 are geometric (fractions of the image width on the same 800 px, 100°
camera as the paper's) and carry over unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from sitcov.av._fault_map import F1_ACCEPTANCE_RATIO, F1_RAW_THRESHOLD, f1_threshold
from sitcov.errors import ConfigError

#: Default parameters of :class:`sitcov.av.ReferenceStack`.
DEFAULT_PARAMS: dict[str, Any] = {
    # AEB: the paper's three perception tests.
    "threshold": 0.5,  # minimum detection score [-]
    "centering": (0.05, 0.98),  # open interval for the box centre / image width [-]
    "distance": 0.6,  # fire when round((1 - box width / image width)^4, 1) <= distance [-]
    "label": "car",  # detection class that counts as a vehicle
    # detection classes the AEB acts on (the label above always counts); how closeness
    # is judged per class: sitcov.av._aeb.CLASS_SIZE, docs/embedded.md
    "classes": ("car", "person", "bicycle"),
    # What the AEB does once it fired: brake fully to a standstill, hold while a frame
    # still triggers it and for aeb_hold seconds after the last one that did, then hand
    # back to route following (a production AEB holds the car, then releases to the
    # driver). aeb_latch: brake to the end of the run instead (the paper's stack; the
    # "reference-latched" stack).
    "aeb_latch": False,
    "aeb_hold": 1.0,  # [s]
    # Route following (CARLA's local planner and PID controllers).
    "target_speed_kmh": 25.0,  # cruise speed [km/h]
    "lat_kp": 0.58,  # lateral P gain [1/rad]
    "lat_kd": 0.02,  # lateral D gain [s/rad]
    "lat_ki": 0.5,  # lateral I gain [1/(rad s)]
    "lon_kp": 0.15,  # longitudinal P gain [h/km]
    "lon_kd": 0.05,  # longitudinal D gain [h s/km]
    "lon_ki": 0.07,  # longitudinal I gain [h/(km s)]
    "pid_window": 10,  # errors kept for the D and I terms [steps]
    "lookahead_base": 3.0,  # target waypoint at least this far ahead [m]
    "lookahead_gain": 0.5,  # ... plus this times the speed [s]
    "max_throttle": 0.75,  # throttle cap of CARLA's local planner [-]
    "max_brake": 0.3,  # brake cap for speed regulation (the AEB brakes with 1.0) [-]
    "max_steer": 0.8,  # steer cap [-]
    "max_steer_change": 0.1,  # steer change limit per control step [-]
}

#: The paper's seeded faults: each overrides one AEB parameter. A callable value is computed
#: when the fault is resolved (F1's threshold, from the detector's PEM).
FAULTS: dict[str, dict[str, Any]] = {
    "f1": {"threshold": f1_threshold},
    "f1-raw": {"threshold": F1_RAW_THRESHOLD},
    "f2": {"centering": (0.3, 0.6)},
    "f3": {"distance": 0.35},
    "f4": {"classes": ("car", "bicycle")},
}

#: One line per fault, for help texts and reports.
FAULT_DESCRIPTIONS: dict[str, str] = {
    "f1": "detection score threshold too high, relative to the detector in use: the threshold "
    f"computed from the PEM to keep {F1_ACCEPTANCE_RATIO:.0%} of the true positives the nominal "
    "0.5 accepts at the braking distance (the paper's 0.95 for its detector)",
    "f1-raw": "the paper's raw threshold 0.95 (for our detector: no emergency brake at all)",
    "f2": "centering limits too narrow (0.3, 0.6): vehicles off the image centre are ignored",
    "f3": "distance threshold too low (0.35): the brake fires only when the vehicle is very close",
    "f4": "the AEB ignores pedestrians: it acts on car and bicycle detections only (not 'person')",
}


def fault_overrides(fault: str) -> dict[str, Any]:
    """The parameter overrides of ``fault`` with computed values resolved.

    Raises:
        ConfigError: unknown fault (one line listing the known ones).
    """
    if fault not in FAULTS:
        raise ConfigError(
            f"unknown fault {fault!r}; expected one of: {', '.join(sorted(FAULTS))} (or none)",
            field="fault",
            value=fault,
            expected=" | ".join(sorted(FAULTS)),
        )
    return {k: v() if callable(v) else v for k, v in FAULTS[fault].items()}


_INT_PARAMS = {"pid_window"}


def _number(name: str, value: Any, lo: float | None = None, hi: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(field=f"params.{name}", value=value, expected="a number")
    value = float(value)
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ConfigError(field=f"params.{name}", value=value, expected=f"a number in [{lo}, {hi}]")
    return value


def _validate(name: str, value: Any) -> Any:
    if name == "label":
        if not isinstance(value, str) or not value:
            raise ConfigError(field="params.label", value=value, expected="a class name")
        return value
    if name == "classes":
        if (
            not isinstance(value, list | tuple)
            or not value
            or not all(isinstance(c, str) and c for c in value)
        ):
            raise ConfigError(
                field="params.classes", value=value, expected="a list of class names, e.g. [car]"
            )
        return tuple(value)
    if name == "centering":
        ok = isinstance(value, list | tuple) and len(value) == 2
        if ok:
            lo = _number("centering[0]", value[0], 0.0, 1.0)
            hi = _number("centering[1]", value[1], 0.0, 1.0)
            ok = lo < hi
        if not ok:
            raise ConfigError(
                field="params.centering", value=value, expected="[lo, hi] with 0 <= lo < hi <= 1"
            )
        return (lo, hi)
    if name == "aeb_latch":
        if not isinstance(value, bool):
            raise ConfigError(field="params.aeb_latch", value=value, expected="true or false")
        return value
    if name == "threshold":
        return _number(name, value, 0.0, 1.0)
    if name in _INT_PARAMS:
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ConfigError(field=f"params.{name}", value=value, expected="an integer >= 1")
        return value
    if name in ("max_throttle", "max_brake", "max_steer", "max_steer_change"):
        return _number(name, value, 0.0, 1.0)
    if name == "target_speed_kmh":
        return _number(name, value, 0.0, 200.0)
    return _number(name, value, 0.0)


def resolve_params(fault: str | None = None, params: Mapping[str, Any] | None = None) -> dict:
    """The effective parameters: defaults, then the fault's overrides, then ``params``.

    Raises:
        ConfigError: for an unknown fault or parameter (listing the allowed ones) or a value
            of the wrong type or range.
    """
    merged = dict(DEFAULT_PARAMS)
    if fault is not None:
        merged.update(fault_overrides(fault))
    for name, value in (params or {}).items():
        if name not in DEFAULT_PARAMS:
            raise ConfigError(
                f"unknown reference-stack parameter {name!r}; "
                f"expected one of: {', '.join(sorted(DEFAULT_PARAMS))}",
                field=f"params.{name}",
                value=name,
                expected=" | ".join(sorted(DEFAULT_PARAMS)),
            )
        merged[name] = value
    return {name: _validate(name, value) for name, value in merged.items()}
