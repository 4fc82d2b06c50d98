"""The CARLA backend (a real CARLA server through the ``carla`` client wheel) and the
OpenSCENARIO export of situations for Town03.

The ``carla`` module is imported only when a backend is built; everything else here works
without it.
"""

from sitcov.sim.carla._backend import CarlaBackend, friction_scale
from sitcov.sim.carla._mapfile import CarlaMap, available_maps, load_carla_map
from sitcov.sim.carla._options import backend_for_worker, carla_backend_options, parse_servers
from sitcov.sim.carla._state import image_to_rgb
from sitcov.sim.carla._surface import SURFACE
from sitcov.sim.carla._xosc import (
    export_xosc,
    ov_timing,
    situation_scenario,
    situations_from_json,
)

__all__ = [
    "SURFACE",
    "CarlaBackend",
    "CarlaMap",
    "available_maps",
    "backend_for_worker",
    "carla_backend_options",
    "export_xosc",
    "friction_scale",
    "image_to_rgb",
    "load_carla_map",
    "ov_timing",
    "parse_servers",
    "situation_scenario",
    "situations_from_json",
]
