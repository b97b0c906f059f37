"""The viewer page in a real headless browser (Debian's chromium driven by Playwright): filter, choose a video,
play it, open a question's trace, highlight its events in the causal graph, show a counterfactual run.

The screenshot goes to the test's temporary folder; with ``CRAFT_DSL_SCREENSHOTS=1`` it also replaces
``docs/images/viewer.png``.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.viewer import Viewer

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]
DOCS_SCREENSHOT = Path(__file__).resolve().parent.parent / "docs" / "images" / "viewer.png"


@pytest.fixture(scope="module")
def page(users_dataset: Path) -> Iterator[tuple[Any, Viewer]]:
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="the browser test needs Playwright: pip install 'craft-dsl[integration]'")
    if not Path(CHROMIUM).is_file():
        pytest.skip(f"the browser test needs Debian's chromium at {CHROMIUM} (apt-get install chromium)")
    viewer = Viewer(str(users_dataset)).start()
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            tab = browser.new_page(viewport={"width": 1500, "height": 1000})
            errors: list[str] = []
            tab.on("pageerror", lambda err: errors.append(str(err)))
            tab.goto(viewer.url)
            yield tab, viewer
            assert errors == []
        finally:
            browser.close()
            viewer.stop()


def test_click_through_the_viewer(page: tuple[Any, Viewer], tmp_path: Path) -> None:
    tab, viewer = page
    tab.wait_for_selector("#videos li")
    assert tab.locator("#videos li").count() == 6
    assert "6 videos" in tab.inner_text("#dataset-counts")

    # filters: scene 8 keeps its two videos; a category narrows the questions shown
    tab.select_option("#f-scene", "8")
    tab.wait_for_function("document.querySelectorAll('#videos li').length === 2")
    assert tab.locator("#videos li").all_inner_texts()[0].startswith("000002 · scene 8")
    tab.click("#videos li[data-video='2']")
    tab.wait_for_selector("#questions li")
    assert "Video 000002 (scene 8)" in tab.inner_text("#video-title")
    total = tab.locator("#questions li").count()
    tab.select_option("#f-category", "CF/O")
    tab.wait_for_function("document.querySelectorAll('#videos li').length >= 1")
    tab.wait_for_function("document.querySelectorAll('#questions li.dim').length > 0")
    shown = tab.locator("#questions li:not(.dim)")
    assert 0 < shown.count() < total and all("CF/O" in t for t in shown.all_inner_texts())

    # the factual video plays (the .mpg transcoded to H.264 by the server)
    tab.wait_for_function("document.getElementById('factual').readyState >= 2", timeout=30000)
    assert tab.evaluate("document.getElementById('factual').duration") == pytest.approx(200 / 60, abs=0.05)

    # a question's program with every node's value; the answer recomputed equals the recorded one
    tab.click("#questions li:not(.dim) >> nth=0")
    tab.wait_for_selector("#trace tbody tr")
    answer_line = tab.inner_text("#trace-answer")
    recomputed, recorded = (part.split(": ")[1] for part in answer_line.split(" · "))
    assert recomputed.lower() == recorded.lower()
    assert tab.inner_text("#program").startswith(("Exist(", "AnyTrue(", "AnyFalse("))
    rows = tab.locator("#trace tbody tr").count()
    assert rows >= 5

    # the causal graph: one node per event; clicking a trace row of events highlights them
    trace = viewer.data.trace(2, int(tab.get_attribute("#questions li.active", "data-question")))
    nodes = tab.locator("#graph g.node").count()
    assert nodes == len(viewer.data.simulation(2).events)
    assert tab.locator("#graph path.edge").count() == viewer.data.simulation(2).causal_graph.number_of_edges()
    row = next(r for r in trace["trace"] if r["events"])
    tab.click(f"#trace tr[data-node='{row['index']}']")
    highlighted = tab.locator("#graph g.node.highlight")
    assert sorted(int(h) for h in highlighted.evaluate_all("els => els.map(e => e.dataset.event)")) == sorted(
        row["events"])

    # the counterfactual run without the first dynamic object, beside the factual one
    tab.select_option("#cf-object", index=0)
    tab.click("#cf-run")
    tab.wait_for_function("document.getElementById('counterfactual').readyState >= 2", timeout=60000)
    assert not tab.is_hidden("#counterfactual") and not tab.is_hidden("#cf-graph")
    assert "events kept" in tab.inner_text("#cf-events")
    assert tab.locator("#cf-graph g.node").count() < nodes  # the removed object's events are gone
    tab.wait_for_timeout(500)
    shot = tmp_path / "viewer.png"
    tab.screenshot(path=str(shot), full_page=True)
    assert shot.read_bytes()[:4] == b"\x89PNG"
    if os.environ.get("CRAFT_DSL_SCREENSHOTS") == "1":
        shutil.copyfile(shot, DOCS_SCREENSHOT)

    # clearing the filters brings every video back
    tab.select_option("#f-scene", "")
    tab.select_option("#f-category", "")
    tab.wait_for_function("document.querySelectorAll('#videos li').length === 6")
