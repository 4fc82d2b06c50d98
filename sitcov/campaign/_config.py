"""Campaign configuration: validated with pydantic, from a YAML file and/or flags.

Example ``campaign.yaml``::

    name: night-fog
    generator: sitcov-min
    runs: 2000
    seed: 7
    backend_options: {perception: pem}
    physics: carla          # or physical (docs/weather.md)
    judge: default          # or paper | strict | a list of kinds (docs/campaigns.md)
    fault: f2
    executor: processes
    workers: 2
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from sitcov.errors import ConfigError

#: Settings that only change how a campaign executes, never what it stores; they may differ
#: when a campaign is resumed or extended (``runs`` may grow too).
EXECUTION_ONLY = frozenset({"runs", "executor", "workers", "ray_address"})


class CampaignConfig(BaseModel):
    """Everything that defines a campaign (stored with it, compared on resume).

    Attributes:
        name: campaign name, unique within a store.
        hyperspace: ``t-junction`` (built in) or a hyperspace YAML path.
        generator: generator name (or ``module:Class``); ``generator_options`` its options.
        backend: backend name (or ``module:Class``); ``backend_options`` e.g. ``perception``.
        physics: the backend's physics profile, ``carla`` (what CARLA does: weather acts on
            perception only) or ``physical`` (wet-road friction, crosswind force); given to
            the backend as its ``physics`` option. ``backend_options.physics`` is moved here.
        judge: what counts as a failure: ``default`` (collision while moving, road
            departure, blocked, route incomplete), ``paper`` (every ego collision, the
            paper's judge), ``strict`` (every kind) or a list of kinds
            (``sitcov.sim.FAILURE_KINDS``).
        perception_draws: each run's world simulated this many times (odd) with other
            perception noise, the majority's verdict stored with the share of failing
            draws (``sitcov.campaign._draws``); 1 (the default) is one run per situation.
            Only for a backend that can rerun a world with other perception noise (the
            embedded one).
        av: AV stack name (or ``module:Class``); ``fault`` a seeded fault (f1|f2|f3);
            ``av_params`` parameter overrides.
        runs: total runs wanted in the campaign (running again with more extends it).
        seed: campaign seed; every run's situation and seed derive from (seed, index).
        batch_size: asks per batch, i.e. how often a learning generator is told outcomes.
        executor: ``serial`` | ``processes`` | ``ray``; ``workers`` how many in parallel.
        ray_address: an existing Ray cluster (else a local one is started).
        run_timeout: wall-clock limit per run [s]; exceeded runs are stored as ``timeout``.
        record_traces: store each run's trajectories (for top-down pictures).
        replay_failures_first: first re-run the failures of the store's other campaigns.
        tags: free labels stored with the campaign (e.g. by experiments).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field("default", min_length=1)
    hyperspace: str = "t-junction"
    generator: str = "sitcov"
    generator_options: dict[str, Any] = Field(default_factory=dict)
    backend: str = "embedded"
    backend_options: dict[str, Any] = Field(default_factory=dict)
    physics: Literal["carla", "physical"] = "carla"
    judge: str | list[str] = "default"
    perception_draws: int = Field(1, ge=1)
    av: str = "reference"
    fault: str | None = None
    av_params: dict[str, Any] | None = None
    runs: int = Field(1000, ge=0)
    seed: int = Field(0, ge=0)
    batch_size: int = Field(32, ge=1)
    executor: Literal["serial", "processes", "ray"] = "processes"
    workers: int = Field(default_factory=lambda: os.cpu_count() or 1, ge=1)
    ray_address: str | None = None
    run_timeout: float | None = Field(None, gt=0)
    record_traces: bool = False
    replay_failures_first: bool = False
    tags: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="before")
    @classmethod
    def _physics_from_backend_options(cls, data: Any) -> Any:
        """``backend_options.physics`` and ``physics`` are one setting; keep it in ``physics``."""
        if not isinstance(data, Mapping) or not isinstance(data.get("backend_options"), Mapping):
            return data
        options = dict(data["backend_options"])
        if "physics" not in options:
            return data
        value = options.pop("physics")
        if data.get("physics") not in (None, value):
            raise ValueError(
                f"physics {data['physics']!r} and backend_options.physics {value!r} disagree"
            )
        return {**data, "backend_options": options, "physics": value}

    @field_validator("judge", mode="before")
    @classmethod
    def _canonical_judge(cls, value: Any) -> Any:
        from sitcov.sim import normalize_judge

        if value is not None and not isinstance(value, str | list | tuple):  # e.g. false
            value = [value]  # refused below as an unknown kind, naming the value
        try:
            return normalize_judge(value)
        except ConfigError as exc:
            raise ValueError(str(exc.expected)) from None

    @field_validator("perception_draws")
    @classmethod
    def _odd_draws(cls, value: int) -> int:
        if value % 2 == 0:
            raise ValueError("an odd number of perception draws (a majority needs no ties)")
        return value

    def defining(self) -> dict[str, Any]:
        """The JSON form without execution-only settings (what must match on resume)."""
        data = self.model_dump(mode="json")
        return {k: v for k, v in data.items() if k not in EXECUTION_ONLY}


def _config_error(exc: ValidationError, file: str | None) -> ConfigError:
    first = exc.errors()[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(top level)"
    value = first.get("input")
    if first["type"] == "extra_forbidden":
        known = ", ".join(sorted(CampaignConfig.model_fields))
        return ConfigError(
            f"{file + ': ' if file else ''}{loc}: unknown field; expected one of: {known}",
            file=file,
            field=loc,
            value=value,
            expected=known,
        )
    message = first["msg"].removeprefix("Value error, ")
    if first["type"] == "value_error" and not first["loc"]:
        return ConfigError(f"{file + ': ' if file else ''}{message}", file=file)
    return ConfigError(file=file, field=loc, value=value, expected=message.lower())


#: Local worker processes per CPU core at most: a run is CPU-bound, so more processes than
#: cores only add memory (each holds a backend and a stack) and time slicing.
WORKERS_PER_CORE = 4


def max_workers() -> int:
    """The most local worker processes a campaign may ask for on this machine."""
    return WORKERS_PER_CORE * (os.cpu_count() or 1)


def check_workers(
    workers: int | None, executor: str = "processes", *, file: str | None = None
) -> None:
    """Refuse more local worker processes than :func:`max_workers` (one line naming the
    bound). Ray workers live on a cluster this machine cannot count: not bounded here."""
    if workers is None or executor == "ray" or workers <= max_workers():
        return
    raise ConfigError(
        file=file,
        field="workers",
        value=workers,
        expected=f"at most {max_workers()} ({WORKERS_PER_CORE} per CPU core of this machine: "
        "runs are CPU-bound, more processes only add memory)",
    )


def load_config(
    file: str | Path | None = None, overrides: Mapping[str, Any] | None = None
) -> CampaignConfig:
    """Build a config from a YAML file (optional) with ``overrides`` on top (flags).

    Overrides whose value is None are ignored (a flag that was not given).

    Raises:
        ConfigError: naming the file, the field, the value and what was expected.
    """
    data: dict[str, Any] = {}
    where = str(file) if file is not None else None
    if file is not None:
        try:
            loaded = yaml.safe_load(Path(file).read_text())
        except OSError as exc:
            raise ConfigError(f"{where}: cannot read campaign config ({exc.strerror})") from None
        except UnicodeDecodeError as exc:
            raise ConfigError(f"{where}: not UTF-8 text (byte {exc.start})") from None
        except (yaml.YAMLError, ValueError, RecursionError) as exc:  # multi-line: keep one
            raise ConfigError(f"{where}: not valid YAML ({' '.join(str(exc).split())})") from None
        if loaded is None:
            loaded = {}
        if not isinstance(loaded, dict):
            raise ConfigError(file=where, field="(top level)", value=loaded, expected="a mapping")
        data.update(loaded)
    for key, value in (overrides or {}).items():
        if value is None:
            continue
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    try:
        config = CampaignConfig(**data)
    except ValidationError as exc:
        raise _config_error(exc, where) from None
    if "workers" in data:  # the default (the CPU count) is within the bound
        check_workers(config.workers, config.executor, file=where)
    return config


def config_differences(stored: Mapping[str, Any], new: CampaignConfig) -> list[str]:
    """Fields (other than execution-only ones) where ``new`` differs from a stored config.

    Each entry reads ``field: stored -> new``.
    """
    fresh = new.defining()
    try:  # fill fields added since the campaign was stored with their defaults
        stored = CampaignConfig(**{k: v for k, v in stored.items() if k != "workers"}).defining()
    except (ValidationError, TypeError):
        stored = dict(stored)
    keys = sorted((set(stored) | set(fresh)) - EXECUTION_ONLY)
    return [
        f"{k}: {stored.get(k)!r} -> {fresh.get(k)!r}" for k in keys if stored.get(k) != fresh.get(k)
    ]


def run_overrides(
    *,
    perception: str | None = None,
    carla: Mapping[str, Any] | None = None,
    esmini: Mapping[str, Any] | None = None,
    av_cmd: str | None = None,
    av_step_timeout: float | None = None,
    grey_box: bool | None = None,
    **fields: Any,
) -> dict[str, Any]:
    """Config overrides from ``sitcov run`` flags (None = flag not given).

    Args:
        perception: ``--perception``, an option of the embedded backend.
        carla: the ``--carla-*``/``--map`` flags that were given, as keyword arguments of
            ``sitcov.sim.carla.carla_backend_options``; they need ``backend="carla"``
            (``--map`` alone also goes with ``backend="esmini"``: its ``map`` option).
        esmini: ``--scenario`` (a .xosc file or a folder of them) and ``--road`` (an
            OpenDRIVE file) as the esmini backend's ``scenario`` and ``road`` options, made
            absolute; they need ``backend="esmini"``.
        av_cmd: ``--av-cmd``, an external-process stack (protocol in docs/protocol.md).
        av_step_timeout: ``--av-step-timeout`` [s] for an external stack.
        grey_box: ``--grey-box``: the stack is also given the situation at reset.
        **fields: flags that map one-to-one onto CampaignConfig fields.

    Raises:
        ConfigError: flags that do not go together.
    """
    overrides = dict(fields)
    backend_options: dict[str, Any] = {}
    av_params: dict[str, Any] = {}
    if perception:
        backend_options["perception"] = perception
    if carla and fields.get("backend") == "esmini" and set(carla) == {"map"}:
        backend_options["map"] = carla.pop("map")  # esmini: where situations are placed
    if carla:
        if fields.get("backend") != "carla":
            names = {"map": "--map", "servers": "--carla-servers"}
            flags = ", ".join(names.get(k, "--carla-" + k) for k in carla)
            raise ConfigError(f"{flags}: these flags need --backend carla")
        from sitcov.sim.carla import carla_backend_options

        backend_options.update(carla_backend_options(**carla))
    if esmini:
        if fields.get("backend") != "esmini":
            flags = ", ".join("--" + k for k in esmini)
            raise ConfigError(f"{flags}: these flags need --backend esmini")
        backend_options.update({k: str(Path(v).resolve()) for k, v in esmini.items()})
    if av_cmd:
        if fields.get("av"):
            raise ConfigError("--av and --av-cmd: give one stack, not both")
        overrides["av"] = "cmd:" + av_cmd
    external = str(overrides.get("av") or "").startswith("cmd:")
    if av_step_timeout is not None:
        if not external:
            raise ConfigError("--av-step-timeout applies to external stacks (--av-cmd) only")
        av_params["step_timeout"] = av_step_timeout
    if grey_box:
        backend_options["grey_box"] = True
        if external:
            av_params["grey_box"] = True
    overrides["backend_options"] = backend_options or None
    overrides["av_params"] = av_params or None
    return overrides
