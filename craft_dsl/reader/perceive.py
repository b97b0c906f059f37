"""A CRAFT video file -> what is in it: layout, statics, bodies, their simulation, as a ``PerceivedScene``.

The stages (each its own module): decoding (:mod:`~craft_dsl.reader.video`), layout identification and static fit
(:mod:`~craft_dsl.reader.layout`), colour detection (:mod:`~craft_dsl.reader.detect`), objects and their attributes
(:mod:`~craft_dsl.reader.track`), and the simulation that reproduces the video (:mod:`~craft_dsl.reader.reconstruct`).
The :class:`~craft_dsl.perception.PerceivedScene` written from it holds the scene id, every object with its attribute
distributions, the static poses, per-frame tracks with velocities (the reconstructed motion) and the events of the
reconstructed run; ``craft_dsl.perception`` executes programs over it like over any perceived scene.

Frame rates: frame ``k`` shows the state after ``frame_steps[k]`` steps (:func:`~craft_dsl.reader.video.steps_shown`
of the video's rate, :func:`~craft_dsl.reader.video.frame_rate` measuring it; a resampled copy's frames earlier by the
offset :mod:`~craft_dsl.reader.timing` measures). Tracking runs over the frames; the
reconstruction compares its runs with them at the steps they show, and the perceived scene is the reconstructed run
at 60 fps (one frame per step: events to the step) whatever the video's rate.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import ReaderError
from ..perception.export import export_perceived
from ..perception.schema import PerceivedScene
from ..render.raster import DEFAULT_SIZE, static_layer, world_to_pixel
from ..world import WorldSpec
from .detect import blobs, grid_floor, grid_labels, grid_rims
from .ending import run_end, scene_moving_at_end
from .layout import StaticFit, fit_layout
from .layout_model import LayoutModel, layout_model
from .picture import Picture
from .reconstruct import Reconstruction, fit_frames, reader_engines, reconstruct_best, slot_uid, start_frames
from .timing import frame_offset as measure_offset
from .timing import offsets_allowed
from .tone import Tone, calibrated
from .track import (
    TrackedObject,
    classify_shape,
    compression_depth,
    drop_riding,
    drop_strays,
    measure_frames,
    merge_colour_splits,
    pair_twins,
    refine_frames,
    relink_merges,
    select_objects,
    soft_source,
    track,
    verify_shape,
)
from .video import (
    Decoder,
    FrameRate,
    checked_rate,
    collect_unchecked,
    decode_video,
    frame_rate,
    steps_shown,
    timed_steps,
)


@dataclass
class Perception:
    """Everything the reader saw in one video, with the time each stage took (seconds)."""

    scene: PerceivedScene
    layout: StaticFit
    objects: list[TrackedObject]
    reconstruction: Reconstruction
    timings: dict[str, float] = field(default_factory=dict)
    frame_rate: FrameRate = FrameRate(60.0, "given")  # the rate the frames were read at, and where it comes from
    frame_steps: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # step shown by each frame
    frame_offset: int = 0  # steps each frame shows earlier than the rate's rule (measured or given)
    picture: Picture | None = None  # where the picture lies in frames that are not square (None: the whole frame)
    frames_missing: int = 0  # frames missing inside the video, by their times (each frame read at its own time)
    tone: Tone | None = None  # the colour grading measured and undone (None: the palette's colours, as drawn)


def frame_steps_of(frames: int, fps: float | None = None, frame_steps: Sequence[int] | np.ndarray | None = None
                   ) -> tuple[FrameRate, np.ndarray]:
    """The rate and the step each of ``frames`` frames shows: ``frame_steps`` as given (increasing steps from 1;
    the rate is their mean), else those of ``fps`` (default 60). :class:`ReaderError` for anything else."""
    if frame_steps is not None:
        if fps is not None:
            raise ReaderError("give fps or frame_steps, not both")
        rows = np.asarray(frame_steps)
        if rows.shape != (frames,) or not np.issubdtype(rows.dtype, np.integer) or (
                frames and (rows[0] < 1 or np.any(np.diff(rows) <= 0))):
            raise ReaderError(f"frame_steps must be {frames} whole, increasing steps from 1 on (one per frame), "
                              f"got {rows.shape[0] if rows.ndim == 1 else rows.shape} values")
        rate = checked_rate(60.0 * frames / float(rows[-1]), "the rate frame_steps give") if frames else 60.0
        return FrameRate(rate, "given", "frame_steps"), rows.astype(np.int64)
    rate = checked_rate(60.0 if fps is None else fps)
    return FrameRate(rate, "given", f"{rate:g} fps"), steps_shown(frames, rate)


def perceive_frames(frames: np.ndarray, scene: int | None = None, timings: dict[str, float] | None = None,
                    engines: Sequence[str] | None = None, fps: float | None = None,
                    frame_steps: Sequence[int] | np.ndarray | None = None,
                    rate: FrameRate | None = None, source_size: int | None = None,
                    frame_offset: int | None = None, first_engine: str | None = None) -> Perception:
    """Perceive decoded frames uint8 [T, H, W, 3] (``scene``: skip the identification). ``engines``: the physics
    engines to reconstruct the motion with (default :func:`~craft_dsl.reader.reconstruct.reader_engines`: the
    engine the video is known to come from first, ``first_engine``, else the default engine first; Box2D alone
    where the statics' edges are aliased, as the original CRAFT renderer draws them); the
    reconstruction that follows the frames best is kept (:func:`~craft_dsl.reader.reconstruct.reconstruct_best`).
    ``fps`` (default 60) or ``frame_steps`` (the step each frame shows, for any other timing) say when the frames
    were taken; ``rate`` only records where ``fps`` came from. ``source_size``: the video's own frame size when the
    frames were rescaled to the reader's size as they were decoded (a smaller video's bodies look smaller and softer,
    see :func:`~craft_dsl.reader.track.shape_features`). ``frame_offset``: the steps each frame shows earlier than
    the rate's rule says (0 or negative; a copy resampled by ffmpeg's ``fps=10`` filter: -3); None: measured where
    frames are more than a step apart and ``frame_steps`` are not given (:mod:`~craft_dsl.reader.timing`)."""
    given, rows = frame_steps_of(len(frames), fps, frame_steps)
    if frame_offset is not None:
        if frame_steps is not None:
            raise ReaderError("give frame_steps or frame_offset, not both")
        if frame_offset not in offsets_allowed(rows):
            raise ReaderError(f"frame_offset {frame_offset!r} is not one these frames can have: "
                              f"{', '.join(map(str, offsets_allowed(rows)))} (steps earlier than the rate's rule)")
    rate = rate if rate is not None else given
    times = timings if timings is not None else {}
    t = time.perf_counter()
    frames, tone = calibrated(frames)  # a graded video's colours back to the palette (part of reading its pixels)
    times["decode"] = times.get("decode", 0.0) + time.perf_counter() - t
    t = time.perf_counter()
    layout = fit_layout(frames, scene=scene)
    model = layout_model(layout.scene, (), layout.offset)
    background = static_layer(WorldSpec(bodies=layout.statics), frames.shape[1])
    times["layout"] = time.perf_counter() - t
    t = time.perf_counter()
    tracks = find_tracks(frames, background, rows, source_size)
    absent = absent_slots(model, layout.values, tracks, frames.shape[1])
    if absent:  # a slot the original leaves empty on a duplicate triple (scene 7's last), and the video shows empty
        model = layout_model(layout.scene, absent, layout.offset)
        layout = replace(layout, values=model.renumbered(layout.values))
    objects = choose_tracks(tracks, len(model.layout.dynamic), frames, rows)
    pair_twins(objects)
    relink_merges(objects, frames, background)
    for obj in objects:
        classify_shape(obj, frames, background)
    depth = compression_depth(objects)  # a lossy video's bodies measure smaller than the tables' (H.264, MPEG-4)
    for obj in objects:
        if depth:
            classify_shape(obj, frames, background, depth=depth)
        measure_frames(obj, frames, background, fit_frames(start_frames(rows)))
        verify_shape(obj, frames, background, sparse=bool(rows.size and rows[-1] > rows.size))
    times["detect"] = time.perf_counter() - t
    t = time.perf_counter()

    def measure(obj: TrackedObject, which: Sequence[int], shape: str, size: str) -> None:
        measure_frames(obj, frames, background, which)
        refine_frames(obj, frames, background, which, shape, size)

    if engines is None:  # the engine the video comes from first (the original CRAFT renderer's look: Box2D alone)
        engines = reader_engines(layout.aliased, first_engine)
    steps = int(rows[-1])  # the run the frames were taken from ends where the rule's last frame does
    if frame_offset is None:  # measured unless frame_steps gave every frame's step
        frame_offset = 0 if frame_steps is not None else measure_offset(
            model, layout.values, objects, len(frames), rows, engines[0], measure).steps
    rows = rows + frame_offset
    rec = reconstruct_best(model, layout.values, objects, len(frames), steps=steps, engines=engines,
                           measure=measure, rows=rows)
    times["reconstruct"] = time.perf_counter() - t
    n_slots, trajectory = len(rec.attributes), rec.simulation.trajectory
    at_end = {} if trajectory is None else scene_moving_at_end(
        {slot: obj.blobs for obj, slot in zip(objects, rec.slots) if slot >= 0},
        {s: run_end(trajectory, slot_uid(s, n_slots)) for s in rec.slots if s >= 0}, n_slots, rows)
    perceived = to_perceived(rec, objects, layout, rate, at_end, frame_offset)
    if tone is not None:
        perceived = perceived.model_copy(update={"meta": {**(perceived.meta or {}), "tone": tone.to_json()}})
    return Perception(perceived, layout, objects, rec, times, rate, rows, frame_offset, tone=tone)


def detect_objects(frames: np.ndarray, background: np.ndarray, count: int | None, rows: np.ndarray,
                   source_size: int | None = None) -> list[TrackedObject]:
    """The tracks of the ``count`` most substantial bodies in ``frames`` (over the static layer ``background``;
    ``rows``: the step of each frame), each marked with the size the video was drawn at (``source_size``) where it
    was rescaled to the frames' size (None: read at its own size)."""
    return choose_tracks(find_tracks(frames, background, rows, source_size), count, frames, rows)


def find_tracks(frames: np.ndarray, background: np.ndarray, rows: np.ndarray,
                source_size: int | None = None) -> list[TrackedObject]:
    """Every track of a body colour in ``frames`` (see :func:`detect_objects`), before the bodies are chosen."""
    drawn_at = source_size if source_size is not None and source_size != frames.shape[1] else None
    found = blobs(grid_labels(frames, background, soft_source(drawn_at)), grid_rims(background),
                  grid_floor(background))
    tracks = merge_colour_splits(track(found, len(frames), steps=rows), rows)
    for obj in tracks:
        obj.blobs = drop_strays(obj.blobs, rows)
        obj.source_size = drawn_at
    return tracks


def choose_tracks(tracks: list[TrackedObject], count: int | None, frames: np.ndarray,
                  rows: np.ndarray) -> list[TrackedObject]:
    """The ``count`` most substantial of ``tracks`` (all where None), riders dropped."""
    chosen = select_objects(tracks, count, frames)
    drop_riding(chosen, rows)
    return chosen


#: How near (pixels of a 256-pixel frame) a body seen in the first frames must be to a slot's start for the slot
#: to count as present: under a small body's radius, well under the distance between two slots' starts.
PRESENT_RADIUS_PX = 12.0
#: The first frames in which a slot's body must be seen (a body at rest is seen from the first).
PRESENT_FRAMES = 3


def absent_slots(model: LayoutModel, values: Mapping[str, float], tracks: Sequence[TrackedObject],
                 size: int) -> tuple[int, ...]:
    """The slots that drop their object on a duplicate triple (``on_duplicate: "drop"``) and whose start no
    track shows in the first frames. A slot whose start is not fixed by the static draws ``values`` counts as
    present."""
    scale = size / DEFAULT_SIZE
    absent = []
    for i, slot in enumerate(model.layout.dynamic):
        start = model.fixed_start(i, values) if slot.on_duplicate == "drop" else None
        if start is None:
            continue
        x, y = world_to_pixel(*start, size)
        near = any(b is not None and math.hypot(b.x - x, b.y - y) <= PRESENT_RADIUS_PX * scale
                   for obj in tracks for b in obj.blobs[:PRESENT_FRAMES])
        if not near:
            absent.append(i)
    return tuple(absent)


def to_perceived(rec: Reconstruction, objects: list[TrackedObject], layout: StaticFit,
                 rate: FrameRate | None = None, moving_at_end: Mapping[int, bool] | None = None,
                 frame_offset: int = 0) -> PerceivedScene:
    """The PerceivedScene of a reconstruction: the exported run (60 fps), with the attribute probabilities the
    detector gives (the colour is read directly; shape and size from :func:`~craft_dsl.reader.track.classify_shape`);
    the rate the video was read at goes to ``meta`` where it is not 60 fps. ``moving_at_end`` (by slot): whether the
    frames show each body moving when the video ends (:func:`~craft_dsl.reader.ending.scene_moving_at_end`), the
    objects' ``moving_end`` instead of the run's last velocities; ``frame_offset`` (where not 0) too."""
    scene = export_perceived(rec.simulation)
    n = len(rec.attributes)
    probs: dict[int, dict[str, Any]] = {}
    for obj, slot in zip(objects, rec.slots):
        if slot < 0:
            continue
        uid = slot_uid(slot, n)
        shape, _color, size = rec.attributes[slot]
        p_shape: dict[str, float] = {}
        p_size: dict[str, float] = {}
        for (sh, sz), p in obj.shape_size.items():
            p_shape[sh] = p_shape.get(sh, 0.0) + p
            p_size[sz] = p_size.get(sz, 0.0) + p
        # the chosen (unique, slot-allowed) values stay the most likely ones
        p_shape = _with_mode(p_shape, shape)
        p_size = _with_mode(p_size, size)
        probs[uid] = {"shape": p_shape, "size": p_size}
        if moving_at_end and slot in moving_at_end:
            probs[uid]["moving_end"] = 1.0 if moving_at_end[slot] else 0.0
    objs = []
    for o in scene.objects:
        extra = probs.get(o.id)
        objs.append(o.model_copy(update=extra) if extra else o)
    meta = {"source": "craft_dsl.reader", "layout_rms": round(layout.rms, 3), "fit_frames": rec.fit_frames,
            "refits": rec.refits, "anchors": rec.anchors,
            "max_stray_px": round(max(rec.stray_px.values(), default=0.0), 3), "mean_stray_px": round(rec.final_px, 3),
            "start_px": {str(uid): round(d, 3) for uid, d in sorted(rec.start_px.items())},
            "engines_tried": list(rec.tried)}
    physics = rec.physics or scene.physics
    if physics != scene.physics:  # the run nearest the frames is the other engine's: it stays the record
        meta["run_engine"] = scene.physics
    if rate is not None and rate.fps != 60.0:
        meta.update(video_fps=rate.fps, video_fps_source=rate.source)
    if frame_offset:
        meta["frame_offset"] = frame_offset
    if layout.offset != (0.0, 0.0):  # the run's places are the picture's: the renderer's offset from the layout's
        meta["render_offset_m"] = list(layout.offset)
    return scene.model_copy(update={"objects": objs, "meta": meta, "physics": physics})


def _with_mode(dist: dict[str, float], mode: str) -> dict[str, float]:
    """``dist`` with ``mode`` made the most likely value (probabilities rounded, summing to 1)."""
    dist = {k: v for k, v in dist.items() if v > 1e-6}
    dist.setdefault(mode, 0.0)
    top = max(dist.values())
    if dist[mode] < top:
        dist[mode], other = top, dist[mode]
        for k in dist:
            if k != mode and dist[k] == top:
                dist[k] = other
                break
    total = sum(dist.values())
    rounded = {k: round(v / total, 6) for k, v in sorted(dist.items(), key=lambda kv: -kv[1])}
    drift = 1.0 - sum(rounded.values())
    rounded[mode] = round(rounded[mode] + drift, 6)
    return rounded


def perceive_video(path: str | os.PathLike[str], decoder: Decoder = "auto", scene: int | None = None,
                   engines: Sequence[str] | None = None, fps: float | None = None,
                   frame_steps: Sequence[int] | np.ndarray | None = None, frame_offset: int | None = None,
                   first_engine: str | None = None) -> Perception:
    """Perceive a video file (see the module docstring and :func:`perceive_frames`). Frames that are not square are
    read as the square picture they hold (:mod:`craft_dsl.reader.picture`; where it was found: ``picture`` and the
    scene's ``meta["picture"]``). Its frame rate is measured
    (:func:`~craft_dsl.reader.video.frame_rate`) unless ``fps`` or ``frame_steps`` state it, and so is the step its
    first frame shows unless ``frame_offset`` or ``frame_steps`` state it. Where the frames' times show frames
    missing inside the video (:func:`~craft_dsl.reader.video.timed_steps`), each frame is read at the step its time
    shows (``frames_missing``, and ``meta["frames_missing"]``, ``meta["first_gap_s"]``). What the file's probes
    could not check (:func:`~craft_dsl.reader.video.not_checked`) is ``meta["unchecked"]``. ``first_engine``: the
    engine the video is known to come from (tried first, :func:`perceive_frames`)."""
    timings: dict[str, float] = {}
    t = time.perf_counter()
    # another size is read at the reader's size; frames that are not square, as the square picture they hold
    decoded = decode_video(path, decoder, size=DEFAULT_SIZE)
    frames, picture = decoded.frames, decoded.picture
    timed = None
    rate: FrameRate | None = None
    unchecked: list[str] = []  # what the file's probes could not check: every answer says it
    if fps is None and frame_steps is None:  # neither stated: measured
        timed = timed_steps(decoded.times)
        if timed is not None:  # frames missing inside the video: each frame read at the step its time shows
            frame_steps = timed.steps
            rate = FrameRate(timed.fps, "stated", f"the frames' times ({timed.missing} frames missing)")
        else:
            with collect_unchecked() as unchecked:
                rate = frame_rate(path, len(frames))
            fps = rate.fps
    timings["decode"] = time.perf_counter() - t
    perception = perceive_frames(frames, scene, timings, engines, fps, frame_steps, rate, source_size=picture.side,
                                 frame_offset=frame_offset, first_engine=first_engine)
    meta: dict[str, Any] = {}
    if picture.how != "whole":  # where the picture was found in frames that are not square
        perception.picture = picture
        meta["picture"] = picture.to_json()
    if timed is not None:
        perception.frames_missing = timed.missing
        meta.update(frames_missing=timed.missing, first_gap_s=round(timed.first_gap, 3))
    if unchecked:
        meta["unchecked"] = list(unchecked)
    if meta:
        perception.scene = perception.scene.model_copy(update={"meta": {**(perception.scene.meta or {}), **meta}})
    return perception
