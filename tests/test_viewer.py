"""The dataset viewer's data (filters, traces, graphs, counterfactuals, media) and its HTTP server."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from craft_dsl.program import Program, format_value
from craft_dsl.viewer import Viewer, ViewerData, ViewerError
from tests.foreground import popen_foreground


@pytest.fixture(scope="module")
def data(users_dataset: Path) -> ViewerData:
    return ViewerData(users_dataset)


def test_summary_and_filters(data: ViewerData, users_dataset: Path) -> None:
    minimal = json.loads((users_dataset / "dataset_minimal.json").read_text())
    summary = data.summary()
    assert summary["questions"] == len(minimal) and summary["videos"] == len({r["video_index"] for r in minimal})
    assert summary["filters"]["scene"] == ["1", "8", "11"] and summary["resimulation"] is True
    assert data.videos({}) == [{"video_index": v, "scene": int(s), "matched": n, "questions": n}
                               for v, s, n in sorted({(r["video_index"], r["simulation_id"],
                                                       sum(1 for m in minimal if m["video_index"] == r["video_index"]))
                                                      for r in minimal})]
    only8 = data.videos({"scene": "8"})
    assert [v["video_index"] for v in only8] == [2, 3]
    answer = summary["filters"]["answer"][0]
    template = next(r["template_id"] for r in minimal if r["answer"] == answer)
    hits = data.videos({"answer": answer, "template": template})
    expected = [r for r in minimal if r["answer"] == answer and r["template_id"] == template]
    assert sum(v["matched"] for v in hits) == len(expected)
    assert data.videos({"scene": "8", "category": "no such"}) == []
    assert data.videos({"unknown": "x"}) == data.videos({})


def test_video_questions_and_graph(data: ViewerData) -> None:
    view = data.video(2, {"category": "D/2Q"})
    sim = data.simulation(2)
    assert view["scene"] == 8 and view["video_file_path"] == "./videos/sid_8/000002.mpg" and view["has_video_file"]
    assert {q["category"] for q in view["questions"] if q["matches"]} == {"D/2Q"}
    assert any(not q["matches"] for q in view["questions"])
    graph = view["graph"]
    assert {n["id"] for n in graph["nodes"]} == {e.id for e in sim.events}
    assert sorted(map(tuple, graph["edges"])) == sorted(sim.causal_graph.edges)
    start = next(n for n in graph["nodes"] if n["type"] == "Start")
    assert start["x"] == 0 and all(n["x"] >= start["x"] for n in graph["nodes"])
    collision = next(n for n in graph["nodes"] if n["type"] == "Collision")
    assert collision["label"] == "C" and "Collision at step" in collision["title"]
    assert [lane["y"] for lane in graph["lanes"]] == list(range(1, len(sim.dynamic_ids) + 1))
    assert view["counterfactual"] == {"objects": sorted(sim.dynamic_ids), "video": True, "reason": None}
    with pytest.raises(ViewerError, match="no video 99"):
        data.video(99)


def test_trace_is_the_programs_trace(data: ViewerData, users_dataset: Path) -> None:
    full = json.loads((users_dataset / "dataset.json").read_text())
    video = next(v for v in full if v["questions"]["info"]["video_index"] == 4)
    for q in video["questions"]["questions"][:12]:
        trace = data.trace(4, q["question_index"])
        program = Program.from_nodes(q["program"])
        entries = program.trace(data.simulation(4))
        assert trace["program"] == str(program)
        assert [(t["expression"], t["value"]) for t in trace["trace"]] == [
            (e.expression, format_value(e.value)) for e in entries]
        assert trace["answer"].lower() == str(q["answer"]).lower()
    counterfactual = next(q for q in video["questions"]["questions"] if q["template_id"].startswith("counterfactual"))
    trace = data.trace(4, counterfactual["question_index"])
    sim = data.simulation(4)
    factual = {(e.id, e.type, e.step, e.objects) for e in sim.events}
    entries = Program.from_nodes(counterfactual["program"]).trace(sim)
    for row, entry in zip(trace["trace"], entries, strict=True):
        if row["expression"].startswith("GetCounterfactEvents"):
            # only the counterfactual events identical to factual ones are nodes of the drawn (factual) graph
            assert row["events"] == [e.id for e in entry.value if (e.id, e.type, e.step, e.objects) in factual]
            assert len(row["events"]) < len(entry.value) or entry.value == sim.events
    factual_rows = [t for t in trace["trace"] if t["expression"] == "Events()"]
    for row in factual_rows:
        assert row["events"] == [e.id for e in data.simulation(4).events]
    with pytest.raises(ViewerError, match="no question 999"):
        data.trace(4, 999)


def test_counterfactual_events_and_videos(data: ViewerData) -> None:
    sim = data.simulation(2)
    obj = min(sim.dynamic_ids)
    result = data.counterfactual(2, obj)
    cf = sim.counterfactual(obj)
    assert result["object"]["id"] == obj and result["video"] is True
    gone = [e for e in sim.events if e.type not in ("Start", "End") and obj in e.objects]
    assert len(result["removed_events"]) >= len(gone)  # every event of the removed object is gone
    assert result["kept_events"] + len(result["removed_events"]) == sum(
        1 for e in sim.events if e.type not in ("Start", "End"))
    assert {n["id"] for n in result["graph"]["nodes"]} == {e.id for e in cf.events}
    live = data.live(2)
    assert sorted((e.type, e.step) for e in live.counterfactual(obj).events) == sorted(
        (e.type, e.step) for e in cf.events)  # the live re-simulation reproduces the recorded counterfactual
    video = data.counterfactual_mp4(2, obj)
    assert video[4:8] == b"ftyp" and video != data.video_mp4(2)
    assert data.video_mp4(2)[4:8] == b"ftyp"  # the .mpg transcoded for browsers
    assert data.frame_png(2, "first")[:4] == b"\x89PNG"
    with pytest.raises(ViewerError, match="not a dynamic object"):
        data.counterfactual(2, sim.ground_id)


def test_without_seeds_or_videos(users_dataset: Path, tmp_path: Path) -> None:
    folder = tmp_path / "published-like"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "intermediates"))
    (folder / "generation_config.json").unlink()
    data = ViewerData(folder)
    view = data.video(0)
    assert view["counterfactual"]["video"] is False and "records no simulation seeds" in view["counterfactual"][
        "reason"]
    result = data.counterfactual(0, min(data.simulation(0).dynamic_ids))
    assert result["video"] is False and result["removed_events"]  # recorded events still shown
    with pytest.raises(ViewerError, match="no such video .*records no simulation seeds"):
        data.video_mp4(0)
    with pytest.raises(ViewerError, match="cannot re-simulate video 0"):
        data.counterfactual_mp4(0, min(data.simulation(0).dynamic_ids))
    # with its seeds but without video files, the video is rendered from a re-simulation
    folder2 = tmp_path / "no-videos"
    shutil.copytree(users_dataset, folder2, ignore=shutil.ignore_patterns("videos"))
    assert ViewerData(folder2).video_mp4(5)[4:8] == b"ftyp"


def test_resimulation_mismatch_is_reported(users_dataset: Path, tmp_path: Path) -> None:
    folder = tmp_path / "edited"
    shutil.copytree(users_dataset, folder, ignore=shutil.ignore_patterns("videos", "*_frames"))
    qa_path = folder / "questions" / "qa_000001.json"
    qa = json.loads(qa_path.read_text())
    qa["stats"]["simulation_seed"] += 1  # no longer the seed of the recorded run
    qa_path.write_text(json.dumps(qa))
    with pytest.raises(ViewerError, match="re-simulation's events differ from the recorded ones"):
        ViewerData(folder).live(1)


# -- HTTP -----------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def server(users_dataset: Path) -> Iterator[Viewer]:
    viewer = Viewer(str(users_dataset)).start()
    yield viewer
    viewer.stop()


def get(viewer: Viewer, path: str, headers: dict[str, str] | None = None) -> tuple[int, dict[str, str], bytes]:
    request = urllib.request.Request(viewer.url.rstrip("/") + path, headers=headers or {})
    try:
        with urllib.request.urlopen(request, timeout=30) as response:
            return response.status, dict(response.headers), response.read()
    except urllib.error.HTTPError as err:
        return err.code, dict(err.headers), err.read()


def get_json(viewer: Viewer, path: str) -> tuple[int, Any]:
    status, _, body = get(viewer, path)
    return status, json.loads(body)


def test_http_api(server: Viewer, data: ViewerData) -> None:
    status, headers, page = get(server, "/")
    assert status == 200 and headers["Content-Type"].startswith("text/html") and b'id="graph"' in page
    assert get(server, "/static/app.js")[0] == 200 and get(server, "/static/style.css")[0] == 200
    assert get_json(server, "/api/summary") == (200, data.summary())
    assert get_json(server, "/api/videos?scene=8&answer=") == (200, data.videos({"scene": "8"}))
    status, video = get_json(server, "/api/video/3")
    assert status == 200 and video["video_index"] == 3
    qi = video["questions"][0]["question_index"]
    assert get_json(server, f"/api/trace/3/{qi}") == (200, data.trace(3, qi))
    obj = video["counterfactual"]["objects"][0]
    status, cf = get_json(server, f"/api/counterfactual/3/{obj}")
    assert status == 200 and cf["object"]["id"] == obj
    for path in ("/api/video/77", "/api/trace/3/999", "/media/frame/3/middle.png", "/nothing", "/static/../x"):
        status, body = get_json(server, path)
        assert status == 404 and body["error"], path


def test_http_media_and_ranges(server: Viewer, data: ViewerData) -> None:
    status, headers, body = get(server, "/media/video/3.mp4")
    assert status == 200 and headers["Content-Type"] == "video/mp4" and body == data.video_mp4(3)
    assert headers["Accept-Ranges"] == "bytes"
    status, headers, part = get(server, "/media/video/3.mp4", {"Range": "bytes=10-19"})
    assert status == 206 and part == body[10:20] and headers["Content-Range"] == f"bytes 10-19/{len(body)}"
    status, _, tail = get(server, "/media/video/3.mp4", {"Range": "bytes=-8"})
    assert status == 206 and tail == body[-8:]
    assert get(server, "/media/video/3.mp4", {"Range": f"bytes={len(body)}-"})[0] == 416
    obj = min(data.simulation(3).dynamic_ids)
    status, headers, cf = get(server, f"/media/counterfactual/3/{obj}.mp4")
    assert status == 200 and cf[4:8] == b"ftyp"
    status, headers, png = get(server, "/media/frame/3/last.png")
    assert status == 200 and headers["Content-Type"] == "image/png" and png[:4] == b"\x89PNG"


def test_view_command_in_a_subprocess(users_dataset: Path) -> None:
    proc = popen_foreground([sys.executable, "-m", "craft_dsl.cli", "view", str(users_dataset), "--port", "0"],
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        assert line.startswith(f"serving {users_dataset} at http://127.0.0.1:"), line
        url = line.split(" at ")[1].split()[0]
        with urllib.request.urlopen(url + "api/summary", timeout=30) as response:
            assert json.loads(response.read())["videos"] == 6
    finally:
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 0
    bad = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "view", os.devnull], capture_output=True, text=True,
                         check=False)
    assert bad.returncode == 2 and "no such dataset folder" in bad.stderr
