"""The PEM per class of road user: pedestrians and cyclists get their own coefficients.

Vehicles keep the car PEM of ``data/pem.yaml``. Pedestrians and cyclists are smaller,
narrower and lower in contrast, so the same logistic form (:func:`sitcov.perception._pem.
pem_logit`) gets its own coefficients per kind, stored in ``data/pem_classes.yaml``::

    classes:
      pedestrian: {label: person, params: {bias: ..., size_gain: ..., ...}}
      cyclist: {label: bicycle, params: {...}}

Missing parameter names take the car PEM's values, except those of :data:`OWN_TERMS`
(terms newer than the files: a class entry without them has no such term, as before).
The label is the class the detection carries. The file is the output of ``sitcov
calibrate --classes pedestrian,cyclist``
(:mod:`sitcov.calibration._calibrate_classes`), which fits on static frames
(:mod:`sitcov.calibration._class_fit`) and on frames along recorded camera-mode runs; its
command heads the file.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path

from sitcov.errors import ConfigError
from sitcov.perception._pem_params import PEMParams, load_pem_params, read_yaml

#: The shipped per-class file.
PEM_CLASSES_FILE = Path(__file__).parent / "data" / "pem_classes.yaml"
#: Parameters a class entry never takes from the car PEM: without them it keeps the
#: default (no term), so a file written before them loads and draws as before. The car's
#: size bends and side-on bend are car terms (car candidates of the frame model): a class
#: file that does not set them has none, whatever the car PEM fitted; so are the score
#: noise's outlier frames, upper size gain, size bend, lower tail and scale in windy rain
#: (a class's own noise law), and the car's terms for a box cut by the image edge (``cut_gain``,
#: ``cut_tent_gain``) and for one seen head-on from the front (``head_on_gain``), and the
#: car's score ceiling (``noise_ceiling_*``).
OWN_TERMS = (
    "noise_size_gain", "noise_size_max_px", "noise_bend_gain", "noise_bend_px", "box_dx0",
    "box_dy0", "box_dx1", "box_dy1", "jitter_y", "size_hinge40_gain", "size_hinge80_gain",
    "view_hinge40_gain", "noise_outlier_share", "noise_outlier_ratio", "noise_up_size_gain",
    "noise_low_tail", "cut_gain", "cut_tent_gain", "noise_up_rain_wind_gain",
    "noise_up_rain_wind_px", "noise_tau_size_gain", "head_on_gain", "noise_ceiling_logit",
    "noise_ceiling_size_gain", "noise_ceiling_slope",
)  # fmt: skip
#: Kinds scored by the car PEM (``data/pem.yaml``), reported as ``car``.
VEHICLE_KINDS = ("car", "truck")


def load_class_params(path: str | Path | None = None) -> dict[str, tuple[str, PEMParams]]:
    """Kind -> (detection label, PEM parameters) for the non-vehicle kinds."""
    if path is None:
        return dict(_default_classes())
    return _read(Path(path))


@lru_cache(maxsize=1)
def _default_classes() -> tuple[tuple[str, tuple[str, PEMParams]], ...]:
    return tuple(_read(PEM_CLASSES_FILE).items())


def _read(path: Path) -> dict[str, tuple[str, PEMParams]]:
    data = read_yaml(path, "per-class PEM parameters")
    classes = data.get("classes") if isinstance(data, Mapping) else None
    if not isinstance(classes, Mapping):
        raise ConfigError(file=str(path), field="classes", expected="a mapping kind -> entry")
    car = load_pem_params().to_dict()
    default = PEMParams().to_dict()
    car.update({name: default[name] for name in OWN_TERMS})
    out: dict[str, tuple[str, PEMParams]] = {}
    for kind, entry in classes.items():
        where = f"classes.{kind}"
        if not isinstance(entry, Mapping) or not isinstance(entry.get("label"), str):
            raise ConfigError(file=str(path), field=f"{where}.label", expected="a class name")
        params = entry.get("params", {})
        if not isinstance(params, Mapping):
            raise ConfigError(file=str(path), field=f"{where}.params", expected="a mapping")
        out[str(kind)] = (entry["label"], PEMParams.from_mapping({**car, **params}, file=str(path)))
    return out
