"""The Workability page in a real headless browser (Debian's Chromium driven by Playwright, as
tests/web/viewer/test_browser.py): choose the shipped record and a planner, run, watch the progress
and see the summary and the PNG plots appear, loaded from the server."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from playwright.sync_api import Page, expect, sync_playwright

from tests.timing import scaled
from tests.web.support import free_port, wait_for
from tests.web.viewer.test_browser import ARGS, CHROMIUM
from twin.runs.executor import IN_PROCESS, Executor
from twin.sim.live import LiveSession
from twin.web.access import Access
from twin.web.api import create_app
from twin.web.store import RunStore

SHIPPED = "46097h2019_08.txt"

pytestmark = [
    pytest.mark.serial,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium"),
]


@pytest.fixture
def served(tmp_path: Path) -> Iterator[int]:
    """A REST app on an in-process executor, served by uvicorn on a free port (yielded)."""
    import uvicorn

    with RunStore(tmp_path / "runs.sqlite") as store, Executor.start(IN_PROCESS) as executor:
        port = free_port()
        app = create_app(LiveSession(), store, executor=executor,
                         access=Access.for_server("127.0.0.1", (port,)))  # fmt: skip
        server = uvicorn.Server(
            uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning")
        )
        thread = threading.Thread(target=server.run, daemon=True)
        thread.start()
        assert wait_for(lambda: server.started, timeout=20.0)
        try:
            yield port
        finally:
            server.should_exit = True
            thread.join(timeout=10)


def run_page(port: int, act: Callable[[Page], None]) -> None:
    """Open the landing page, follow its Workability link, and `act` on that page; no page
    error may be raised meanwhile."""
    errors: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=str(CHROMIUM), args=ARGS)
        try:
            page = browser.new_page()
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(f"http://127.0.0.1:{port}/", timeout=30_000)
            page.get_by_role("link", name="Workability").click()
            page.wait_for_url("**/workability", timeout=30_000)
            # the shipped record and the mechanism's default planner, from the API
            page.locator("#record option", has_text=SHIPPED).wait_for(
                state="attached", timeout=30_000
            )
            page.select_option("#record", SHIPPED)  # the month: the other records are a year
            # the planners arrive from the API after the page: wait for the default checked
            expect(page.locator("input[name=planner][value=mtmp]")).to_be_checked(timeout=30_000)
            page.fill("#seeds", "1")
            page.fill("#duration", "2")  # a tiny evaluation: 2 s runs, one seed
            act(page)
        finally:
            browser.close()
    assert errors == [], errors


def shown(page: Page, plot: str) -> None:
    """The plot's PNG was fetched and decoded: its image is visible and has a size."""
    assert page.locator(f"#plot-{plot}").is_visible(), plot
    page.wait_for_function(
        f"document.getElementById('plot-{plot}').naturalWidth > 0", timeout=30_000
    )


def test_the_workability_page_runs_the_shipped_record_and_shows_its_plots(served: int) -> None:
    """In a real browser the shipped record runs to "done" with its one planner's summary row,
    the monthly, window and strip PNGs decoded, a window table and no forecast part."""
    def act(page: Page) -> None:
        page.click("#run")
        page.locator("#results").wait_for(state="visible", timeout=scaled(240) * 1000)
        status = page.text_content("#status") or ""
        assert status.startswith("done"), status
        assert page.locator("#summary tr").count() == 1
        assert "mtmp" in (page.text_content("#summary") or "")
        for plot in ("monthly", "windows", "strip"):
            shown(page, plot)
        assert not page.locator("#forecast-part").is_visible()  # not a forecast
        assert page.locator("#windows tr").count() >= 1

    run_page(served, act)


def test_an_uploaded_forecast_shows_bars_per_step_and_a_table_of_limits(
    served: int, tmp_path: Path
) -> None:
    """An uploaded forecast shows its bar plot and one table row per 3 h step, with the
    uploaded Hs and each planner's limiting constraint."""
    hs = [0.5, 1.0, 2.5, 3.5, 3.5, 1.0]
    path = tmp_path / "forecast.csv"
    path.write_text("time,hs,tp,direction\n" + "".join(
        f"2026-01-01T{3 * i:02d}:00,{h},8.0,270\n" for i, h in enumerate(hs)
    ))  # fmt: skip

    def act(page: Page) -> None:
        page.set_input_files("#upload", str(path))
        page.select_option("#kind", "forecast")
        page.click("#run")
        page.locator("#results").wait_for(state="visible", timeout=scaled(240) * 1000)
        expect(page.locator("#forecast-part")).to_be_visible(timeout=30_000)
        shown(page, "forecast")
        rows = page.locator("#steps tr")
        assert rows.count() == len(hs)  # one row per 3 h step
        header = page.text_content("#steps-head") or ""
        assert "mtmp" in header and "limited by" in header
        first = rows.nth(0).locator("td").all_text_contents()
        assert first[1] == "0.500"  # Hs of the first step, as uploaded

    run_page(served, act)
