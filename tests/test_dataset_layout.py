"""The published CRAFT layout of generated datasets: .mpg videos (MPEG-1), first/last frame PNGs, downsampled
videos, parked videos, and reading them the way code written for the published dataset does."""

from __future__ import annotations

import glob
import hashlib
import json
import os.path as osp
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from craft_dsl.dataset import layout as L
from craft_dsl.dataset import pipeline as P
from craft_dsl.errors import CraftError


def published_frame_path(datadir: str, path: str, frame: str = "first") -> str:
    """The published models' rule for frame images (replace 'videos' and 'mpg' in the recorded path)."""
    return osp.abspath(osp.join(datadir, path.replace("videos", frame + "_frames").replace("mpg", "png")))


def published_downsampled_path(datadir: str, path: str, fps: int) -> str:
    return osp.abspath(osp.join(datadir, path.replace("videos", f"downsampled/{fps}-fps").replace(".mpg", ".mp4")))


def ffmpeg_frame_count(path: Path) -> int:
    """Frames decoded by FFmpeg (imageio-ffmpeg's binary), independent of PyAV."""
    import imageio_ffmpeg

    done = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(path), "-map", "0:v:0",
                           "-c", "copy", "-f", "null", "-"], capture_output=True, text=True, check=True)
    assert done.stderr == ""
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    return int(frames)


def test_paths_follow_the_published_rules() -> None:
    video = L.video_relpath(3, 7)
    assert video == "./videos/sid_3/000007.mpg"
    assert L.frame_relpath(video) == video.replace("videos", "first_frames").replace("mpg", "png")
    assert L.frame_relpath(video, "last") == "./last_frames/sid_3/000007.png"
    assert L.downsampled_relpath(video, 5) == "./downsampled/5-fps/sid_3/000007.mp4"
    assert L.frame_relpath(L.video_relpath(12, 10000, "mp4")) == "./first_frames/sid_12/010000.png"
    with pytest.raises(ValueError, match="allowed: first, last"):
        L.frame_relpath(video, "middle")
    files = L.media_files(Path("/d"), 3, 7, "mpg", (5, 10))
    assert [str(f) for f in files] == ["/d/videos/sid_3/000007.mpg", "/d/first_frames/sid_3/000007.png",
                                       "/d/last_frames/sid_3/000007.png", "/d/downsampled/5-fps/sid_3/000007.mp4",
                                       "/d/downsampled/10-fps/sid_3/000007.mp4"]


def test_generated_dataset_reads_like_the_published_one(users_dataset: Path) -> None:
    datadir = str(users_dataset)
    minimal = json.loads((users_dataset / "dataset_minimal.json").read_text())
    full = json.loads((users_dataset / "dataset.json").read_text())
    assert minimal and full
    # every path of every file names an existing .mpg, in the published form
    for rec in minimal:
        path = rec["video_file_path"]
        assert path == f"./videos/sid_{rec['simulation_id']}/{rec['video_index']:06d}.mpg"
        assert Path(osp.join(datadir, path)).is_file()
        for frame in ("first", "last"):
            assert Path(published_frame_path(datadir, path, frame)).is_file()
    for video in full:
        assert video["video_path"].endswith(".mpg") and video["questions"]["info"]["video_filename"] == video[
            "video_path"]
        assert all(q["video_filename"] == video["video_path"] for q in video["questions"]["questions"])
    # the original dataset viewer finds a video by globbing videos/**/*.mpg for its six-digit stem
    found = {Path(p).stem for p in glob.glob(osp.join(datadir, "videos", "**", "*.mpg"), recursive=True)}
    assert {f"{r['video_index']:06d}" for r in minimal} <= found


def test_mpg_is_an_mpeg1_elementary_stream_like_the_original(users_dataset: Path) -> None:
    path = next((users_dataset / "videos").rglob("*.mpg"))
    data = path.read_bytes()
    assert data[:4] == b"\x00\x00\x01\xb3"  # sequence header, no container
    width_height = int.from_bytes(data[4:7], "big")
    assert (width_height >> 12, width_height & 0xFFF) == (256, 256)
    assert data[7] & 0x0F == 8  # frame_rate_code 8: 60 frames per second
    assert data.endswith(b"\x00\x00\x01\xb7")  # the MPEG end code the original appended
    assert ffmpeg_frame_count(path) == 200  # one frame per step


def test_frame_pngs_are_the_videos_first_and_last_frames(users_dataset: Path) -> None:
    from craft_dsl.physics import simulate
    from craft_dsl.render import encode_png, frame

    qa = json.loads((users_dataset / "questions" / "qa_000002.json").read_text())
    sim = simulate(qa["stats"]["scene"], seed=qa["stats"]["simulation_seed"], steps=200)
    first = users_dataset / "first_frames" / "sid_8" / "000002.png"
    last = users_dataset / "last_frames" / "sid_8" / "000002.png"
    assert first.read_bytes() == encode_png(frame(sim, 1))  # the state after step 1, as the video's frame 0
    assert last.read_bytes() == encode_png(frame(sim, 200))
    assert first.read_bytes() != last.read_bytes()


def test_decoded_mpg_matches_the_rendered_frames(users_dataset: Path) -> None:
    av = pytest.importorskip("av", reason="decoding needs PyAV, the torch extra: pip install 'craft-dsl[torch]'")
    from craft_dsl.physics import simulate
    from craft_dsl.render import frame

    qa = json.loads((users_dataset / "questions" / "qa_000004.json").read_text())
    sim = simulate(qa["stats"]["scene"], seed=qa["stats"]["simulation_seed"], steps=200)
    with av.open(str(users_dataset / "videos" / "sid_11" / "000004.mpg")) as container:
        decoded = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    assert len(decoded) == 200
    for i in (0, 99, 199):
        error = np.abs(decoded[i].astype(int) - frame(sim, i + 1).astype(int)).mean()
        assert error < 6.0, (i, error)  # MPEG-1 at 4 Mb/s: close to the rendered frame, not equal


def hashes(folder: Path) -> dict[str, str]:
    """Every file's hash, the log (which holds times) left out."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != P.LOG_FILE}


def test_mp4_format_downsampled_videos_and_identical_bytes_for_any_workers(tmp_path: Path) -> None:
    config: dict[str, Any] = {"size": 2, "scenes": (3,), "steps": 60, "perturbations": 0, "balance": False,
                              "videos": True, "video_format": "mp4", "downsampled": (10, 5, 10)}
    c1 = P.GenerationConfig.make(**config)
    assert c1.downsampled == (5, 10)
    P.generate_dataset(c1, tmp_path / "w1")
    P.generate_dataset(P.GenerationConfig.make(**config, workers=2), tmp_path / "w2")
    assert hashes(tmp_path / "w1") == hashes(tmp_path / "w2")
    out = tmp_path / "w1"
    minimal = json.loads((out / "dataset_minimal.json").read_text())
    assert minimal and all(r["video_file_path"].endswith(".mp4") for r in minimal)
    video = out / "videos" / "sid_3" / "000000.mp4"
    assert video.read_bytes()[4:8] == b"ftyp"
    assert (out / "first_frames" / "sid_3" / "000000.png").is_file()
    for fps in (5, 10):
        path = Path(published_downsampled_path(str(out), "./videos/sid_3/000000.mpg", fps))
        assert path.is_file() and ffmpeg_frame_count(path) == 60 * fps // 60
    assert json.loads((out / "generation_config.json").read_text())["video_format"] == "mp4"


def test_resume_redoes_an_instance_with_missing_media(tmp_path: Path) -> None:
    config = P.GenerationConfig.make(size=1, scenes=(5,), steps=30, perturbations=0, balance=False, videos=True)
    P.generate_dataset(config, tmp_path)
    before = hashes(tmp_path)
    assert L.media_complete(tmp_path, 5, 0, "mpg")
    (tmp_path / "last_frames" / "sid_5" / "000000.png").unlink()
    assert not L.media_complete(tmp_path, 5, 0, "mpg")
    log = tmp_path / P.LOG_FILE
    # the video's questions are done: only its media are made again (a media-only task), nothing else changes
    assert P.generate_dataset(config, tmp_path)["resumed"] == 1
    assert "1 already done, 1 tasks" in log.read_text().splitlines()[-2]
    assert hashes(tmp_path) == before


def test_videos_added_later_with_force(tmp_path: Path) -> None:
    config = P.GenerationConfig.make(size=1, scenes=(5,), steps=30, perturbations=0, balance=False)
    P.generate_dataset(config, tmp_path)
    before = hashes(tmp_path)
    with_videos = P.GenerationConfig.make(**dict(config.model_dump(), videos=True))
    with pytest.raises(CraftError, match="videos False here, True now"):
        P.generate_dataset(with_videos, tmp_path)
    P.generate_dataset(with_videos, tmp_path, force=True)  # only media settings differ: the media are added
    after = hashes(tmp_path)
    assert L.media_complete(tmp_path, 5, 0, "mpg")
    assert {k: v for k, v in after.items() if k in before and k != "generation_config.json"} == \
        {k: v for k, v in before.items() if k != "generation_config.json"}


def test_folder_of_an_older_version_is_refused(tmp_path: Path) -> None:
    config = P.GenerationConfig.make(size=1, scenes=(5,), steps=30, perturbations=0, balance=False)
    old = {k: v for k, v in config.content().items() if k not in ("video_format", "balance")}
    (tmp_path / "generation_config.json").write_text(json.dumps(old))
    message = f"format_version None here, {P.FORMAT_VERSION} now; video_format None here, 'mpg' now"
    with pytest.raises(CraftError, match=message):
        P.generate_dataset(config, tmp_path)
    with pytest.raises(CraftError, match="downsampled frame rates are 1-60"):
        P.GenerationConfig.make(size=1, downsampled=(0,))
    with pytest.raises(CraftError, match="video_format"):
        P.GenerationConfig.make(size=1, video_format="avi")


def test_videos_without_questions_are_parked_and_brought_back(tmp_path: Path) -> None:
    scene_of = {0: 2, 1: 2, 2: 4}
    for vi, scene in scene_of.items():
        path = L.resolve(tmp_path, L.video_relpath(scene, vi))
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(bytes([vi]))
    assert L.park_videos_without_questions(tmp_path, scene_of, [0, 2], "mpg") == 1
    assert (tmp_path / "videos_with_no_questions" / "sid_2" / "000001.mpg").read_bytes() == b"\x01"
    assert not (tmp_path / "videos" / "sid_2" / "000001.mpg").exists()
    for kind in ("first", "last"):
        (tmp_path / f"{kind}_frames" / "sid_2").mkdir(parents=True, exist_ok=True)
        (tmp_path / f"{kind}_frames" / "sid_2" / "000001.png").write_bytes(b"")
    assert L.media_complete(tmp_path, 2, 1, "mpg")  # a parked video counts as done for resuming
    assert L.park_videos_without_questions(tmp_path, scene_of, [0, 1, 2], "mpg") == 0
    assert (tmp_path / "videos" / "sid_2" / "000001.mpg").read_bytes() == b"\x01"


def test_cli_video_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from craft_dsl.cli import main

    out = tmp_path / "c"
    assert main(["generate", "--size", "1", "--scenes", "6", "--steps", "30", "--perturbations", "0",
                 "--no-balance", "--videos", "--video-format", "mp4", "--downsampled", "30", "--out", str(out)]) == 0
    assert (out / "videos" / "sid_6" / "000000.mp4").is_file()
    assert (out / "downsampled" / "30-fps" / "sid_6" / "000000.mp4").is_file()
    assert "Hugging Face" in capsys.readouterr().out
    assert main(["generate", "--size", "1", "--downsampled", "5,x", "--out", str(out)]) == 2
    assert "--downsampled '5,x': 'x' is not one of the frame rates or a range of them; allowed: 1-60" in \
        capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["generate", "--size", "1", "--video-format", "avi", "--out", str(out)])
    assert "invalid choice: 'avi'" in capsys.readouterr().err
