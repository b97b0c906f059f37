"""How fast the oracle scores *fresh* predicted programs, against the original CRAFT engine in the same run.

Scoring predicted programs runs inside training loops (rewards, beam re-ranking), so what counts is the cost
of a program the oracle has never seen: read it (node list, prefix or postfix tokens, or DSL text), check it,
compile it and run it on the true simulation. Printed, in programs per second and as a ratio to the original
engine's rate (a re-implementation of its executor, benchmarks/original_engine.py):

* original engine: a saved node list run the original's way;
* compiled: ``program.run(sim)`` of programs already built (the floor);
* fresh node lists / prefix tokens / postfix tokens / text: ``Program.from_nodes(...)`` etc., then ``run``;
* cached structures: the same forms through a :class:`craft_dsl.oracle.ProgramCache` that has seen each
  program once (a model re-emitting programs it emitted before: beams, epochs).

Targets (issue 9): fresh node lists >= 2x the original, cached structures >= 5x, text >= 1x.

    python benchmarks/oracle_speed.py [--sims N] [--repeat R]

Workload: every template with a valid instance on each of N live simulations (scenes 1..20 round-robin)
plus the worked example scene E1, all written to JSON with their variations and loaded back, so that both engines
read the same recorded files.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from original_engine import INVALID as ORIGINAL_INVALID
from original_engine import OriginalScene, answer_question

from craft_dsl import INVALID, Program, load_simulation
from craft_dsl.oracle import ProgramCache
from craft_dsl.recorded import simulation_dict
from craft_dsl.templates import first_instances

ROOT = Path(__file__).resolve().parents[1]


def recorded(n: int, folder: Path) -> list[dict[str, Any]]:
    out = [json.loads((ROOT / "tests" / "data" / "e1.json").read_text())]
    if n:
        from craft_dsl.physics import simulate

        for k in range(n):
            path = folder / f"sim_{k:03d}.json"
            path.write_text(json.dumps(simulation_dict(simulate(k % 20 + 1, seed=k // 20))))
            out.append(json.loads(path.read_text()))
    return out


def same(ours: Any, theirs: Any) -> bool:
    if ours is INVALID:
        return bool(theirs == ORIGINAL_INVALID)
    return bool(ours == theirs)


def best_rates(paths: dict[str, Callable[[], None]], n: int, repeat: int) -> dict[str, float]:
    """Programs/s of every path, best of ``repeat`` rounds; the paths take turns within each round, so that a
    machine busy with other work slows them alike."""
    best = dict.fromkeys(paths, float("inf"))
    for _ in range(repeat):
        for label, fn in paths.items():
            t0 = time.perf_counter()
            fn()
            best[label] = min(best[label], time.perf_counter() - t0)
    return {label: n / t for label, t in best.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sims", type=int, default=20, help="live simulations to record besides E1 (default 20)")
    ap.add_argument("--repeat", type=int, default=5, help="passes per measurement; the best is kept (default 5)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        datas = recorded(args.sims, Path(tmp))
    work = []  # (our sim, original scene, node list, prefix, postfix, text)
    for data in datas:
        sim, scene = load_simulation(data), OriginalScene(data)
        for _t, _params, program, _answer in first_instances(sim, include_dropped=True):
            nodes = program.to_nodes()
            work.append((sim, scene, program, nodes, program.to_tokens("prefix"), program.to_tokens("postfix"),
                         str(program)))
    for sim, scene, program, nodes, *_ in work:  # both engines must agree before anything is timed
        assert same(program.run(sim), answer_question(scene, nodes)), (str(program), program.run(sim))
        program.run(sim)  # counterfactual simulations are now cached inside each Simulation
    n = len(work)

    def original() -> None:
        for _sim, scene, _p, nodes, *_ in work:
            answer_question(scene, nodes)

    def compiled() -> None:
        for sim, _s, program, *_ in work:
            program.run(sim)

    def fresh(reader: Callable[[Any], Program], field: int) -> Callable[[], None]:
        def go() -> None:
            for item in work:
                reader(item[field]).run(item[0])
        return go

    paths: dict[str, Callable[[], None]] = {
        "original engine (node lists)": original,
        "compiled (already built)": compiled,
        "fresh node lists": fresh(Program.from_nodes, 3),
        "fresh prefix tokens": fresh(Program.from_tokens, 4),
        "fresh postfix tokens": fresh(lambda t: Program.from_tokens(t, "postfix"), 5),
        "fresh DSL text": fresh(Program.parse, 6),
    }
    cache = ProgramCache()
    for form, field in (("nodes", 3), ("prefix", 4), ("postfix", 5), ("text", 6)):
        for item in work:
            cache.get(item[field], form)  # type: ignore[arg-type]

    def cached(form: str, field: int) -> Callable[[], None]:
        def go() -> None:
            for item in work:
                cache.get(item[field], form).run(item[0])  # type: ignore[arg-type]
        return go

    for form, field in (("nodes", 3), ("prefix", 4), ("postfix", 5), ("text", 6)):
        paths[f"cached structures ({form})"] = cached(form, field)
    rates = best_rates(paths, n, args.repeat)
    base = rates["original engine (node lists)"]
    targets = {"fresh node lists": 2.0, "fresh DSL text": 1.0, "cached structures (nodes)": 5.0,
               "cached structures (prefix)": 5.0, "cached structures (postfix)": 5.0}
    print(f"simulations: {len(datas)}   programs per pass: {n}   passes: {args.repeat} (best kept)")
    print(f"{'path':34} {'programs/s':>11} {'x original':>11}  target")
    for label, rate in rates.items():
        target = f">= {targets[label]:.0f}x" if label in targets else ""
        print(f"{label:34} {rate:11.0f} {rate / base:11.2f}  {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
