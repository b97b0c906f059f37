"""Counterfactuals, causes and the causal graph of a live simulation.

    python examples/counterfactuals.py [scene] [seed]

Simulates a scene, removes each dynamic object in turn (clean counterfactuals: objects the removal never
reaches keep exactly their factual events), and asks the paper's cause / enable / prevent programs.
"""

from __future__ import annotations

import sys

import networkx as nx

from craft_dsl import parse
from craft_dsl.physics import simulate

OUTCOME = "FilterObjectsFromEvents(FilterEnterBasket({events}))"
CAUSES = (
    'Var A = FilterShape(FilterColor(FilterSize(SceneAtStart(), "{size}"), "{color}"), "{shape}")\n'
    "Count(FilterStationary(Difference(Difference(FilterDynamic({factual}), FilterDynamic({removed})), AsList(A)),"
    " StartSceneStep()))"
)


def main(scene: int = 4, seed: int = 0) -> None:
    sim = simulate(scene, seed=seed)
    print(f"scene {scene}, seed {seed}: {len(sim.events)} events, "
          f"causal graph with {sim.causal_graph.number_of_edges()} edges, "
          f"longest causal chain {nx.dag_longest_path_length(sim.causal_graph)} events")
    entered = parse(f"FilterDynamic({OUTCOME.format(events='Events()')})").run(sim)
    print("entered the basket:", [sim.describe(o) for o in entered] or "nothing")
    for obj in (o for o in sim.objects if o.dynamic):
        cf = sim.counterfactual(obj.id)
        untouched = sorted(set(sim.dynamic_ids) - set(cf.affected) - {obj.id})  # type: ignore[attr-defined]
        program = parse(CAUSES.format(size=obj.size, color=obj.color, shape=obj.shape,
                                      factual=OUTCOME.format(events="Events()"),
                                      removed=OUTCOME.format(events="GetCounterfactEvents(A)")))
        print(f"without {sim.describe(obj.id)}: re-simulated {sorted(cf.affected)}, replayed exactly {untouched}; "  # type: ignore[attr-defined]
              f"it causes {program.run(sim)} object(s) to enter the basket")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
