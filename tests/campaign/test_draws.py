"""Perception draws (sitcov.campaign._draws): the majority of several perception draws of
one world, stored as one real run; through campaigns, replay, summary and the CLI."""

from __future__ import annotations

from pathlib import Path

import pytest
from campaign_fakes import DRAWS_BACKEND, DrawsBackend, FakeBackend, FakeStack, draw_fails
from campaign_helpers import fake_config
from cli_helpers import run_cli as sitcov

from sitcov._seeding import ask_rng, draw_seed
from sitcov.campaign import load_config, open_store, run_campaign
from sitcov.campaign._build import build_backend
from sitcov.campaign._draws import PerceptionDraws, check_draws
from sitcov.campaign._replay import replay_run
from sitcov.campaign._summary import summarize_store, summary_table
from sitcov.errors import ConfigError
from sitcov.generation import make_generator
from sitcov.hyperspace import load_hyperspace


def _situation(i: int = 0):
    return make_generator("random", load_hyperspace()).ask(ask_rng(5, i))


@pytest.mark.parametrize("seed", [11, 12, 13, 14, 15, 16, 17, 18])
def test_the_stored_draw_is_the_first_of_the_majority(seed: int) -> None:
    wrapped = PerceptionDraws(DrawsBackend(), 5, lambda o: o.failed)
    outcome = wrapped.run(_situation(), FakeStack(), seed)
    senses = [None] + [draw_seed(seed, j) for j in range(1, 5)]
    verdicts = [draw_fails(seed, s) for s in senses]
    majority = sum(verdicts) >= 3
    assert outcome.failed is majority
    assert outcome.metrics["perception_draws"] == 5
    assert outcome.metrics["draws_failed"] == sum(verdicts)
    assert outcome.metrics["draw"] == verdicts.index(majority)
    # the stored outcome is that draw's own run (its perception seed), not a blend
    assert outcome.metrics["sense"] == senses[verdicts.index(majority)]


def test_draws_split_the_worlds_and_flip_single_verdicts() -> None:
    """Over many worlds some draws disagree, and the majority differs from draw 0 in some:
    the wrapper does change verdicts (else it would be pointless), always towards the
    majority of the world's own draws."""
    wrapped = PerceptionDraws(DrawsBackend(), 7, lambda o: o.failed)
    flips = splits = 0
    for seed in range(200):
        outcome = wrapped.run(_situation(), FakeStack(), seed)
        k = outcome.metrics["draws_failed"]
        splits += 0 < k < 7
        flips += outcome.failed != draw_fails(seed, None)
        assert outcome.failed is (k >= 4)
    assert splits > 50 and flips > 5


def test_recording_reruns_only_the_stored_draw_with_its_trace() -> None:
    DrawsBackend.calls.clear()
    wrapped = PerceptionDraws(DrawsBackend(), 3, lambda o: o.failed)
    plain = wrapped.run(_situation(), FakeStack(), 21)
    recorded = wrapped.run(_situation(), FakeStack(), 21, record=True)
    assert recorded.trace is not None and plain.trace is None
    assert recorded.status == plain.status and recorded.metrics == plain.metrics
    assert [c[2] for c in DrawsBackend.calls] == [False] * 6 + [True]


def test_a_perception_seed_moves_every_draw() -> None:
    """The agreement experiment's world-A/perception-B runs: draw 0 takes the given
    perception seed and the others derive from it."""
    DrawsBackend.calls.clear()
    PerceptionDraws(DrawsBackend(), 3, lambda o: o.failed).run(
        _situation(), FakeStack(), 21, perception_seed=99
    )
    assert [c[1] for c in DrawsBackend.calls] == [99, draw_seed(99, 1), draw_seed(99, 2)]


@pytest.mark.parametrize("draws", [0, 2, 4, -1, True, 1.5, "3"])
def test_a_bad_number_of_draws_is_refused(draws) -> None:
    with pytest.raises(ConfigError) as err:
        check_draws(draws)
    assert err.value.field == "perception_draws"


def test_a_backend_without_perception_seed_is_refused() -> None:
    with pytest.raises(ConfigError) as err:
        PerceptionDraws(FakeBackend(), 3, lambda o: o.failed)
    assert "perception_seed" in str(err.value) and err.value.field == "perception_draws"
    assert check_draws(1, FakeBackend()) == 1  # one draw needs nothing of the backend


def test_the_embedded_backends_draw_zero_is_the_plain_run() -> None:
    from sitcov.av import make_stack
    from sitcov.sim.embedded import EmbeddedBackend

    backend, stack = EmbeddedBackend(), make_stack("reference")
    situation = _situation(3)
    plain = backend.run(situation, stack, 7)
    wrapped = PerceptionDraws(backend, 1, lambda o: o.failed).run(situation, stack, 7)
    extra = {"perception_draws", "draws_failed", "draw"}
    assert {k: v for k, v in wrapped.metrics.items() if k not in extra} == plain.metrics
    assert (wrapped.status, wrapped.sim_time, wrapped.aeb_time) == (
        plain.status,
        plain.sim_time,
        plain.aeb_time,
    )


def test_a_campaign_stores_majority_verdicts_and_replays_them(tmp_path: Path) -> None:
    db = tmp_path / "d.db"
    store = open_store(db)
    cfg = fake_config(backend=DRAWS_BACKEND, generator="random", perception_draws=3, runs=24)
    run_campaign(cfg, store)
    runs = store.runs("default")
    assert len(runs) == 24
    for run in runs:
        k = run.outcome.metrics["draws_failed"]
        assert run.outcome.metrics["perception_draws"] == 3
        assert run.failed is (k >= 2)
    summary = summarize_store(store)
    assert summary["perception_draws"] == 3
    shares = [r.outcome.metrics["draws_failed"] / 3 for r in runs]
    assert summary["draws"]["runs"] == 24
    assert summary["draws"]["failing_draw_share"] == pytest.approx(sum(shares) / 24)
    assert summary["draws"]["split_runs"] == sum(0 < s < 1 for s in shares)
    memory = open_store(None)
    run_campaign(cfg, memory)
    assert summarize_store(memory)["draws"] == summary["draws"]  # SQL and Python agree
    text = _table_text(summary)
    assert "3 per run, majority verdict" in text
    result = replay_run(store, "default", runs[5].index)
    assert not result.differences
    store.close()


def test_one_draw_stores_no_draw_facts() -> None:
    store = open_store(None)
    run_campaign(fake_config(backend=DRAWS_BACKEND, generator="random", runs=8), store)
    summary = summarize_store(store)
    assert summary["perception_draws"] == 1 and summary["draws"] is None
    assert "perception draws" not in _table_text(summary)
    assert all("draws_failed" not in r.outcome.metrics for r in store.runs())


def test_resuming_with_other_draws_is_refused() -> None:
    store = open_store(None)
    run_campaign(fake_config(backend=DRAWS_BACKEND, runs=8), store)
    with pytest.raises(ConfigError, match="perception_draws"):
        run_campaign(fake_config(backend=DRAWS_BACKEND, runs=16, perception_draws=3), store)


def test_build_backend_wraps_only_the_campaigns_own_backend() -> None:
    cfg = fake_config(backend=DRAWS_BACKEND, perception_draws=3)
    assert isinstance(build_backend(cfg), PerceptionDraws)
    other = build_backend(cfg, backend="campaign_fakes:FakeBackend")
    assert not isinstance(other, PerceptionDraws)
    with pytest.raises(ConfigError, match="perception_draws"):
        build_backend(fake_config(perception_draws=3))  # FakeBackend: no perception seed


def test_an_even_number_of_draws_in_a_config_file_names_the_field(tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text("perception_draws: 4\n")
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert "perception_draws" in str(err.value) and "odd" in str(err.value)


def test_the_cli_refuses_even_draws_before_creating_the_database(tmp_path: Path, capsys) -> None:
    db = tmp_path / "x.db"
    code, out, err = sitcov(
        capsys, "run", "--db", str(db), "--runs", "4", "--perception-draws", "2"
    )
    assert code == 2
    assert "perception_draws" in err and "odd" in err
    assert "Traceback" not in out + err and not db.exists()


def _table_text(summary: dict) -> str:
    from rich.console import Console

    console = Console(width=200, record=True)
    console.print(summary_table(summary))
    return console.export_text()
