#!/usr/bin/env python3
"""Make the few edits the unpacked CRAFT-Box2D sources need to build and run on Linux.

Usage: patch_sources.py CRAFT_BOX2D_DIR VIDEO_WRITER_H

CRAFT_BOX2D_DIR is the unpacked ``data_generation/2d/CRAFT-Box2D`` folder; VIDEO_WRITER_H is
tools/original/VideoWriter.h. Each edit finds a short anchor, checks that it occurs exactly once
and changes that spot only. Running it twice is harmless: an edit already made is skipped.
None of the edits touches physics or events. One lets a caller that records no video skip drawing (the environment
variable CRAFT_ORIGINAL_NO_DRAW), which saves most of a run's time and changes nothing it writes. One changes what is
drawn, to match the simulator's own live path: a scene loaded from JSON draws its static balls, as a generated scene
(the path that drew the published videos) does. One lets a caller seed a freshly generated scene (the environment
variable CRAFT_ORIGINAL_SEED): unset, the clock and the hardware seed it as before.
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


SEED_VARIABLE = "CRAFT_ORIGINAL_SEED"
#: Helpers put above the first hardware-seeded draw in Simulation.h. Unset, CraftHardwareSeed returns rd() as the
#: original did; set, it returns the next number of one mt19937 seeded from the variable, so each draw still gets
#: its own fresh mt19937 (as in the original) but from reproducible seeds. srand() and that generator get two seeds
#: mixed from the variable by std::seed_seq: glibc's srand() turns consecutive seeds into related streams.
SEED_HELPERS = (f"// craft_dsl: ${SEED_VARIABLE} (an unsigned 32-bit decimal) replaces the clock and hardware "
                "randomness\n") + f"""inline bool CraftSeedGiven(unsigned int* seed)
{{
\tstatic const char* text = std::getenv("{SEED_VARIABLE}");
\tif (text == nullptr) return false;
\tchar* end = nullptr;
\tunsigned long long value = std::strtoull(text, &end, 10);
\tif (text[0] < '0' || text[0] > '9' || *end != '\\0' || value > 0xFFFFFFFFull) {{
\t\tstd::cerr << "{SEED_VARIABLE} must be an unsigned 32-bit decimal integer, got '" << text << "'" << std::endl;
\t\tstd::exit(2);
\t}}
\t*seed = (unsigned int)value;
\treturn true;
}}

inline unsigned int CraftDerivedSeed(unsigned int seed, unsigned int purpose)
{{
\tstd::seed_seq mix{{seed, purpose}};
\tunsigned int out = 0;
\tmix.generate(&out, &out + 1);
\treturn out;
}}

inline unsigned int CraftHardwareSeed(std::random_device& rd)
{{
\tunsigned int seed = 0;
\tif (!CraftSeedGiven(&seed)) return rd();
\tstatic std::mt19937 stream(CraftDerivedSeed(seed, 2));
\treturn stream();
}}

"""
HARDWARE_DRAWS = ("inline float32 RandomFloatFromHardware(", "inline int RandomInteger(",
                  "inline float32 RandomFloatWithinRanges(")
HARDWARE_SEEDING = "std::mt19937 eng(rd());"


def seed_on_request(root: Path) -> str:
    # A fresh scene draws its positions, angles and speeds from std::random_device (a new mt19937 seeded by rd() for
    # each number) and its shapes, sizes and colours from rand() seeded with the clock: no run can be repeated.
    # With CRAFT_ORIGINAL_SEED set, the rd() seeds come from one mt19937 and srand() gets a seed, both mixed from it.
    path = root / "Testbed/Framework/Simulation.h"
    lines = _read(path)
    done = any("CraftHardwareSeed" in line for line in lines)
    if not done:
        for name in HARDWARE_DRAWS:
            at = _only_line(lines, name, path)
            seeding = [i for i in range(at, min(at + 8, len(lines))) if lines[i].strip().startswith(HARDWARE_SEEDING)]
            if len(seeding) != 1:
                raise PatchError(f"Simulation.h: expected one {HARDWARE_SEEDING!r} in {name.strip()}...")
            lines[seeding[0]] = lines[seeding[0]].replace("eng(rd())", "eng(CraftHardwareSeed(rd))", 1)
        first = _only_line(lines, HARDWARE_DRAWS[0], path)
        lines[first:first] = SEED_HELPERS.splitlines(keepends=True)
        if not any(line.strip() in ("#include <cstdlib>", "#include <stdlib.h>") for line in lines):
            lines.insert(0, "#include <cstdlib>\n")
        _write(path, lines)
    path = root / "Testbed/Framework/SimulationMain.cpp"
    lines = _read(path)
    if any("CraftSeedGiven" in line for line in lines):
        return "Simulation.h, SimulationMain.cpp: " + ("already " if done else "") + f"seeded by {SEED_VARIABLE}"
    at = _only_line(lines, "srand(time(NULL) + 42);", path)
    indent = lines[at][: len(lines[at]) - len(lines[at].lstrip())]
    lines[at:at + 1] = [indent + f"unsigned int craftSeed = 0;  // craft_dsl: ${SEED_VARIABLE} replaces the clock\n",
                        indent + "if (CraftSeedGiven(&craftSeed)) srand(CraftDerivedSeed(craftSeed, 1)); else "
                        + lines[at].lstrip()]
    _write(path, lines)
    return f"Simulation.h, SimulationMain.cpp: fresh scenes seeded by {SEED_VARIABLE} when it is set"


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
                     draw_static_balls_from_json, seed_on_request):
            print(edit(root))
        print(replace_video_writer(root, replacement))
    except PatchError as exc:
        print(f"patch_sources.py: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
