"""Rendering against encoding, in the same run: ms per frame and per 10-second video.

    python benchmarks/render_speed.py [--scenes 4] [--repeat 3]

Target: rendering at most a quarter of the encoding time. Also times the two encoders measured before
choosing one (imageio-ffmpeg, used by craft_dsl; PyAV, if installed), on the same frames.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from craft_dsl.physics import simulate
from craft_dsl.render import frames, write_frames


def _pyav_encode(frames_: np.ndarray, path: Path, fps: int = 60) -> None:
    import av

    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=fps)
        stream.width, stream.height, stream.pix_fmt = 256, 256, "yuv420p"
        stream.options = {"crf": "18"}
        stream.codec_context.thread_type = "AUTO"
        for f in frames_:
            for packet in stream.encode(av.VideoFrame.from_ndarray(f, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=8, help="scenes 1..N, seed 0")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sims = [simulate(s, seed=0) for s in range(1, args.scenes + 1)]
    render_t, mp4_t, gif_t, pyav_t = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeat):
            for sim in sims:
                t0 = time.perf_counter()
                fr = frames(sim)
                render_t.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                write_frames(iter(fr), Path(tmp) / "v.mp4")
                mp4_t.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                write_frames(iter(fr[::2]), Path(tmp) / "v.gif", fps=30)
                gif_t.append(time.perf_counter() - t0)
                try:
                    t0 = time.perf_counter()
                    _pyav_encode(fr, Path(tmp) / "p.mp4")
                    pyav_t.append(time.perf_counter() - t0)
                except ImportError:
                    pass
    n = 600
    r, e = statistics.median(render_t), statistics.median(mp4_t)
    print(f"{len(sims)} simulations x {args.repeat} passes, 600 frames of 256x256 each (medians)")
    print(f"render (numpy rasteriser) : {1000 * r / n:6.2f} ms/frame  {r:6.3f} s/video")
    print(f"encode MP4 (imageio-ffmpeg): {1000 * e / n:6.2f} ms/frame  {e:6.3f} s/video")
    print(f"encode GIF 30 fps           : {1000 * statistics.median(gif_t) / 300:6.2f} ms/frame  "
          f"{statistics.median(gif_t):6.3f} s/video")
    if pyav_t:
        print(f"encode MP4 (PyAV, threads)  : {1000 * statistics.median(pyav_t) / n:6.2f} ms/frame  "
              f"{statistics.median(pyav_t):6.3f} s/video")
    print(f"render / encode             : {r / e:6.2f}   (target <= 0.25)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
