"""CLI-facing options and the per-worker choice of server."""

from __future__ import annotations

import pytest

from sitcov.errors import ConfigError
from sitcov.sim.carla import backend_for_worker, carla_backend_options, parse_servers


def test_parse_servers() -> None:
    assert parse_servers("a:2000, b:2002,c") == [("a", 2000), ("b", 2002), ("c", 2000)]
    assert parse_servers(["h:1", ("g", 3)]) == [("h", 1), ("g", 3)]
    for bad in ("a:0", "a:x", ":2000", ","):
        with pytest.raises(ConfigError, match="carla_servers"):
            parse_servers(bad)


def test_options_from_flags() -> None:
    opts = carla_backend_options("gpu1", 2010, 5.0, "Town03", "gpu1:2000,gpu2:2000")
    assert opts == {
        "host": "gpu1",
        "port": 2010,
        "timeout": 5.0,
        "map": "Town03",
        "servers": ["gpu1:2000", "gpu2:2000"],
    }
    assert "servers" not in carla_backend_options()
    with pytest.raises(ConfigError, match="carla_port"):
        carla_backend_options(port=70000)
    with pytest.raises(ConfigError, match="carla_timeout"):
        carla_backend_options(timeout=0)
    with pytest.raises(ConfigError, match="map"):
        carla_backend_options(map="Atlantis")


def test_each_worker_gets_servers_round_robin() -> None:
    opts = carla_backend_options(servers="a:1,b:2,c:3")
    chosen = [backend_for_worker(opts, k) for k in range(5)]
    assert [(o["host"], o["port"]) for o in chosen] == [
        ("a", 1),
        ("b", 2),
        ("c", 3),
        ("a", 1),
        ("b", 2),
    ]
    assert all("servers" not in o for o in chosen)
    plain = carla_backend_options(host="x", port=9)
    assert backend_for_worker(plain, 4) == plain
