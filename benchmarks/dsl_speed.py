"""How fast the DSL evaluates the 67 CRAFT template programs, against plain Python in the same run.

The baseline is an interpreter of the same programs' node lists written here over plain dicts (the
recorded JSON, indexed once per simulation: objects by id, events sorted by step, variation events),
the way one would write it without craft_dsl. Printed: programs per second for both, and the ratio
of our time to the baseline's (target <= 1.0: types cost nothing at run time).

    python benchmarks/dsl_speed.py [--sims N] [--repeat R]

Simulations: the worked example scene E1 plus N live simulations (scenes 1..20 round-robin, seed 0..),
written to JSON with variations and loaded back, so both evaluators read the same recorded files.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from craft_dsl import load_simulation
from craft_dsl.recorded import simulation_dict
from craft_dsl.templates import instantiate, templates

ROOT = Path(__file__).resolve().parents[1]

# -- the plain-Python baseline ----------------------------------------------------------------------------


class PlainScene:
    """A recorded simulation-with-variations dict, indexed once."""

    def __init__(self, data: dict[str, Any]) -> None:
        orig = data["original_video_output"]
        states = sorted(orig["scene_states"], key=lambda s: s["step"])
        self.start = {o["uniqueID"]: o for o in states[0]["scene"]["objects"]}
        self.end = {o["uniqueID"]: o for o in states[-1]["scene"]["objects"]}
        self.ids = sorted(self.start)
        self.ground = next(i for i, o in self.start.items() if o["shape"] == "ground")
        self.basket = next(i for i, o in self.start.items() if o["shape"] == "basket")
        self.events = sorted(orig["causal_graph"]["nodes"], key=lambda e: e["step"])
        self.variations = {int(k): sorted(v["causal_graph"]["nodes"], key=lambda e: e["step"])
                           for k, v in data["variations_outputs"].items()}


def _moving(o: dict[str, Any]) -> bool:
    vx, vy = o["2dLinearVelocity"]
    return o["bodyType"] != 0 and (abs(vx) > 0.001 or abs(vy) > 0.001)


def _collide(evs: list[dict[str, Any]], target: int) -> list[dict[str, Any]]:
    return [e for e in evs if e["type"] == "Collision" and target in e["objects"]]


def _objs(evs: list[dict[str, Any]]) -> list[int]:
    return sorted({o for e in evs for o in e["objects"]})


HANDLERS: dict[str, Any] = {
    "start_scene": lambda s: list(s.ids),
    "end_scene": lambda s: list(s.ids),
    "start_scene_step": lambda s: 0,
    "end_scene_step": lambda s: -1,
    "events": lambda s: s.events,
    "filter_color": lambda s, x, v: [i for i in x if s.start[i]["color"] == v],
    "filter_shape": lambda s, x, v: [i for i in x if s.start[i]["shape"] == v],
    "filter_size": lambda s, x, v: [i for i in x if s.start[i]["size"] == v],
    "filter_dynamic_objects": lambda s, x: [i for i in x if s.start[i]["bodyType"] != 0],
    "filter_moving_objects": lambda s, x, k: [i for i in x if _moving((s.start, s.end)[k][i])],
    "filter_stationary_objects": lambda s, x, k: [i for i in x if not _moving((s.start, s.end)[k][i])],
    "unique": lambda s, x: x[0] if len(x) == 1 else "__INVALID__",
    "as_list": lambda s, o: [o],
    "query_color": lambda s, o: s.start[o]["color"],
    "query_shape": lambda s, o: s.start[o]["shape"],
    "intersect": lambda s, a, b: sorted(set(a) & set(b)),
    "difference": lambda s, a, b: sorted(set(a) - set(b)),
    "intersect_list": lambda s, ls, b: [sorted(set(x) & set(b)) for x in ls],
    "count": lambda s, x: len(x),
    "exist": lambda s, x: len(x) > 0,
    "event_exist": lambda s, x: len(x) > 0,
    "exist_list": lambda s, ls: [len(x) > 0 for x in ls],
    "any_true": lambda s, x: True in x,
    "filter_events": lambda s, evs, o: [e for e in evs if o in e["objects"]],
    "filter_collision_with_dynamics": lambda s, evs: [
        e for e in evs if e["type"] == "Collision" and all(s.start[o]["bodyType"] != 0 for o in e["objects"])
    ],
    "filter_collide_ground": lambda s, evs: _collide(evs, s.ground),
    "filter_collide_basket": lambda s, evs: _collide(evs, s.basket),
    "filter_enter_container": lambda s, evs: [e for e in evs if e["type"] == "ContainerEndUp"],
    "filter_collide_ground_list": lambda s, ls: [_collide(x, s.ground) for x in ls],
    "filter_collide_basket_list": lambda s, ls: [_collide(x, s.basket) for x in ls],
    "filter_enter_container_list": lambda s, ls: [[e for e in x if e["type"] == "ContainerEndUp"] for x in ls],
    "filter_first": lambda s, evs: evs[0] if evs else "__INVALID__",
    "filter_last": lambda s, evs: evs[-1] if evs else "__INVALID__",
    "filter_before": lambda s, evs, r: [e for e in evs if e["step"] < r["step"]],
    "filter_after": lambda s, evs, r: [e for e in evs if e["step"] > r["step"]],
    "is_before": lambda s, a, b: a["step"] < b["step"],
    "event_partner": lambda s, o, e: (
        "__INVALID__" if len(e["objects"]) != 2 or o not in e["objects"]
        else (e["objects"][1] if e["objects"][0] == o else e["objects"][0])
    ),
    "filter_objects_from_events": lambda s, evs: _objs(evs),
    "filter_objects_from_events_list": lambda s, ls: [_objs(x) for x in ls],
    "counterfact_events": lambda s, o: s.variations[o],
    "counterfact_events_list": lambda s, x: [s.variations[o] for o in x],
}


def plain_run(scene: PlainScene, nodes: list[dict[str, Any]]) -> Any:
    outputs: list[Any] = []
    for node in nodes:
        args = [outputs[i] for i in node["inputs"]]
        if any(isinstance(a, str) and a == "__INVALID__" for a in args):
            return "__INVALID__"
        outputs.append(HANDLERS[node["type"]](scene, *args, *node["value_inputs"]))
    return outputs[-1]


# -- the benchmark -------------------------------------------------------------------------------------------


def recorded_files(n: int, folder: Path) -> list[Path]:
    files = [ROOT / "tests" / "data" / "e1.json"]
    if n:
        from craft_dsl.physics import simulate

        for k in range(n):
            sim = simulate(k % 20 + 1, seed=k // 20)
            path = folder / f"sim_{k:03d}.json"
            path.write_text(json.dumps(simulation_dict(sim)))
            files.append(path)
    return files


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sims", type=int, default=20, help="live simulations to record (0: E1 only)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        try:
            files = recorded_files(args.sims, Path(tmp))
        except ImportError:
            print("physics adapter not available: benchmarking on E1 only", file=sys.stderr)
            files = recorded_files(0, Path(tmp))
        work = []  # (our sim, plain scene, program, node list)
        for f in files:
            data = json.loads(f.read_text())
            sim, plain = load_simulation(data), PlainScene(data)
            for t in templates().values():
                found = instantiate(t, sim)
                if found is None:
                    continue
                program = t.program(found[0])
                work.append((sim, plain, program, program.to_nodes()))
    # Agreement first: the two evaluators must give the same answers.
    for sim, plain, program, nodes in work:
        ours, theirs = program.run(sim), plain_run(plain, nodes)
        assert (ours if not hasattr(ours, "__iter__") or isinstance(ours, str) else ours) == theirs, (
            str(program), ours, theirs)
    # Counterfactual simulations are cached inside each Simulation after the first run, as the plain
    # baseline's variation lists are indexed once: both now measure evaluation only.
    ours_t, plain_t = [], []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        for sim, _plain, program, _nodes in work:
            program.run(sim)
        ours_t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _sim, plain, _program, nodes in work:
            plain_run(plain, nodes)
        plain_t.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    for _sim, _plain, program, _nodes in work:
        type(program).parse(str(program))
    parse_s = time.perf_counter() - t0
    n = len(work)
    ours_best, plain_best = min(ours_t), min(plain_t)
    print(f"simulations: {len(files)}   program runs per pass: {n}   passes: {args.repeat}")
    print(f"craft_dsl evaluator : {n / ours_best:10.0f} programs/s  (median {n / statistics.median(ours_t):.0f})")
    print(f"plain-Python dicts  : {n / plain_best:10.0f} programs/s  (median {n / statistics.median(plain_t):.0f})")
    print(f"ratio ours/plain    : {ours_best / plain_best:10.2f}   (target <= 1.0)")
    print(f"parse + type-check  : {n / parse_s:10.0f} programs/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
