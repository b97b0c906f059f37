#!/usr/bin/env python3
"""Make the few edits the unpacked CRAFT-Box2D sources need to build and run on Linux.

Usage: patch_sources.py CRAFT_BOX2D_DIR VIDEO_WRITER_H

CRAFT_BOX2D_DIR is the unpacked ``data_generation/2d/CRAFT-Box2D`` folder; VIDEO_WRITER_H is
tools/original/VideoWriter.h. Each edit finds a short anchor, checks that it occurs exactly once
and changes that spot only. Running it twice is harmless: an edit already made is skipped.
None of the edits touches physics or events. One lets a caller that records no video skip drawing (the environment
variable CRAFT_ORIGINAL_NO_DRAW), which saves most of a run's time and changes nothing it writes. One changes what is
drawn, to match the simulator's own live path: a scene loaded from JSON draws its static balls, as a generated scene
(the path that drew the published videos) does.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

NOT_APPLE = "#if !defined(__APPLE__)"


class PatchError(RuntimeError):
    pass


def _read(path: Path) -> list[str]:
    if not path.is_file():
        raise PatchError(f"missing source file: {path}")
    return path.read_text(encoding="utf-8", errors="surrogateescape").splitlines(keepends=True)


def _write(path: Path, lines: list[str]) -> None:
    path.write_text("".join(lines), encoding="utf-8", errors="surrogateescape")


def _only_line(lines: list[str], needle: str, path: Path) -> int:
    hits = [i for i, line in enumerate(lines) if needle in line]
    if len(hits) != 1:
        raise PatchError(f"{path.name}: expected one line with {needle!r}, found {len(hits)}")
    return hits[0]


def _guard_before(lines: list[str], index: int, path: Path, what: str) -> int:
    """Index of the nearest preprocessor guard above line ``index``."""
    for i in range(index - 1, max(index - 8, -1), -1):
        text = lines[i].strip()
        if text.startswith("#if"):
            return i
    raise PatchError(f"{path.name}: no #if guard found above {what}")


def include_cstring(root: Path) -> str:
    # b2VisTexture.cpp calls memcpy without including <cstring>; g++ 12 rejects it.
    path = root / "Box2D/Extension/b2VisTexture.cpp"
    lines = _read(path)
    if any(line.strip() == "#include <cstring>" for line in lines):
        return "b2VisTexture.cpp: <cstring> already included"
    at = _only_line(lines, "#include <png.h>", path)
    lines.insert(at + 1, "#include <cstring>\n")
    _write(path, lines)
    return "b2VisTexture.cpp: added #include <cstring>"


def _msvc_guard_to_not_apple(root: Path, anchor: str, what: str) -> bool:
    """Turn the ``#ifdef _MSC_VER`` guard above the line holding ``anchor`` in SimulationMain.cpp into a guard for
    every non-Apple platform; False if that was already done."""
    path = root / "Testbed/Framework/SimulationMain.cpp"
    lines = _read(path)
    guard = _guard_before(lines, _only_line(lines, anchor, path), path, what)
    if lines[guard].strip() == NOT_APPLE:
        return False
    if lines[guard].strip() != "#ifdef _MSC_VER":
        raise PatchError(f"SimulationMain.cpp: unexpected guard above {what}: {lines[guard].strip()!r}")
    lines[guard] = NOT_APPLE + "\n"
    _write(path, lines)
    return True


def load_glad_off_apple(root: Path) -> str:
    # glad's GL entry points are only loaded under MSVC; on Linux every GL call then jumps to NULL.
    if not _msvc_guard_to_not_apple(root, "gladLoadGLLoader(", "gladLoadGLLoader"):
        return "SimulationMain.cpp: glad loader already enabled"
    return "SimulationMain.cpp: gladLoadGLLoader now runs on every non-Apple platform"


def full_size_window_off_apple(root: Path) -> str:
    # Off Windows the window is opened at width/2 x height/2 (a Retina assumption); without a
    # 2x display the read-back frame would hold the scene only in its lower-left quarter.
    if not _msvc_guard_to_not_apple(root, "glfwCreateWindow(g_camera.m_width, g_camera.m_height",
                                    "the full-size glfwCreateWindow"):
        return "SimulationMain.cpp: full-size window already selected"
    return "SimulationMain.cpp: window created at full width x height off macOS"


NO_DRAW_GUARD = 'if (std::getenv("CRAFT_ORIGINAL_NO_DRAW") == nullptr) {  // craft_dsl: no video, no drawing\n'


def skip_drawing_on_request(root: Path) -> str:
    # Every step draws the whole world in software GL even when no video is written (about 80% of a run's time);
    # with CRAFT_ORIGINAL_NO_DRAW set, the draw and flush calls after the world step are skipped.
    path = root / "Testbed/Framework/Simulation.cpp"
    lines = _read(path)
    if any("CRAFT_ORIGINAL_NO_DRAW" in line for line in lines):
        return "Simulation.cpp: drawing already skippable"
    draw = _only_line(lines, "m_world->DrawDebugData();", path)
    if "g_debugDraw.Flush();" not in lines[draw + 1]:
        raise PatchError("Simulation.cpp: expected g_debugDraw.Flush() right after m_world->DrawDebugData()")
    indent = lines[draw][: len(lines[draw]) - len(lines[draw].lstrip())]
    lines[draw + 2:draw + 2] = [indent + "}\n"]
    lines[draw:draw] = [indent + NO_DRAW_GUARD]
    if not any(line.strip() == "#include <cstdlib>" for line in lines):
        lines.insert(0, "#include <cstdlib>\n")
    _write(path, lines)
    # The render loop also clears and swaps the 16x multisampled window every step: skipped the same way.
    path = root / "Testbed/Framework/SimulationMain.cpp"
    lines = _read(path)
    for call in ("glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);", "glfwSwapBuffers(mainWindow);"):
        at = _only_line(lines, call, path)
        indent = lines[at][: len(lines[at]) - len(lines[at].lstrip())]
        lines[at] = indent + 'if (std::getenv("CRAFT_ORIGINAL_NO_DRAW") == nullptr) ' + lines[at].lstrip()
    if not any(line.strip() == "#include <cstdlib>" for line in lines):
        lines.insert(0, "#include <cstdlib>\n")
    _write(path, lines)
    return "Simulation.cpp, SimulationMain.cpp: draw, clear and swap skipped when CRAFT_ORIGINAL_NO_DRAW is set"


STATIC_BALL_CASE = "case SimulationObject::STATIC_BALL:"


def draw_static_balls_from_json(root: Path) -> str:
    # A generated scene gives every static body the platform texture (SimulationBase.h). A scene loaded from JSON
    # (ObjectState.h, the path craft_dsl drives) gives it to each static shape except the static ball, and with
    # textures on, an untextured body draws nothing: its static balls were invisible, though they collide. The
    # static ball joins the other static shapes' case, so both paths draw the same picture.
    path = root / "Testbed/Tests/SVQA/ObjectState.h"
    lines = _read(path)
    if any(STATIC_BALL_CASE in line for line in lines):
        return "ObjectState.h: static balls already textured"
    at = _only_line(lines, "case SimulationObject::STATIC_BOTTOM_BOUNDARY:", path)
    if "platformMat" not in lines[at + 1]:
        raise PatchError("ObjectState.h: expected the platform texture right after the bottom boundary's case")
    indent = lines[at][: len(lines[at]) - len(lines[at].lstrip())]
    lines.insert(at + 1, indent + STATIC_BALL_CASE + "  // craft_dsl: drawn as in a generated scene\n")
    _write(path, lines)
    return "ObjectState.h: static balls get the platform texture, as in a generated scene"


def replace_video_writer(root: Path, replacement: Path) -> str:
    # The original header uses the FFmpeg 4 encode API (avcodec_encode_video2), gone in FFmpeg 5.
    path = root / "Testbed/Framework/VideoWriter.h"
    if not path.is_file():
        raise PatchError(f"missing source file: {path}")
    if not replacement.is_file():
        raise PatchError(f"missing replacement header: {replacement}")
    if path.read_bytes() == replacement.read_bytes():
        return "VideoWriter.h: already replaced"
    shutil.copyfile(replacement, path)
    return "VideoWriter.h: replaced by tools/original/VideoWriter.h (FFmpeg 5 API)"


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    root, replacement = Path(argv[1]), Path(argv[2])
    try:
        for edit in (include_cstring, load_glad_off_apple, full_size_window_off_apple, skip_drawing_on_request,
                     draw_static_balls_from_json):
            print(edit(root))
        print(replace_video_writer(root, replacement))
    except PatchError as exc:
        print(f"patch_sources.py: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
