"""Rendering and encoding a 10-second video, in CPU time (this process and its children), in the same run:
craft_dsl's path against the one it replaced.

    python benchmarks/render_speed.py [--scenes 8] [--repeat 2]

* ``render RGB``: :func:`craft_dsl.render.frames` (600 frames, 256 x 256);
* ``render + YUV (tiles)``: :func:`craft_dsl.render.yuv.iter_yuv420`, the frames as YUV 4:2:0 planes converted only
  where a body changed;
* ``.mpg`` / ``.mp4``: :func:`craft_dsl.render.write_video`, the whole file (render, conversion, PyAV encoding);
* ``.mpg, RGB piped to FFmpeg``: the previous path, for the ratio: the same frames rendered, piped as RGB to
  imageio-ffmpeg's ``ffmpeg`` process with the same MPEG-1 settings (it converts every pixel of every frame);
* ``.gif`` at 30 fps (imageio-ffmpeg, palettegen/paletteuse).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from craft_dsl.physics import simulate
from craft_dsl.render import frames, iter_frames, write_frames, write_video
from craft_dsl.render.yuv import iter_yuv420


def cpu() -> float:
    """CPU seconds of this process and of its finished children."""
    own = time.process_time()
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own + children.ru_utime + children.ru_stime


def timed(fn: Callable[[], object]) -> float:
    start = cpu()
    fn()
    return cpu() - start


def pipe_mpg(sim: object, path: Path) -> None:
    """The previous .mpg path: RGB frames piped to an FFmpeg process, which converts and encodes them."""
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(str(path), (256, 256), fps=60, macro_block_size=1, ffmpeg_log_level="error",
                                         codec="mpeg1video", pix_fmt_out="yuv420p", bitrate="4M",
                                         output_params=["-g", "25", "-bf", "1", "-threads", "1", "-f", "mpeg1video"])
    writer.send(None)
    for img in iter_frames(sim):  # type: ignore[arg-type]
        writer.send(img)
    writer.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", type=int, default=8, help="scenes 1..N, seed 0")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    sims = [simulate(s, seed=0) for s in range(1, args.scenes + 1)]
    rows: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        write_video(sims[0], out / "warm.mpg")
        for _ in range(args.repeat):
            for sim in sims:
                for label, fn in (
                    ("render RGB", lambda sim=sim: frames(sim)),
                    ("render + YUV (tiles)", lambda sim=sim: sum(1 for _ in iter_yuv420(sim))),
                    (".mpg (craft_dsl: YUV tiles, PyAV in-process)", lambda sim=sim: write_video(sim, out / "v.mpg")),
                    (".mpg, RGB piped to FFmpeg (previous path)", lambda sim=sim: pipe_mpg(sim, out / "p.mpg")),
                    (".mp4 (H.264, CRF 18)", lambda sim=sim: write_video(sim, out / "v.mp4")),
                    (".gif, 30 fps", lambda sim=sim: write_frames(iter(frames(sim, fps=30)), out / "v.gif", fps=30)),
                ):
                    rows.setdefault(label, []).append(timed(fn))
    med = {k: statistics.median(v) for k, v in rows.items()}
    print(f"{len(sims)} simulations x {args.repeat} passes, 10-s videos of 256 x 256 (medians of CPU time, this "
          f"process and its children); load {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("| step | ms per video | ms per frame |")
    print("|---|---|---|")
    for label, t in med.items():
        frames_n = 300 if "gif" in label else 600
        print(f"| {label} | {1000 * t:.0f} | {1000 * t / frames_n:.3f} |")
    new, old = med[".mpg (craft_dsl: YUV tiles, PyAV in-process)"], med[".mpg, RGB piped to FFmpeg (previous path)"]
    print(f".mpg: {old / new:.2f}x less CPU than the previous path")
    return 0


if __name__ == "__main__":
    sys.exit(main())
