#!/usr/bin/env python3
"""Check that a built original CRAFT simulator runs headless and replays its own scenes exactly.

Usage: smoke_test.py [BINARY] [--scene N] [--keep DIR]

BINARY defaults to what tools/original/build.sh prints (building on first use). Uses $DISPLAY when
set, else starts a private Xvfb. Runs one fresh scene with video, then replays its step-0 state
(as {"scene_states": [...]}) without video and compares end states and events. When PyAV is
importable it also decodes the video and checks frame count, size and that both halves of the
picture hold drawing. Exit 0 when every check passes.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
STEPS = 600
SIZE = 256


def start_xvfb() -> tuple[subprocess.Popen, str]:
    read_end, write_end = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_end), "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
        pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    with os.fdopen(read_end) as reader:
        number = reader.readline().strip()
    if not number:
        raise SystemExit("smoke_test: Xvfb did not start")
    return proc, f":{number}"


def run(binary: Path, env: dict, workdir: Path, name: str, scene: str, video: bool) -> tuple[dict, float, Path]:
    controller = {
        "simulationID": ARGS.scene, "offline": True, "width": SIZE, "height": SIZE,
        "inputScenePath": scene, "outputVideoPath": str(workdir / f"{name}.mpg") if video else "",
        "outputJSONPath": str(workdir / f"{name}.json"), "stepCount": STEPS,
    }
    path = workdir / f"{name}_controller.json"
    path.write_text(json.dumps(controller))
    started = time.monotonic()
    done = subprocess.run([str(binary), str(path)], cwd=binary.parent, env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.monotonic() - started
    out = Path(controller["outputJSONPath"])
    if done.returncode != 0 or not out.is_file():
        raise SystemExit(f"smoke_test: {name}: exit {done.returncode}, no JSON\n{done.stderr}")
    return json.loads(out.read_text()), elapsed, Path(controller["outputVideoPath"] or "/nonexistent")


def events(output: dict) -> list:
    return sorted((n["type"], n["step"], tuple(sorted(n["objects"]))) for n in output["causal_graph"]["nodes"])


def check(ok: bool, what: str, failures: list) -> None:
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def main() -> int:
    binary = Path(ARGS.binary) if ARGS.binary else Path(subprocess.run(
        [str(HERE / "build.sh")], check=True, stdout=subprocess.PIPE, text=True).stdout.strip().splitlines()[-1])
    env = dict(os.environ)
    xvfb = None
    if not env.get("DISPLAY"):
        xvfb, env["DISPLAY"] = start_xvfb()
    workdir = Path(ARGS.keep) if ARGS.keep else Path(tempfile.mkdtemp(prefix="craft-original-smoke-"))
    workdir.mkdir(parents=True, exist_ok=True)
    failures: list[str] = []
    try:
        fresh, t_video, video = run(binary, env, workdir, "fresh", "", True)
        states = {s["step"]: s for s in fresh["scene_states"]}
        check(sorted(states) == [0, STEPS], f"scene_states at steps 0 and {STEPS}", failures)
        check(bool(states[0]["scene"]["objects"]), f"{len(states[0]['scene']['objects'])} objects", failures)
        kinds = {n["type"] for n in fresh["causal_graph"]["nodes"]}
        check({"Start", "End"} <= kinds, f"causal graph nodes: {len(fresh['causal_graph']['nodes'])}", failures)

        scene_file = workdir / "scene.json"
        scene_file.write_text(json.dumps({"scene_states": [states[0]]}))
        replay, t_plain, _ = run(binary, env, workdir, "replay", str(scene_file), False)
        end = {s["step"]: s for s in replay["scene_states"]}[STEPS]
        check(end == states[STEPS], "replay end state equals the fresh run's", failures)
        check(events(replay) == events(fresh), "replay events equal the fresh run's", failures)
        print(f"time per {STEPS}-step run: {t_video:.2f} s with video, {t_plain:.2f} s without")

        try:
            import av  # type: ignore[import-not-found]
        except ImportError:
            print("skip video decode (PyAV not installed); size", video.stat().st_size, "bytes")
        else:
            with av.open(str(video)) as container:
                frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
            check(len(frames) == STEPS, f"{len(frames)} frames", failures)
            check(frames[0].shape == (SIZE, SIZE, 3), f"frame size {frames[0].shape}", failures)
            ink = frames[0].min(axis=2) < 200
            half = SIZE // 2
            check(ink[:, :half].any() and ink[:, half:].any() and ink[half:, :].any(),
                  "drawing in both halves of the frame", failures)
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait()
        if not ARGS.keep:
            shutil.rmtree(workdir, ignore_errors=True)
    print("smoke test", "passed" if not failures else f"FAILED: {failures}")
    return 0 if not failures else 1


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("binary", nargs="?")
    parser.add_argument("--scene", type=int, default=1)
    parser.add_argument("--keep", metavar="DIR", help="keep the outputs in DIR")
    ARGS = parser.parse_args()
    sys.exit(main())
