"""Physics speed, per engine: simulate() (events, recording) vs bare stepping of the same engine, and
variation sets (factual run + every clean removal) per second.

Run: ``python benchmarks/simulate_speed.py [--seeds 3] [--scenes 1-20] [--engines pymunk,box2d]``.
Figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from craft_dsl.physics import simulate
from craft_dsl.physics.live import get_engine
from craft_dsl.scenes import sample_world
from craft_dsl.world import WorldSpec


def measure(engine_name: str, worlds: list[WorldSpec], steps: int) -> dict[str, Any]:
    engine: Any = get_engine(engine_name)
    n = len(worlds)

    t = time.perf_counter()
    for w in worlds:
        engine.run_bare(w, steps)
    bare = time.perf_counter() - t

    t = time.perf_counter()
    sims = [simulate(w, steps=steps, engine=engine) for w in worlds]
    full = time.perf_counter() - t

    t = time.perf_counter()
    removals = 0
    for w in worlds:
        sim = simulate(w, steps=steps, engine=engine)
        for uid in sorted(sim.dynamic_ids):
            sim.counterfactual(uid)
            removals += 1
    variations = time.perf_counter() - t
    return {
        "engine": engine_name,
        "bare_ms": bare / n * 1000,
        "simulate_ms": full / n * 1000,
        "ratio": full / bare,
        "events": sum(len(s.events) for s in sims) / n,
        "sets_per_s": n / variations,
        "set_ms": variations / n * 1000,
        "removals": removals / n,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--scenes", default="1-20")
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--engines", default="pymunk,box2d")
    args = parser.parse_args()
    lo, _, hi = args.scenes.partition("-")
    scenes = list(range(int(lo), int(hi or lo) + 1))
    worlds = [sample_world(sc, seed) for sc in scenes for seed in range(args.seeds)]
    print(f"{len(worlds)} worlds (scenes {scenes[0]}-{scenes[-1]}, {args.seeds} seeds), {args.steps} steps each")
    rows = [measure(name, worlds, args.steps) for name in args.engines.split(",")]
    for r in rows:
        print(f"[{r['engine']}]")
        print(f"  bare stepping       : {r['bare_ms']:7.1f} ms/run")
        print(f"  simulate() + events : {r['simulate_ms']:7.1f} ms/run  ({r['events']:.1f} events)")
        print(f"  ratio simulate/bare : {r['ratio']:7.2f}x")
        print(f"  variation sets      : {r['sets_per_s']:7.2f} sets/s  (factual + {r['removals']:.1f} clean removals "
              f"each; {r['set_ms']:.0f} ms per set)")
    print()
    print("| engine | bare ms/run | simulate() ms/run | ratio | events/run | variation sets/s | ms/set |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['engine']} | {r['bare_ms']:.1f} | {r['simulate_ms']:.1f} | {r['ratio']:.2f}x | "
              f"{r['events']:.1f} | {r['sets_per_s']:.2f} | {r['set_ms']:.0f} |")


if __name__ == "__main__":
    main()
