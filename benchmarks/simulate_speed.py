"""Physics speed: simulate() (events, recording) vs bare pymunk stepping, and variation sets per second.

Run: ``python benchmarks/simulate_speed.py [--seeds 3] [--scenes 1-20]``. Figures are printed, never asserted.
"""

from __future__ import annotations

import argparse
import time

from craft_dsl.physics import simulate
from craft_dsl.physics.pymunk_engine import PymunkEngine
from craft_dsl.scenes import sample_world


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--scenes", default="1-20")
    parser.add_argument("--steps", type=int, default=600)
    args = parser.parse_args()
    lo, _, hi = args.scenes.partition("-")
    scenes = list(range(int(lo), int(hi or lo) + 1))
    engine = PymunkEngine()
    worlds = [sample_world(sc, seed) for sc in scenes for seed in range(args.seeds)]

    t = time.perf_counter()
    for w in worlds:
        engine.run_bare(w, args.steps)
    bare = time.perf_counter() - t

    t = time.perf_counter()
    sims = [simulate(w, steps=args.steps, engine=engine) for w in worlds]
    full = time.perf_counter() - t

    t = time.perf_counter()
    removals = 0
    for w in worlds:
        sim = simulate(w, steps=args.steps, engine=engine)
        for uid in sorted(sim.dynamic_ids):
            sim.counterfactual(uid)
            removals += 1
    variations = time.perf_counter() - t

    n = len(worlds)
    events = sum(len(s.events) for s in sims)
    print(f"{n} worlds (scenes {scenes[0]}-{scenes[-1]}, {args.seeds} seeds), {args.steps} steps each")
    print(f"bare pymunk stepping : {bare / n * 1000:7.1f} ms/run  ({n / bare:6.1f} runs/s)")
    print(f"simulate() + events  : {full / n * 1000:7.1f} ms/run  ({n / full:6.1f} runs/s, {events / n:.1f} events)")
    print(f"ratio simulate/bare  : {full / bare:7.2f}x  (target <= 1.5x)")
    print(f"variation sets       : {n / variations:7.2f} sets/s  (factual + {removals / n:.1f} clean removals each; "
          f"{variations / n * 1000:.0f} ms per set)")


if __name__ == "__main__":
    main()
