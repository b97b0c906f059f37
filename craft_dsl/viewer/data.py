"""What the viewer shows, as JSON-ready dicts and video bytes (no HTTP here: see :mod:`.server`).

* videos and their questions, filtered by scene, template, category and answer;
* a question's program with every node's value over the video's recorded simulation (the trace);
* the causal graph of a video's events, laid out for drawing (x: time, y: one lane per object);
* the counterfactual run without one object beside the factual one: its events (recorded in
  ``annotations.json``) and, when the dataset records each video's scene and simulation seed (``craft-dsl
  generate`` does, in ``questions/qa_<id6>.json``), its video, re-simulated and rendered on demand. A dataset
  without seeds (the published CRAFT dataset), or a re-simulation whose events differ from the recorded ones
  (another physics build), gets the recorded events without a video, and the reason.

Browsers cannot play MPEG-1, so ``.mpg`` videos are transcoded to H.264 once and kept in memory.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import networkx as nx

from ..dataset.folder import DatasetFolder
from ..errors import CraftError
from ..simulation import Event, Simulation
from ..vocabulary import LEGACY_DEFAULT_ENGINE
from ..world import DEFAULT_STEPS

#: Short event labels drawn in the graph.
EVENT_LABELS = {"Start": "S", "End": "E", "Collision": "C", "TouchStart": "TS", "TouchEnd": "TE", "EnterBasket": "B"}
#: Filters the viewer offers (query parameter -> record field).
FILTERS = {"scene": "simulation_id", "template": "template_id", "category": "category", "answer": "answer"}


class ViewerError(CraftError):
    """A request the viewer cannot answer (unknown video, question or object; no video to show)."""


def _event_key(e: Event) -> tuple[str, int, tuple[int, ...]]:
    return (e.type, e.step, tuple(sorted(e.objects)))


class _Bytes:
    """A small thread-safe LRU of generated media (bytes by key)."""

    def __init__(self, size: int) -> None:
        self._items: OrderedDict[str, bytes] = OrderedDict()
        self._size = size
        self._lock = threading.Lock()

    def get(self, key: str, make: Callable[[], bytes]) -> bytes:
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        data = make()
        with self._lock:
            self._items[key] = data
            while len(self._items) > self._size:
                self._items.popitem(last=False)
        return data


class ViewerData:
    """The dataset folder as the viewer's page asks for it."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.folder = DatasetFolder(root)
        self.by_video = self.folder.by_video()
        self._media = _Bytes(64)
        self._live: OrderedDict[int, Simulation] = OrderedDict()
        self._lock = threading.Lock()

    # -- listing --------------------------------------------------------------------------------------------

    def summary(self) -> dict[str, Any]:
        records = self.folder.records
        from ..dataset.stats import answer_order, template_order

        return {
            "name": self.folder.root.name,
            "questions": len(records),
            "videos": len(self.by_video),
            "filters": {
                "scene": sorted({r["simulation_id"] for r in records}, key=lambda s: int(s or 0)),
                "template": sorted({r["template_id"] for r in records}, key=template_order),
                "category": sorted({r["category"] for r in records}),
                "answer": sorted({str(r["answer"]) for r in records}, key=answer_order),
            },
            "resimulation": self.folder.config is not None,
        }

    def _matches(self, record: Mapping[str, Any], filters: Mapping[str, str]) -> bool:
        return all(str(record[FILTERS[k]]) == v for k, v in filters.items() if v and k in FILTERS)

    def videos(self, filters: Mapping[str, str]) -> list[dict[str, Any]]:
        """Videos with at least one question matching every filter, with the counts."""
        out = []
        for vi, recs in self.by_video.items():
            matched = sum(1 for r in recs if self._matches(r, filters))
            if matched:
                out.append({"video_index": vi, "scene": int(recs[0]["simulation_id"] or 0), "matched": matched,
                            "questions": len(recs)})
        return out

    def _records(self, video_index: int) -> list[dict[str, Any]]:
        try:
            return self.by_video[video_index]
        except KeyError:
            raise ViewerError(f"no video {video_index} with questions in {self.folder.root}") from None

    def simulation(self, video_index: int) -> Simulation:
        """The recorded simulation (with counterfactual variations) of a video."""
        annotations = self.folder.annotations
        key = annotations.resolve(f"{video_index:06d}", video_index)
        if key is None:
            raise ViewerError(f"{annotations.name}: no simulation for video {video_index:06d}")
        return annotations.simulation(key)

    # -- one video ------------------------------------------------------------------------------------------

    def video(self, video_index: int, filters: Mapping[str, str] | None = None) -> dict[str, Any]:
        recs = self._records(video_index)
        sim = self.simulation(video_index)
        programs = self.folder.programs
        questions = []
        for r in recs:
            key = (int(r["video_index"]), int(r["question_index"]))
            questions.append({
                "question_index": key[1], "question": r.get("question", ""), "answer": str(r["answer"]),
                "answer_type": r.get("answer_type", ""), "template_id": r["template_id"], "category": r["category"],
                "question_type": r["question_type"], "has_program": bool(programs.get(key)),
                "matches": self._matches(r, filters or {}),
            })
        reason = self.resimulation_unavailable(video_index)
        return {
            "video_index": video_index,
            "scene": int(recs[0]["simulation_id"] or 0),
            "video_file_path": self.folder.video_relpath(recs[0]),
            "has_video_file": self.folder.video_file(recs[0]).is_file(),
            "objects": [self._object(sim, o.id) for o in sim.objects],
            "questions": questions,
            "graph": self.graph(sim),
            "counterfactual": {"objects": [o.id for o in sim.objects if o.dynamic], "video": reason is None,
                               "reason": reason},
        }

    @staticmethod
    def _object(sim: Simulation, object_id: int) -> dict[str, Any]:
        o = sim.object(object_id)
        return {"id": o.id, "shape": o.shape, "color": o.color, "size": o.size, "dynamic": o.dynamic,
                "label": f"#{o.id} {o.size} {o.color} {o.shape}" if o.dynamic else f"#{o.id} {o.shape}"}

    @staticmethod
    def graph(sim: Simulation, graph: nx.DiGraph | None = None) -> dict[str, Any]:
        """Nodes (with x = rank of the step, y = lane of the event's first dynamic object) and edges."""
        g = sim.causal_graph if graph is None else graph
        steps = sorted({e.step for e in sim.events})
        dynamic = sorted(sim.dynamic_ids)
        lane_of = {oid: k + 1 for k, oid in enumerate(dynamic)}
        middle = (len(dynamic) + 1) / 2
        nodes = []
        for e in sim.events:
            lanes = [lane_of[o] for o in e.objects if o in lane_of]
            y = middle if e.type in ("Start", "End") else (min(lanes) if lanes else len(dynamic) + 1)
            names = ", ".join(sim.describe(o) for o in e.objects)
            nodes.append({"id": e.id, "type": e.type, "step": e.step, "objects": list(e.objects),
                          "label": EVENT_LABELS.get(e.type, e.type[:2]), "x": steps.index(e.step), "y": y,
                          "title": f"{e.type} at step {e.step}" + (f": {names}" if names else "")})
        edges = [[int(a), int(b)] for a, b in sorted(g.edges)]
        lane_labels = [{"y": lane_of[o], "label": sim.describe(o)} for o in dynamic]
        return {"nodes": nodes, "edges": edges, "lanes": lane_labels, "columns": len(steps)}

    # -- trace ----------------------------------------------------------------------------------------------

    def trace(self, video_index: int, question_index: int) -> dict[str, Any]:
        """The question's program with the value of every node over the recorded simulation."""
        from ..program import Program, format_value

        rec = next((r for r in self._records(video_index) if int(r["question_index"]) == question_index), None)
        if rec is None:
            raise ViewerError(f"video {video_index} has no question {question_index}")
        nodes = self.folder.programs.get((video_index, question_index))
        if not nodes:
            raise ViewerError(f"question {video_index}_{question_index} has no program (no dataset.json?)")
        program = Program.from_nodes(nodes)
        sim = self.simulation(video_index)
        factual = {e.id: _event_key(e) for e in sim.events}
        entries = []
        for k, entry in enumerate(program.trace(sim)):
            value = entry.value if isinstance(entry.value, tuple) else (entry.value,)
            # events of the factual run only (a counterfactual run's events are not nodes of the drawn graph)
            events = [e.id for e in value if isinstance(e, Event) and factual.get(e.id) == _event_key(e)]
            entries.append({"index": k, "expression": entry.expression, "type": str(entry.type),
                            "value": format_value(entry.value), "events": events})
        answer = program.run(sim)
        return {"video_index": video_index, "question_index": question_index, "question": rec.get("question", ""),
                "program": str(program), "recorded_answer": str(rec["answer"]), "answer": format_value(answer),
                "trace": entries}

    # -- counterfactuals ------------------------------------------------------------------------------------

    def resimulation_unavailable(self, video_index: int) -> str | None:
        """Why the video cannot be re-simulated live (``None`` if it can)."""
        if self.folder.config is None:
            return ("this dataset records no simulation seeds (it was not made by craft-dsl generate), so runs "
                    "cannot be re-simulated: the counterfactual events shown are the recorded ones")
        stats = self.folder.instance_stats(video_index)
        if not stats or "simulation_seed" not in stats:
            return f"questions/qa_{video_index:06d}.json with the video's simulation seed is missing"
        return None

    def live(self, video_index: int) -> Simulation:
        """The video re-simulated from its scene and seed; its events must equal the recorded ones."""
        with self._lock:
            if video_index in self._live:
                self._live.move_to_end(video_index)
                return self._live[video_index]
        reason = self.resimulation_unavailable(video_index)
        if reason is not None:
            raise ViewerError(f"cannot re-simulate video {video_index}: {reason}")
        from ..dataset.custom_scenes import recorded_layout
        from ..physics import simulate
        from ..scenes import sample_world

        stats = self.folder.instance_stats(video_index) or {}
        config = self.folder.config or {}
        seed = int(stats["simulation_seed"])
        layout = recorded_layout(config, int(stats["scene"]))
        scene: Any = int(stats["scene"]) if layout is None else sample_world(layout, seed)
        sim = simulate(scene, seed=seed, steps=int(config.get("steps", DEFAULT_STEPS)),
                       engine=str(config.get("engine", LEGACY_DEFAULT_ENGINE)))
        recorded = self.simulation(video_index)
        if sorted(map(_event_key, sim.events)) != sorted(map(_event_key, recorded.events)):
            raise ViewerError(f"video {video_index}: the re-simulation's events differ from the recorded ones "
                              "(another physics engine build?); showing recorded events only")
        with self._lock:
            self._live[video_index] = sim
            while len(self._live) > 4:
                self._live.popitem(last=False)
        return sim

    def counterfactual(self, video_index: int, object_id: int) -> dict[str, Any]:
        """The run without ``object_id``: its events against the factual ones, its graph, and whether a video
        of it can be rendered."""
        self._records(video_index)
        sim = self.simulation(video_index)
        if object_id not in sim.dynamic_ids:
            raise ViewerError(f"video {video_index}: object {object_id} is not a dynamic object "
                              f"(dynamic: {sorted(sim.dynamic_ids)})")
        cf = sim.counterfactual(object_id)
        factual = {_event_key(e) for e in sim.events if e.type not in ("Start", "End")}
        counter = {_event_key(e) for e in cf.events if e.type not in ("Start", "End")}

        def describe(keys: set[tuple[str, int, tuple[int, ...]]]) -> list[str]:
            return [f"{t} at step {s}: " + ", ".join(sim.describe(o) for o in objs) for t, s, objs in sorted(
                keys, key=lambda k: (k[1], k[0], k[2]))]

        reason = self.resimulation_unavailable(video_index)
        return {"video_index": video_index, "object": self._object(sim, object_id),
                "removed_events": describe(factual - counter), "new_events": describe(counter - factual),
                "kept_events": len(factual & counter), "graph": self.graph(cf), "video": reason is None,
                "reason": reason}

    # -- media ----------------------------------------------------------------------------------------------

    def video_mp4(self, video_index: int) -> bytes:
        """The factual video as browser-playable H.264 MP4 bytes."""
        recs = self._records(video_index)
        path = self.folder.video_file(recs[0])
        if path.suffix == ".mp4" and path.is_file():
            return path.read_bytes()
        if path.is_file():
            return self._media.get(f"video/{video_index}", lambda: transcode_to_mp4(path))
        reason = self.resimulation_unavailable(video_index)
        if reason is not None:
            raise ViewerError(f"{path}: no such video (generate with --videos), and {reason}")
        return self._media.get(f"video/{video_index}", lambda: render_mp4(self.live(video_index)))

    def counterfactual_mp4(self, video_index: int, object_id: int) -> bytes:
        """The counterfactual run without ``object_id``, re-simulated and rendered (H.264 MP4 bytes)."""
        sim = self.live(video_index)
        if object_id not in sim.dynamic_ids:
            raise ViewerError(f"video {video_index}: object {object_id} is not a dynamic object")
        return self._media.get(f"cf/{video_index}/{object_id}", lambda: render_mp4(sim.counterfactual(object_id)))

    def frame_png(self, video_index: int, which: str) -> bytes:
        recs = self._records(video_index)
        try:
            path = self.folder.frame_file(recs[0], which)
        except ValueError as err:
            raise ViewerError(str(err)) from None
        if not path.is_file():
            raise ViewerError(f"{path}: no such frame image")
        return path.read_bytes()


def render_mp4(sim: Simulation) -> bytes:
    """Render a live simulation to H.264 MP4 bytes."""
    from ..render import write_video

    with tempfile.TemporaryDirectory(prefix="craft-view-") as tmp:
        path = Path(tmp) / "video.mp4"
        write_video(sim, path)
        return path.read_bytes()


def transcode_to_mp4(path: Path) -> bytes:
    """An MPEG-1 (or any FFmpeg-readable) video as H.264 MP4 bytes, with imageio-ffmpeg's FFmpeg."""
    import imageio_ffmpeg

    with tempfile.TemporaryDirectory(prefix="craft-view-") as tmp:
        out = Path(tmp) / "video.mp4"
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-y", "-i", str(path), "-c:v", "libx264",
               "-pix_fmt", "yuv420p", "-crf", "18", "-movflags", "+faststart", str(out)]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0 or not out.is_file():
            raise ViewerError(f"{path}: cannot transcode to MP4: {done.stderr.strip()[-300:]}")
        return out.read_bytes()


__all__ = ["EVENT_LABELS", "FILTERS", "ViewerData", "ViewerError", "render_mp4", "transcode_to_mp4"]
