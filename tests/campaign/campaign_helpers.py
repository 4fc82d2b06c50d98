"""Helpers shared by the campaign tests (configs on the fakes, row dumps, child env)."""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path
from typing import Any

from campaign_fakes import BACKEND, GENERATOR, STACK

from sitcov.campaign import CampaignConfig

HERE = Path(__file__).resolve().parent


def fake_config(**changes: Any) -> CampaignConfig:
    """A campaign on the fakes: learning generator, fake backend and stack, small batches."""
    base: dict[str, Any] = {
        "generator": GENERATOR,
        "backend": BACKEND,
        "av": STACK,
        "runs": 40,
        "seed": 3,
        "batch_size": 8,
        "executor": "serial",
        "workers": 1,
    }
    base.update(changes)
    return CampaignConfig(**base)


def db_rows(path: Path | str, campaign: str | None = None) -> list[tuple]:
    """Every stored run column except wall_time, ordered (for row-by-row comparison)."""
    with sqlite3.connect(str(path)) as db:
        cols = [r[1] for r in db.execute("PRAGMA table_info(runs)") if r[1] != "wall_time"]
        where = " WHERE campaign = ?" if campaign else ""
        args = (campaign,) if campaign else ()
        sql = f"SELECT {', '.join(cols)} FROM runs{where} ORDER BY campaign, idx"
        return db.execute(sql, args).fetchall()


def subprocess_env() -> dict[str, str]:
    """Environment for child processes that must import the fakes."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE), env.get("PYTHONPATH")) if p)
    return env
