"""Building a campaign's parts (hyperspace, generator, backend, stack) from its config.

Workers call :func:`build_backend` and :func:`build_stack` once each, when they start.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sitcov._plugins import import_path, load
from sitcov.errors import ConfigError

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.campaign._config import CampaignConfig
    from sitcov.generation import Generator
    from sitcov.sim import Backend

#: The embedded backend's map when ``backend_options`` names none.
DEFAULT_EMBEDDED_MAP = "t-junction"


def resolve_hyperspace(spec: str | None) -> Any:
    """The hyperspace named by ``spec``: ``t-junction``, a YAML path, or ``module:attr``.

    A ``module:attr`` path (not an existing file) names a Hyperspace object or a
    zero-argument callable returning one (useful for tests and programmatic hyperspaces).
    """
    from pathlib import Path

    if spec and ":" in spec and not Path(spec).exists():
        obj = import_path(spec, kind="hyperspace")
        return obj() if callable(obj) and not hasattr(obj, "elements") else obj
    from sitcov.hyperspace import load_hyperspace

    return load_hyperspace(spec)


def with_hyperspace_map(config: CampaignConfig, hyperspace: Any) -> CampaignConfig:
    """``config`` with the embedded backend's ``map`` taken from ``hyperspace.metadata.map``.

    A derived hyperspace (``sitcov hyperspace derive``) names the map its routes belong to;
    running it on another map would fail on every run (or, worse, run other geometry). The
    map is written into ``backend_options`` so that the stored config says it and resume,
    replay and report rebuild the same backend. Other backends, and hyperspaces not derived
    (no ``metadata.derived_by``: the paper's names the T-junction it was written for, but it
    runs on the skewed cross too), leave the config unchanged.

    Raises:
        ConfigError: ``backend_options.map`` names another map than the hyperspace.
    """
    metadata = getattr(hyperspace, "metadata", None) or {}
    wanted = metadata.get("map")
    if "derived_by" not in metadata or not isinstance(wanted, str) or config.backend != "embedded":
        return config
    given = config.backend_options.get("map")
    if given is None:
        options = {**config.backend_options, "map": wanted}
        return config.model_copy(update={"backend_options": options})
    if map_file(given) != map_file(wanted):
        raise ConfigError(
            f"backend_options.map {given!r} contradicts metadata.map {wanted!r} of hyperspace "
            f"{config.hyperspace!r}; drop the map option or use a hyperspace derived on {given!r}"
        )
    return config


def map_file(ref: Any) -> str:
    """The embedded map file a ``map`` option names, resolved: a built-in name and any path
    to the same file give the same string (a reference that cannot be resolved: itself)."""
    from pathlib import Path

    from sitcov.sim.embedded._map import MAPS_DIR

    path = Path(str(ref))
    if not path.suffix:
        path = MAPS_DIR / f"{ref}.yaml"
    try:
        return str(path.resolve())
    except (OSError, RuntimeError):  # pragma: no cover - a symlink loop
        return str(ref)


def stored_map_as_given(stored: Mapping[str, Any], config: CampaignConfig, where: str) -> dict:
    """A stored campaign config with its embedded map spelled as ``config`` spells it.

    Resume compares stored and new configs field by field; the map must compare by the
    file it names: ``crossroads`` and a path to the shipped ``crossroads.yaml`` are one
    map, and a config stored without a map option (before a derived hyperspace's
    ``metadata.map`` was written into it) ran on the embedded default, ``t-junction``.

    Raises:
        ConfigError: the two configs name different maps (one line: both maps, the fix).
    """
    out = dict(stored)
    if config.backend != "embedded" or stored.get("backend", "embedded") != "embedded":
        return out
    options = dict(stored.get("backend_options") or {})
    how = "" if "map" in options else " (no map option: the default)"
    old = options.pop("map", DEFAULT_EMBEDDED_MAP)
    new = config.backend_options.get("map", DEFAULT_EMBEDDED_MAP)
    if map_file(old) != map_file(new):
        raise ConfigError(
            f"{where}: ran on map {str(old)!r}{how}, this config runs map {str(new)!r}; a "
            "campaign resumes on its own map: use another --name, or a hyperspace derived on "
            f"{str(old)!r}"
        )
    if "map" in config.backend_options:
        options["map"] = config.backend_options["map"]
    out["backend_options"] = options
    return out


def make_generator(config: CampaignConfig, hyperspace: Any) -> Generator:
    """A fresh generator as the config names it."""
    from sitcov.generation import make_generator as factory

    return factory(config.generator, hyperspace, **config.generator_options)


def restore_generator(config: CampaignConfig, hyperspace: Any, state: dict) -> Generator:
    """The generator rebuilt from its saved state."""
    from sitcov.generation import restore_generator as factory

    return factory(config.generator, hyperspace, state)


def build_backend(
    config: CampaignConfig,
    *,
    backend: str | None = None,
    options: dict | None = None,
    worker_index: int = 0,
) -> Backend:
    """The simulation backend of ``config`` (or ``backend`` with ``options`` instead).

    The config's ``physics`` profile is given as the backend's ``physics`` option when the
    backend has one; a backend without it runs ``carla`` only. A backend configured with a
    ``servers`` list (e.g. several CARLA servers) is told its
    ``worker_index`` so that worker k uses server k mod len(servers). A config with
    ``perception_draws`` > 1 gets its own backend wrapped in
    :class:`~sitcov.campaign._draws.PerceptionDraws` (another ``backend`` is not: a
    replay elsewhere runs the stored run once).
    """
    from sitcov.sim import Backend, make_backend

    name = backend or config.backend
    opts = dict(config.backend_options if options is None else options)
    if opts.get("servers"):
        opts["worker_index"] = worker_index
    cls = load("backend", name, Backend)
    if _accepts(cls, "physics"):
        opts["physics"] = config.physics
    elif config.physics != "carla":
        raise ConfigError(
            field="physics",
            value=config.physics,
            expected=f"'carla': backend {name!r} has no physics profiles (no 'physics' option)",
        )
    built = cls(**opts) if ":" in name else make_backend(name, **opts)
    if config.perception_draws > 1 and name == config.backend:
        from sitcov.campaign._draws import PerceptionDraws
        from sitcov.sim import Judge

        judge = Judge.from_spec(config.judge)
        try:
            return PerceptionDraws(built, config.perception_draws, lambda o: judge(o).failed)
        except ConfigError:
            built.close()
            raise
    return built


def _accepts(cls: type, option: str) -> bool:
    """Whether ``cls(option=...)`` is a named parameter of the backend's constructor."""
    try:
        return option in inspect.signature(cls).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False


def build_stack(config: CampaignConfig) -> AVStack:
    """The AV stack under test, with the config's fault and parameters."""
    from sitcov.av import make_stack

    return make_stack(config.av, fault=config.fault, params=config.av_params)


def check_backend_hyperspace(backend: Any, hyperspace: Any, spec: str | None = None) -> None:
    """Let a backend refuse a hyperspace it cannot play (its optional ``check_hyperspace``:
    the esmini backend's scenario parameters, the embedded and CARLA backends' routes and
    actor keys); an error that names no file names the hyperspace ``spec`` (file or
    built-in name) the values came from.

    Raises:
        ConfigError: the backend's one-line reason.
    """
    check = getattr(backend, "check_hyperspace", None)
    if not callable(check):
        return
    try:
        check(hyperspace)
    except ConfigError as exc:
        if exc.file is not None or exc.field is None:
            raise
        where = spec or "t-junction"
        file = where if Path(where).exists() else f"hyperspace {where!r}"
        raise ConfigError(
            file=file, field=exc.field, value=exc.value, expected=exc.expected
        ) from None


def check_parts(config: CampaignConfig) -> None:
    """Build every part ``config`` names once, then close it.

    ``sitcov run`` calls this before it creates the database file, so a bad hyperspace,
    generator, backend, stack or fault is one error and leaves no file behind.

    Raises:
        ConfigError: a part cannot be built (SetupError: a model or extra is missing).
    """
    hyperspace = resolve_hyperspace(config.hyperspace)
    config = with_hyperspace_map(config, hyperspace)
    make_generator(config, hyperspace)
    backend = build_backend(config)
    try:
        check_backend_hyperspace(backend, hyperspace, config.hyperspace)
    finally:
        backend.close()
    build_stack(config).close()


def warm_up(config: CampaignConfig) -> float:
    """Run one situation of ``config`` in this process and throw the outcome away, so that
    numba's kernels are compiled (first use after an install: 10-20 s) or loaded from its
    disk cache before a campaign starts: the caller can say so while it happens, and the
    worker processes then load the cached kernels instead of each compiling them.

    Only the embedded backend with PEM perception is warmed (other backends have no
    kernels to compile, camera mode would load the detector twice). Nothing is stored and
    no campaign state is touched. Returns the seconds it took (0.0 when skipped).
    """
    import time

    from sitcov._jit import enabled
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.generation import make_generator as _make

    if not enabled() or config.backend != "embedded":
        return 0.0
    if config.backend_options.get("perception", "pem") != "pem":
        return 0.0
    start = time.perf_counter()
    hyperspace = resolve_hyperspace(config.hyperspace)
    config = with_hyperspace_map(config, hyperspace)
    situation = _make("random", hyperspace).ask(ask_rng(config.seed, 0))
    backend, stack = build_backend(config), build_stack(config)
    try:
        backend.run(situation, stack, run_seed(config.seed, 0))
    except Exception:  # noqa: BLE001 - a run's own error is the campaign's to store
        pass
    finally:
        stack.close()
        backend.close()
    return time.perf_counter() - start
