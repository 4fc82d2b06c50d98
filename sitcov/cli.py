"""The ``sitcov`` command: parses arguments and calls the library; no logic of its own."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from sitcov.errors import SitcovError

app = typer.Typer(
    name="sitcov",
    help="Situation-coverage testing of autonomous-driving stacks at intersections.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
hyperspace_app = typer.Typer(help="Inspect situation hyperspaces.", no_args_is_help=True)
experiment_app = typer.Typer(help="Run predefined experiments.", no_args_is_help=True)
models_app = typer.Typer(help="Manage detector models.", no_args_is_help=True)
app.add_typer(hyperspace_app, name="hyperspace")
app.add_typer(experiment_app, name="experiment")
app.add_typer(models_app, name="models")

console = Console()
err_console = Console(stderr=True)

HYPERSPACE_OPT = typer.Option(
    None, "--hyperspace", help="Hyperspace YAML file (default: the built-in t-junction)."
)


# --- hyperspace & generation (owner: foundation) -------------------------------------------


# --- campaigns, summary, exports, replay (owner: campaign) ----------------------------------


# --- report (owner: report) -----------------------------------------------------------------


# --- embedded backend bench (owner: embedded world) ----------------------------------------


# --- camera perception: models fetch, render, calibrate (owner: camera) --------------------


# --- CARLA and OpenSCENARIO (owner: carla) ------------------------------------------------


def main(argv: Optional[list[str]] = None) -> None:  # noqa: UP045
    """Entry point: run the app, turning SitcovError into one clear line and exit code 2."""
    try:
        app(args=argv, standalone_mode=False)
    except SitcovError as exc:
        err_console.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
        sys.exit(2)
    except typer.Abort:
        err_console.print("aborted")
        sys.exit(130)
    except Exception as exc:  # click usage errors
        import click

        if isinstance(exc, click.exceptions.Exit):
            sys.exit(exc.exit_code)
        if isinstance(exc, click.ClickException):
            exc.show()
            sys.exit(exc.exit_code)
        raise


_ = (Path,)  # used by the commands below
