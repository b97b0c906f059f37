"""The published CRAFT dataset's media layout: where videos and frame images live, and writing them.

The published dataset keeps one MPEG-1 video per simulation at ``videos/sid_<scene>/<id6>.mpg``; the JSON files
name it as ``./videos/sid_<scene>/<id6>.mpg`` (``video_path``, ``video_filename``, ``video_file_path``). Code
written for it derives the other media paths from that string:

* first and last frames: ``videos`` -> ``first_frames`` (or ``last_frames``) and ``mpg`` -> ``png``, e.g.
  ``./first_frames/sid_3/000007.png``;
* downsampled videos (models reading ``fps > 0``): ``videos`` -> ``downsampled/<fps>-fps`` and ``.mpg`` ->
  ``.mp4``, e.g. ``./downsampled/5-fps/sid_3/000007.mp4``;
* videos of simulations left without questions are moved to ``videos_with_no_questions/sid_<scene>/``.

:func:`write_media` writes all of these for one live simulation, :func:`media_files` lists them (so that resuming
can tell a complete instance), and :func:`park_videos_without_questions` moves the videos as the original did.
``mp4`` (H.264) replaces ``mpg`` for loaders that cannot read MPEG-1 (browsers, torchcodec without FFmpeg).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from ..atomic import atomic_path
from ..errors import CraftError
from ..simulation import Simulation

if TYPE_CHECKING:
    from ..physics.original import OriginalSimulation

VideoFormat = Literal["mpg", "mp4"]
#: Video formats ``generate --video-format`` writes; ``mpg`` (the published dataset's) is the default.
VIDEO_FORMATS: tuple[str, ...] = ("mpg", "mp4")
DEFAULT_VIDEO_FORMAT: VideoFormat = "mpg"
#: Frame image folders of the published layout (``<which>_frames``).
FRAME_KINDS: tuple[str, ...] = ("first", "last")
NO_QUESTIONS_FOLDER = "videos_with_no_questions"


def id6(instance_id: int) -> str:
    """The six-digit file stem of a simulation (``7`` -> ``"000007"``)."""
    return f"{instance_id:06d}"


def video_relpath(scene: int, instance_id: int, video_format: str = DEFAULT_VIDEO_FORMAT) -> str:
    """The dataset-relative video path recorded in the JSON files, e.g. ``./videos/sid_3/000007.mpg``."""
    return f"./videos/sid_{scene}/{id6(instance_id)}.{video_format}"


def frame_relpath(video_path: str, which: str = "first") -> str:
    """The frame image path that code written for the published dataset derives from a video path.

    ``./videos/sid_3/000007.mpg`` -> ``./first_frames/sid_3/000007.png`` (the published rule replaces
    ``videos`` by ``<which>_frames`` and ``mpg`` by ``png``; an ``.mp4`` path gets a ``.png`` suffix likewise).
    """
    if which not in FRAME_KINDS:
        raise ValueError(f"frame kind {which!r}; allowed: {', '.join(FRAME_KINDS)}")
    path = video_path.replace("videos", f"{which}_frames", 1)
    stem, _dot, _ext = path.rpartition(".")
    return f"{stem}.png"


def downsampled_relpath(video_path: str, fps: int) -> str:
    """The downsampled video path of the published models' loaders (``./downsampled/<fps>-fps/...mp4``)."""
    stem, _dot, _ext = video_path.replace("videos", f"downsampled/{fps}-fps", 1).rpartition(".")
    return f"{stem}.mp4"


def resolve(root: str | os.PathLike[str], relpath: str) -> Path:
    """A dataset-relative path (``./videos/...``) as a path under ``root``."""
    return Path(root) / relpath.removeprefix("./")


def media_files(root: Path, scene: int, instance_id: int, video_format: str,
                downsampled: Sequence[int] = ()) -> list[Path]:
    """Every media file :func:`write_media` writes for one simulation (the video first)."""
    video = video_relpath(scene, instance_id, video_format)
    paths = [video] + [frame_relpath(video, k) for k in FRAME_KINDS]
    paths += [downsampled_relpath(video, fps) for fps in downsampled]
    return [resolve(root, p) for p in paths]


def parked_video(root: Path, scene: int, instance_id: int, video_format: str) -> Path:
    """Where the video of a simulation without questions is moved (``videos_with_no_questions/sid_<s>/``)."""
    return root / NO_QUESTIONS_FOLDER / f"sid_{scene}" / f"{id6(instance_id)}.{video_format}"


def media_complete(root: Path, scene: int, instance_id: int, video_format: str,
                   downsampled: Sequence[int] = ()) -> bool:
    """True if every media file of the simulation exists (its video possibly parked, see above)."""
    video, *rest = media_files(root, scene, instance_id, video_format, downsampled)
    parked = parked_video(root, scene, instance_id, video_format)
    return (video.is_file() or parked.is_file()) and all(p.is_file() for p in rest)


def write_media(sim: Simulation, root: Path, scene: int, instance_id: int, video_format: str,
                downsampled: Sequence[int] = ()) -> list[Path]:
    """Render a live simulation into the published layout: the video (``.mpg`` MPEG-1 or ``.mp4`` H.264, 60 fps,
    256 x 256), its first and last frames as PNG (the states shown by the video's first and last frames: after
    step 1 and after the last step), and one H.264 video per ``downsampled`` frame rate. Each file is atomic."""
    from ..physics.original import OriginalSimulation
    from ..render import frame_steps, write_png, write_video

    if isinstance(sim, OriginalSimulation):
        return write_original_media(sim, root, scene, instance_id, video_format, downsampled)
    video, first, last, *lower = media_files(root, scene, instance_id, video_format, downsampled)
    write_video(sim, video)
    steps = frame_steps(sim.steps)
    write_png(sim, first, int(steps[0]))
    write_png(sim, last, int(steps[-1]))
    for fps, path in zip(downsampled, lower, strict=True):
        write_video(sim, path, fps=fps)
    return [video, first, last, *lower]


def write_original_media(sim: OriginalSimulation, root: Path, scene: int, instance_id: int, video_format: str,
                         downsampled: Sequence[int] = ()) -> list[Path]:
    """:func:`write_media` for a run of the original simulator: the original renderer draws the video (the factual
    run again, from the same start state or, where the original sampled it, the same seeded fresh scene, with
    drawing and MPEG-1 encoding on; its bytes are the ``.mpg``), and the first and last frames, an
    ``.mp4`` and the lower frame rates are taken from its decoded frames."""
    import tempfile

    from ..reader.video import decode
    from ..render import encode_png, frame_steps, write_frames

    video, first, last, *lower = media_files(root, scene, instance_id, video_format, downsampled)
    with tempfile.TemporaryDirectory(prefix="craft-original-media-") as tmp:
        mpg = Path(tmp) / "original.mpg"
        what = f"scene {scene} video {instance_id}"
        if sim.sampler_seed is not None:  # the original drew the start state itself: drawn again the same way
            sim.simulator.run_fresh(scene, sim.sampler_seed, sim.steps, video=mpg, what=what)
        else:
            sim.simulator.run(sim.world_spec, sim.steps, video=mpg, what=what)
        frames = decode(mpg, "pyav")
        if len(frames) != sim.steps:
            raise CraftError(f"the original renderer's video of scene {scene} video {instance_id} has {len(frames)} "
                             f"frames; {sim.steps} were drawn")
        if video_format == ".mpg":
            with atomic_path(video) as part:
                part.write_bytes(mpg.read_bytes())
        else:
            write_frames(frames, video)
        for path, image in ((first, frames[0]), (last, frames[-1])):
            with atomic_path(path) as part:
                part.write_bytes(encode_png(image))
        for fps, path in zip(downsampled, lower, strict=True):  # frame i shows the state after i + 1 steps
            write_frames([frames[int(row) - 1] for row in frame_steps(sim.steps, fps)], path, fps=fps)
    return [video, first, last, *lower]


def park_videos_without_questions(root: Path, scene_of: dict[int, int], with_questions: Iterable[int],
                                  video_format: str) -> int:
    """Move the videos of simulations without questions to ``videos_with_no_questions/sid_<s>/`` (as the
    original's cleanup did) and any parked video that has questions back; returns how many were moved away."""
    keep = set(with_questions)
    moved = 0
    for vi, scene in sorted(scene_of.items()):
        active = resolve(root, video_relpath(scene, vi, video_format))
        parked = parked_video(root, scene, vi, video_format)
        if vi in keep and parked.is_file() and not active.is_file():
            active.parent.mkdir(parents=True, exist_ok=True)
            os.replace(parked, active)
        elif vi not in keep and active.is_file():
            parked.parent.mkdir(parents=True, exist_ok=True)
            os.replace(active, parked)
            moved += 1
    return moved


__all__ = [
    "DEFAULT_VIDEO_FORMAT", "FRAME_KINDS", "NO_QUESTIONS_FOLDER", "VIDEO_FORMATS", "VideoFormat",
    "downsampled_relpath", "frame_relpath", "id6", "media_complete", "media_files", "park_videos_without_questions",
    "parked_video", "resolve", "video_relpath", "write_media",
]
