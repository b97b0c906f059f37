"""How fast the public hypothesis strategies draw, against hypothesis's own cost measured in the same run.

Every strategy is drawn N times inside a plain ``@given`` test (generation phase only, no database), the way a
user's property test draws it. The baseline is the same harness drawing a list of 50 small integers, i.e. what
hypothesis itself costs for a value made of 50 choices; drawn simulations are also compared with the live
physics runs of ``simulations(live=True)``. Printed: values per second, and each strategy's time per value over
the baseline's (how many "50-integer lists" one value costs).

    python benchmarks/strategies_speed.py [--examples N] [--repeat R]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from craft_dsl import DslType, Simulation
from craft_dsl.strategies import node_lists, programs, questions, simulations, world_specs


def with_counterfactuals(sim: Simulation) -> Simulation:
    """The simulation after asking for the counterfactual of every dynamic object (what GetCounterfactEvents
    programs do; a live simulation computes them on demand)."""
    for object_id in sorted(sim.dynamic_ids):
        sim.counterfactual(object_id)
    return sim


def seconds_per_value(strategy: st.SearchStrategy[Any], examples: int) -> float:
    """Wall time of one ``@given`` run drawing ``examples`` values, per value."""
    count = [0]

    @settings(max_examples=examples, database=None, deadline=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(strategy)
    def draw(value: Any) -> None:
        count[0] += 1

    start = time.perf_counter()
    draw()
    return (time.perf_counter() - start) / max(count[0], 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--examples", type=int, default=300, help="values drawn per run (default: 300)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per strategy; the median is kept (default: 3)")
    args = parser.parse_args()

    cases: list[tuple[str, st.SearchStrategy[Any], int]] = [
        ("baseline: 50 integers", st.lists(st.integers(0, 9), min_size=50, max_size=50), args.examples),
        ("programs()", programs(), args.examples),
        ("programs(DslType.BOOL)", programs(DslType.BOOL), args.examples),
        ("node_lists()", node_lists(), args.examples),
        ("world_specs()", world_specs(), args.examples),
        ("simulations()", simulations(), args.examples),
        ("simulations(live=True)", simulations(live=True), max(args.examples // 10, 10)),
        ("  + every counterfactual", simulations().map(with_counterfactuals), args.examples),
        ("  live + every counterfactual", simulations(live=True).map(with_counterfactuals),
         max(args.examples // 10, 10)),
        ("questions()", questions(), args.examples),
    ]
    timings: dict[str, list[float]] = {name: [] for name, _, _ in cases}
    for _ in range(args.repeat):  # round robin, so that a change of machine load hits every strategy alike
        for name, strategy, examples in cases:
            timings[name].append(seconds_per_value(strategy, examples))
    results = {name: statistics.median(times) for name, times in timings.items()}
    baseline = results["baseline: 50 integers"]
    print(f"{'strategy':26s} {'values/s':>9s} {'ms/value':>9s} {'x baseline':>11s}")
    for name, per_value in results.items():
        print(f"{name:26s} {1 / per_value:9.0f} {per_value * 1000:9.2f} {per_value / baseline:11.2f}")
    live, drawn = results["simulations(live=True)"], results["simulations()"]
    live_cf, drawn_cf = results["  live + every counterfactual"], results["  + every counterfactual"]
    print(f"\ndrawn simulations are {live / drawn:.1f}x faster than live ones (240 steps of pymunk each), "
          f"{live_cf / drawn_cf:.1f}x with every counterfactual")


if __name__ == "__main__":
    main()
