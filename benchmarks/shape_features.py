"""The reader's (shape, size) feature table, measured on a dataset's test videos at their own size or on copies
rescaled to a smaller one: how :data:`craft_dsl.reader.track.SHAPE_FEATURES_128` was made.

For each test video of a dataset written by ``craft-dsl generate --videos`` (``--part train``: the videos of no test
question, to calibrate on videos the reader is not scored on), the bodies are detected and tracked as the reader does
(layout, blobs, tracks) and, for each body whose colour is that of exactly one body of the true world (the dataset's
``annotations.json``: its start state, whichever sampler drew it), the three shape features (area,
radius / sqrt(area), second moment / area) are measured in every frame where it is seen whole; the body's medians
are its row. Printed per (shape, size), in the table's form: the median of the rows and their robust spread (1.4826 x
median absolute deviation, at least the native table's spread), and how many bodies.

    python benchmarks/shape_features.py --dataset DIR [--dataset DIR2 ...] [--size 128] [--part train] [--workers 2]
        [--limit N]

Several ``--dataset`` folders pool their bodies into one table.

``--size N`` reads copies made by ffmpeg as ``reader_robustness.py`` makes them (``scale=N:N``, its default bicubic,
lossless H.264) instead of the files, decoded back to the reader's size as ``craft-dsl read`` does. No randomness:
the same inputs give the same table.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from reader_robustness import LOSSLESS_H264, Variant, ffmpeg_exe, make_copies

from craft_dsl.reader.answer import find_videos
from craft_dsl.reader.layout import fit_layout
from craft_dsl.reader.layout_model import layout_model
from craft_dsl.reader.perceive import detect_objects, frame_steps_of
from craft_dsl.reader.track import SHAPE_FEATURES, _features, classify_shape
from craft_dsl.reader.video import decode_sized
from craft_dsl.render.raster import DEFAULT_SIZE, static_layer
from craft_dsl.world import WorldSpec

Row = tuple[str, str, float, float, float]
#: A dynamic body of a video's start state: (shape, colour, size).
Triple = tuple[str, str, str]


def start_triples(dataset: Path) -> dict[int, list[Triple]]:
    """Each video's dynamic bodies as its ``annotations.json`` records them (the first scene state)."""
    annotations = json.loads((dataset / "annotations.json").read_text())
    return {int(key): [(o["shape"], o["color"], o["size"])
                       for o in record["original_video_output"]["scene_states"][0]["scene"]["objects"]
                       if o["bodyType"] == 2]
            for key, record in annotations.items()}


def body_rows(index: int, video: Path, truth: list[Triple]) -> list[Row]:
    """(shape, size, median area, median radius / sqrt(area), median moment) of the bodies of one video (``truth``:
    its bodies) that its colour names alone."""
    frames, source = decode_sized(video, size=DEFAULT_SIZE)
    _given, rows = frame_steps_of(len(frames))
    layout = fit_layout(frames)
    model = layout_model(layout.scene)
    background = static_layer(WorldSpec(bodies=layout.statics), frames.shape[1])
    objects = detect_objects(frames, background, len(model.layout.dynamic), rows, source)
    out: list[Row] = []
    for obj in objects:
        named = [(shape, size) for shape, color, size in truth if color == obj.color_name]
        if len(named) != 1:
            continue
        classify_shape(obj, frames, background)  # measures the frames it samples
        features = _features(obj, obj.seen_whole())
        if len(features):
            area, radius, moment = np.median(features, axis=0).tolist()
            out.append((named[0][0], named[0][1], area, radius, moment))
    return out


def _job(args: tuple[int, Path, list[Triple]]) -> list[Row]:
    return body_rows(*args)


def copies(videos: dict[int, Path], size: int, folder: Path, workers: int) -> dict[int, Path]:
    """Lossless H.264 copies rescaled to ``size`` x ``size`` by ffmpeg, made as ``reader_robustness.py`` makes its
    ``scale-128`` and ``scale-512`` copies."""
    variant = Variant(f"scale-{size}", ".mp4", ("-vf", f"scale={size}:{size}", *LOSSLESS_H264), "libx264", "h264",
                      size=size)
    return make_copies(videos, variant, folder, workers, ffmpeg_exe())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", required=True, action="append",
                        help="a dataset folder written by craft-dsl generate --videos (repeat to pool several)")
    parser.add_argument("--size", type=int, help="read copies rescaled to this many pixels (default: the files)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--part", choices=("test", "train"), default="test",
                        help="the videos measured: those of the test questions (default), or those of none (to "
                             "calibrate on videos the reader is not scored on)")
    parser.add_argument("--limit", type=int, help="only the first N videos (a quick look)")
    args = parser.parse_args()
    rows: list[Row] = []
    count = 0
    for folder in args.dataset:
        dataset = Path(folder)
        test = {int(q["video_index"]) for name in ("random", "hard")
                for q in json.loads((dataset / f"split_info_{name}.json").read_text())["test"]}
        truth = start_triples(dataset)
        chosen = sorted(test if args.part == "test" else set(truth) - test)[:args.limit]
        count += len(chosen)
        videos = find_videos(dataset, chosen)
        with tempfile.TemporaryDirectory() as tmp:
            if args.size:
                videos = copies(videos, args.size, Path(tmp), args.workers)
            with ProcessPoolExecutor(args.workers) as pool:
                rows += [r for part in pool.map(_job, [(i, videos[i], truth[i]) for i in chosen]) for r in part]
    table: dict[tuple[str, str], list[tuple[float, float, float]]] = defaultdict(list)
    for shape, size, *features in rows:
        table[(shape, size)].append((features[0], features[1], features[2]))
    print(f"{count} {args.part} videos, {len(rows)} bodies named by their colour"
          + (f", copies at {args.size} px" if args.size else ""))
    for key in sorted(table):
        values = np.array(table[key])
        median = np.median(values, axis=0)
        spread = np.maximum(1.4826 * np.median(np.abs(values - median), axis=0), SHAPE_FEATURES[key][1])
        print(f"    {key!r}: (({median[0]:.1f}, {median[1]:.4f}, {median[2]:.4f}), "
              f"({spread[0]:.1f}, {spread[1]:.4f}, {spread[2]:.4f})),  # {len(values)} bodies")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
