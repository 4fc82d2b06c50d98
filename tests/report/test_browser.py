"""The report in a real browser: headless Chromium loads it offline, logs no console errors,
and the screenshot shows a rendered page (not a blank one)."""

from __future__ import annotations

import subprocess

import pytest
from needs import need_program
from report_fakes import add_campaign

from sitcov.report import build_report

pytestmark = pytest.mark.browser

#: Flags for a quiet, offline, sandbox-free headless run (CI containers run as root).
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-logging=stderr",
    "--v=0",
]


def test_report_renders_in_headless_chromium(make_db, tmp_path):
    chromium = need_program("chromium", "chromium-browser")  # CI installs Debian's
    from PIL import Image, ImageStat

    def build(store):
        add_campaign(store, "rand", 120, seed=1, generator="random")
        add_campaign(store, "<b>cov</b>", 120, seed=2, generator="sitcov")

    db = make_db("b.db", build)
    index = build_report(db, tmp_path / "out", pictures=0)
    shot = tmp_path / "shot.png"
    proc = subprocess.run(
        [
            chromium,
            *FLAGS,
            f"--user-data-dir={tmp_path / 'profile'}",
            f"--screenshot={shot}",
            "--window-size=1280,2000",
            index.resolve().as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    log = proc.stderr
    assert proc.returncode == 0, log[-2000:]
    # the page has no scripts, so ANY console message (Chromium logs them as
    # "INFO:CONSOLE..." / "ERROR:CONSOLE...", uncaught exceptions as "Uncaught ...") is a bug
    console = [line for line in log.splitlines() if ":CONSOLE" in line or "Uncaught" in line]
    assert not console, console

    image = Image.open(shot).convert("L")
    assert image.size == (1280, 2000)
    stat = ImageStat.Stat(image)
    assert stat.stddev[0] > 20.0, "screenshot is (nearly) blank"
    # the dark page header is drawn at the top, the light page body below it
    top = ImageStat.Stat(image.crop((0, 0, 1280, 60))).mean[0]
    body = ImageStat.Stat(image.crop((0, 200, 1280, 400))).mean[0]
    assert top < 80 < body
