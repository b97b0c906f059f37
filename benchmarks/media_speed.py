"""The dataset's media, in one run: writing (.mpg MPEG-1, .mp4 H.264, frame PNGs) against rendering, reading
(PyAV decoding as craft_dsl.torch does) and the viewer's .mpg -> H.264 transcoding.

    python benchmarks/media_speed.py [--scenes 6] [--repeat 2]

Every figure is a median over scenes and repeats of 10-second videos (600 frames, 256 x 256); ratios are
against rendering the same frames, measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

from craft_dsl.physics import simulate
from craft_dsl.render import frames, write_frames, write_png
from craft_dsl.simulation import Simulation
from craft_dsl.viewer.data import transcode_to_mp4


def timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _two_pngs(sim: Simulation, folder: Path) -> None:
    write_png(sim, folder / "a.png", 1)
    write_png(sim, folder / "b.png", sim.steps)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=6, help="scenes 1..N, seed 0")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    try:
        from craft_dsl.torch import decode_video
    except ImportError:
        decode_video = None  # type: ignore[assignment]
    sims = [simulate(s, seed=0) for s in range(1, args.scenes + 1)]
    times: dict[str, list[float]] = {k: [] for k in ("render", "mpg", "mp4", "pngs", "decode mpg", "decode mp4",
                                                      "decode mpg 5 fps 128 px", "transcode mpg")}
    sizes: dict[str, list[int]] = {"mpg": [], "mp4": []}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            for k, sim in enumerate(sims):
                fr = frames(sim)
                times["render"].append(timed(partial(frames, sim)))
                for ext in ("mpg", "mp4"):
                    path = Path(tmp) / f"{k}.{ext}"
                    times[ext].append(timed(partial(write_frames, fr, path)))
                    sizes[ext].append(path.stat().st_size)
                times["pngs"].append(timed(partial(_two_pngs, sim, Path(tmp))))
                if decode_video is not None:
                    mpg, mp4 = Path(tmp) / f"{k}.mpg", Path(tmp) / f"{k}.mp4"
                    times["decode mpg"].append(timed(partial(decode_video, mpg)))
                    times["decode mp4"].append(timed(partial(decode_video, mp4)))
                    times["decode mpg 5 fps 128 px"].append(timed(partial(decode_video, mpg, 5, 128)))
                times["transcode mpg"].append(timed(partial(transcode_to_mp4, Path(tmp) / f"{k}.mpg")))
    render = statistics.median(times["render"])
    print(f"{len(sims)} simulations x {args.repeat} repeats, 600 frames of 256x256 (medians per 10-s video)")
    for name, values in times.items():
        if not values:
            print(f"{name:<26}: not measured (PyAV missing: pip install 'craft-dsl[torch]')")
            continue
        med = statistics.median(values)
        print(f"{name:<26}: {1000 * med:7.1f} ms/video  {1000 * med / 600:6.2f} ms/frame  {med / render:5.2f}x render")
    for ext, byte_counts in sizes.items():
        print(f"{ext} size                  : {statistics.median(byte_counts) / 1024:7.0f} KB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
