"""Console output of the campaign commands: progress bar, end-of-run summary, replay."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sitcov.campaign._open import open_store
from sitcov.campaign._replay import ReplayResult
from sitcov.campaign._runner import CampaignProgress, CampaignResult
from sitcov.campaign._store import Store, StoreError

MAX_REPLAY_LINES = 5


@contextmanager
def existing_store(path: Path) -> Iterator[Store]:
    """Open a store that must already exist (reading commands never create files)."""
    if not Path(path).exists():
        raise StoreError(f"{path}: no such campaign database")
    store = open_store(path)
    try:
        yield store
    finally:
        store.close()


@contextmanager
def created_store(path: Path) -> Iterator[Store]:
    """Open (or create) a store; a file this call created is removed again if an error
    leaves it without any campaign (no empty schema-only database is left behind)."""
    path = Path(path)
    created = not path.exists()
    store = open_store(path)
    try:
        yield store
    except BaseException:
        empty = created and not store.campaigns()
        store.close()
        if empty:
            for suffix in ("", "-wal", "-shm"):
                Path(f"{path}{suffix}").unlink(missing_ok=True)
        raise
    store.close()


class ProgressView:
    """A rich progress bar (runs/s, failures so far, ETA) fed by ``run_campaign``."""

    def __init__(self, console: Any) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeRemainingColumn,
        )

        self.console = console
        self._bar = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[rate]} runs/s"),
            TextColumn("[red]{task.fields[failures]} failed[/] {task.fields[errors]} errors"),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            console=console,
            transient=False,
        )
        self._task: Any = None
        self._t0 = 0.0

    def __enter__(self) -> ProgressView:
        return self

    def __exit__(self, *exc: object) -> None:
        self._bar.stop()

    def update(self, p: CampaignProgress) -> None:
        """The progress callback."""
        import time

        if p.event == "start":
            if p.no_effect:
                self.console.print(
                    "[yellow]note:[/] no effect in this backend: " + ", ".join(p.no_effect)
                )
            verb = "resuming" if p.resumed else "running"
            self.console.print(f"{verb} campaign {p.campaign!r}: {p.done}/{p.total} runs done")
            self._bar.start()
            self._task = self._bar.add_task(
                p.campaign, total=p.total, completed=p.done, rate="-", failures=0, errors=0
            )
            self._t0 = time.perf_counter()
            self._bar.update(self._task, failures=p.failures, errors=p.errors)
            return
        if p.executed <= 1:  # measure from the first result: worker start-up is not a rate
            self._t0 = time.perf_counter()
        elapsed = time.perf_counter() - self._t0
        rate = f"{(p.executed - 1) / elapsed:.1f}" if elapsed > 0 and p.executed > 1 else "-"
        self._bar.update(
            self._task, completed=p.done, rate=rate, failures=p.failures, errors=p.errors
        )


class StageBar:
    """A transient rich progress bar for the long commands that are not campaigns
    (``explain``, ``shrink``, ``experiment flakiness``, ``calibrate``): one task whose
    description is the current stage; a stage of unknown length shows a count.

    Used as a context manager; :meth:`stage` is the ``progress(stage, done, total)``
    callback of the library functions, :meth:`advance` counts units (runs) done.
    """

    def __init__(self, console: Any, title: str, *, disable: bool = False) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            SpinnerColumn,
            TextColumn,
            TimeElapsedColumn,
        )

        self._bar = Progress(
            SpinnerColumn(),
            TextColumn(f"[bold]{title}[/]" + " {task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            console=console,
            transient=True,
            disable=disable,
        )
        self._task = self._bar.add_task("", total=None)

    def __enter__(self) -> StageBar:
        self._bar.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._bar.stop()

    def stage(self, stage: str, done: int, total: int | None) -> None:
        """Show ``stage`` at ``done`` of ``total`` (None: unknown)."""
        self._bar.update(self._task, description=stage, completed=done, total=total)

    def advance(self, units: int = 1) -> None:
        """Count ``units`` more done (e.g. simulated runs)."""
        self._bar.advance(self._task, units)


def print_end_of_run(console: Any, store: Store, db: Path, result: CampaignResult) -> None:
    """The summary table and a paste-ready replay line for the first failing runs."""
    from sitcov.campaign._summary import summarize_store, summary_table

    console.print(
        f"campaign {result.name!r}: {result.executed} runs executed in {result.wall_time:.1f} s"
        + (f" ({result.replayed} replayed stored failures)" if result.replayed else "")
    )
    summary = summarize_store(store, result.name)
    console.print(summary_table(summary, title=f"campaign {result.name}"))
    shown = 0
    for run in store.iter_runs(result.name, "fail"):
        if shown == 0:
            console.print("reproduce a failure:")
        line = f"  sitcov replay --db {db} {run.campaign}:{run.index}"
        console.print(line, highlight=False, soft_wrap=True, markup=False)
        shown += 1
        if shown >= MAX_REPLAY_LINES:
            break
    if result.failures > shown:
        more = f"  ... and {result.failures - shown} more (sitcov export --db {db} --format csv)"
        console.print(more, highlight=False, soft_wrap=True, markup=False)


def print_all_errored(console: Any, store: Store, db: Path, result: CampaignResult) -> bool:
    """If every finished run of the campaign errored, print the first one's traceback.

    Returns True in that case (``sitcov run`` then exits non-zero): a campaign in which no
    run could execute tests nothing, typically because of a bug in a backend or stack.
    """
    if result.runs == 0 or result.errors < result.runs:
        return False
    first = next(iter(store.iter_runs(result.name, ("error", "timeout"))), None)
    message = first.outcome.message if first is not None and first.outcome else None
    where = f"{first.campaign}:{first.index}" if first is not None else "?"
    console.print(
        f"[bold red]error:[/] all {result.runs} runs of campaign {result.name!r} in {db} "
        f"ended in error or timeout; the first ({where}) said:",
        highlight=False,
        soft_wrap=True,
    )
    console.print(message or "(no message stored)", highlight=False, markup=False, soft_wrap=True)
    return True


def print_replay(console: Any, result: ReplayResult) -> bool:
    """Print a replay's verdict; returns False if a same-setup replay did not reproduce."""
    from rich.table import Table

    run = result.run
    head = f"run {run.campaign}:{run.index} seed {run.seed} situation {run.situation.id}"
    if result.render:
        console.print(f"top-down picture written to {result.render}")
    if result.same_setup:
        if result.reproduced:
            console.print(f"{head}: [green]reproduced[/] ({_verdict(result.outcome)})")
            return True
        console.print(f"{head}: [bold red]DID NOT REPRODUCE[/]")
        table = Table("field", "stored", "replay")
        for key, (a, b) in result.differences.items():
            table.add_row(key, repr(a), repr(b))
        console.print(table)
        return False
    stored = run.config.get("backend"), run.config.get("backend_options", {})
    table = Table(
        "field",
        f"stored ({stored[0]} {stored[1] or ''})",
        f"replay ({result.backend} {result.options or ''})",
        title=head,
    )
    a, b = run.outcome.to_dict() if run.outcome else {}, result.outcome.to_dict()
    for key in a:
        if key != "metrics":
            table.add_row(key, repr(a.get(key)), repr(b.get(key)))
    console.print(table)
    return True


def _verdict(outcome: Any) -> str:
    """``pass``, or ``fail: KIND`` for a failed run."""
    return f"fail: {outcome.kind}" if outcome.status == "fail" else outcome.status
