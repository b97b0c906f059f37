"""``craft-dsl generate`` on a real Dask cluster on this machine, with a worker killed in the middle.

Run: ``python benchmarks/generate_dask.py [--size 40] [--scenes 1-20]`` (needs the dask extra).

1. ``craft-dsl generate`` with the local executor (2 processes): the reference bytes and time;
2. ``dask scheduler`` and two ``dask worker ADDRESS --nthreads 1 --no-nanny`` processes on localhost;
3. the same generation with ``--executor dask --scheduler ADDRESS``; once a quarter of the videos are done, one of
   the two workers is killed (SIGKILL): the scheduler re-runs its tasks on the other one;
4. every file of both folders compared (the log, which holds times, left out).

Prints the times, which worker was killed when, how many videos were done then, and whether the bytes are equal.
Figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LOG = "generation.log"


def hashes(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != LOG}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def dask_cli() -> list[str]:
    exe = Path(sys.executable).with_name("dask")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "distributed.cli.dask_spec"]


def wait_for_workers(address: str, n: int, timeout: float = 120.0) -> None:
    from distributed import Client

    with Client(address, timeout=timeout) as client:
        client.wait_for_workers(n, timeout=timeout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=40)
    parser.add_argument("--scenes", default="1-20")
    args = parser.parse_args()
    common = ["--size", str(args.size), "--scenes", args.scenes, "--quiet"]
    with tempfile.TemporaryDirectory() as tmp:
        local, remote = Path(tmp) / "local", Path(tmp) / "dask"
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "craft_dsl", "generate", *common, "--out", str(local),
                        "--workers", "2"], check=True)
        local_s = time.perf_counter() - start

        address = f"tcp://127.0.0.1:{free_port()}"
        port = address.rsplit(":", 1)[1]
        procs = [subprocess.Popen([*dask_cli(), "scheduler", "--host", "127.0.0.1", "--port", port,
                                   "--dashboard-address", ":0"], stderr=subprocess.DEVNULL)]
        try:
            time.sleep(2)
            workers = [subprocess.Popen([*dask_cli(), "worker", address, "--nthreads", "1", "--no-nanny",
                                         "--name", f"w{k}"], stderr=subprocess.DEVNULL) for k in range(2)]
            procs += workers
            wait_for_workers(address, 2)
            start = time.perf_counter()
            run = subprocess.Popen([sys.executable, "-m", "craft_dsl", "generate", *common, "--out", str(remote),
                                    "--executor", "dask", "--scheduler", address])
            killed = None
            while run.poll() is None:
                shards = remote / ".generate" / "shards"
                merged = len(list((remote / "questions").glob("qa_*.json"))) if (remote / "questions").exists() \
                    else 0
                done = merged + (len(list(shards.glob("*.shard"))) if shards.exists() else 0)
                if killed is None and done >= args.size // 4:
                    workers[0].send_signal(signal.SIGKILL)
                    killed = (time.perf_counter() - start, done)
                time.sleep(0.1)
            dask_s = time.perf_counter() - start
            if run.returncode != 0:
                sys.exit(f"the Dask run failed (exit {run.returncode})")
        finally:
            for p in procs:
                if p.poll() is None:
                    p.send_signal(signal.SIGTERM)
            for p in procs:
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
        same = hashes(local) == hashes(remote)
        load = " ".join(f"{x:.2f}" for x in os.getloadavg())
        print(f"generate --size {args.size} --scenes {args.scenes}; load {load}")
        print(f"  local executor, 2 processes      : {local_s:6.1f} s")
        print(f"  Dask, scheduler + 2 workers      : {dask_s:6.1f} s"
              + (f" (worker w0 killed at {killed[0]:.1f} s, {killed[1]} videos done)" if killed else
                 " (finished before a worker could be killed)"))
        print(f"  files: {len(hashes(local))}; byte-identical: {same}")
        if not same:
            sys.exit(1)


if __name__ == "__main__":
    main()
