"""CLI-facing options of the CARLA backend and the choice of server per worker.

``sitcov run`` turns its flags into backend options with :func:`carla_backend_options`;
the campaign executors add ``"worker_index": k`` for worker k, and :class:`CarlaBackend`
then connects to ``servers[k % len(servers)]`` (one server per worker process or Ray
worker). :func:`backend_for_worker` does the same choice explicitly.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from sitcov.errors import ConfigError

DEFAULT_PORT = 2000


def parse_servers(servers: str | Sequence[Any]) -> list[tuple[str, int]]:
    """``"h1:2000,h2:2002"`` or ``["h1:2000", ("h2", 2002)]`` -> ``[(host, port), ...]``.

    A server without a port uses 2000.

    Raises:
        ConfigError: an entry is not ``host[:port]`` with a port in 1..65535.
    """
    items = servers.split(",") if isinstance(servers, str) else list(servers)
    out: list[tuple[str, int]] = []
    for item in items:
        if isinstance(item, (tuple, list)) and len(item) == 2:
            host, port = str(item[0]), item[1]
        else:
            text = str(item).strip()
            if not text:
                continue
            host, sep, port_text = text.rpartition(":")
            if not sep:
                host, port_text = text, str(DEFAULT_PORT)
            port = port_text
        try:
            port_number = int(port)
        except (TypeError, ValueError):
            port_number = -1
        if not host or not 0 < port_number < 65536:
            raise ConfigError(
                field="carla_servers", value=str(item), expected="host:port with port 1..65535"
            )
        out.append((host, port_number))
    if not out:
        raise ConfigError(field="carla_servers", value=str(servers), expected="host:port,...")
    return out


def carla_backend_options(
    host: str = "localhost",
    port: int = 2000,
    timeout: float = 10.0,
    map: str = "Town03",  # noqa: A002 - the CLI's name
    servers: str | Sequence[Any] | None = None,
    launch: str | None = None,
) -> dict[str, Any]:
    """Backend options for ``make_backend("carla", **options)`` from the CLI flags.

    Args:
        host, port: ``--carla-host``, ``--carla-port``.
        timeout: ``--carla-timeout`` [s].
        map: ``--map`` (a shipped map name such as ``Town03`` or a map YAML path).
        servers: ``--carla-servers host:port,...`` (overrides host/port per worker).
        launch: ``--carla-launch CMD``: the shell command that (re)starts a server that
            does not answer (``{host}``/``{port}`` are each worker's server).

    Raises:
        ConfigError: a bad port, time-out, server list or map.
    """
    from sitcov.sim.carla._mapfile import load_carla_map

    if not 0 < int(port) < 65536:
        raise ConfigError(field="carla_port", value=port, expected="1..65535")
    if not float(timeout) > 0:
        raise ConfigError(field="carla_timeout", value=timeout, expected="seconds > 0")
    load_carla_map(map)  # fail early, before any worker starts
    options: dict[str, Any] = {
        "host": str(host),
        "port": int(port),
        "timeout": float(timeout),
        "map": str(map),
    }
    if servers:
        options["servers"] = [f"{h}:{p}" for h, p in parse_servers(servers)]
    if launch is not None:
        if not str(launch).strip():
            raise ConfigError(field="carla_launch", value=launch, expected="a shell command")
        options["launch"] = str(launch)
    return options


def backend_for_worker(options: Mapping[str, Any], worker_index: int) -> dict[str, Any]:
    """The options worker ``worker_index`` uses: its own server from ``servers``.

    ``servers[worker_index % len(servers)]`` becomes host/port and ``servers`` is dropped;
    without ``servers`` the options are returned unchanged (a copy).
    """
    out = dict(options)
    servers = out.pop("servers", None)
    out.pop("worker_index", None)
    if servers:
        parsed = parse_servers(servers)
        out["host"], out["port"] = parsed[int(worker_index) % len(parsed)]
    return out
