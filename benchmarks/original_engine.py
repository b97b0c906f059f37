"""A re-implementation of the original CRAFT question engine's executor, as the speed baseline.

It follows the original's documented behaviour, not its code: a program is a node list run node by node
(each node's handler receives the whole simulation-with-variations dict, the two scene structs, the factual
causal graph, the input values and the side inputs); objects are found by scanning the scene's object list;
``events`` sorts the causal graph's nodes by step at every call; ``counterfact_events`` builds a causal graph
from the variation's JSON at every call; the run stops at the first ``'__INVALID__'``; node lists are copied
and run with caching off, as the original's offline re-answering does. Answers agree with craft_dsl on every
template (checked by the benchmarks before timing).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

INVALID = "__INVALID__"


class CausalGraph:
    """The original's graph object: events by id and outcome edges (every node must be a source)."""

    def __init__(self, graph: dict[str, Any]) -> None:
        self.events = {node["id"]: node for node in graph["nodes"]}
        self.outcomes = {edge["from"]: list(edge["to"]) for edge in graph.get("edges", [])}
        for node_id in self.events:
            self.outcomes.setdefault(node_id, [])

    def sorted_events(self) -> list[dict[str, Any]]:
        return sorted(self.events.values(), key=lambda e: e["step"])


def _find(scene: dict[str, Any], uid: int) -> dict[str, Any]:
    return [o for o in scene["objects"] if o["uniqueID"] == uid][0]


def _static_id(scene: dict[str, Any], shape: str) -> int:
    found = [o["uniqueID"] for o in scene["objects"] if o["shape"] == shape]
    assert len(found) == 1
    return int(found[0])


def _dynamic(scene: dict[str, Any], uid: int) -> bool:
    return bool(_find(scene, uid)["bodyType"] != 0)


def _moving(scene: dict[str, Any], uid: int) -> bool:
    o = _find(scene, uid)
    vx, vy = o["2dLinearVelocity"]
    return bool(o["bodyType"] != 0 and (abs(vx) > 0.001 or abs(vy) > 0.001))


def _filter_attr(attr: str) -> Callable[..., Any]:
    def handler(var: Any, scenes: Any, graph: Any, inputs: Any, side: Any) -> Any:
        value = side[0]
        return [i for i in inputs[0] if value == _find(scenes[0], i)[attr] or value in _find(scenes[0], i)[attr]]

    return handler


def _query(attr: str) -> Callable[..., Any]:
    return lambda var, scenes, graph, inputs, side: _find(scenes[0], inputs[0])[attr]


def _collide(target: str) -> Callable[..., Any]:
    def handler(var: Any, scenes: Any, graph: Any, inputs: Any, side: Any) -> Any:
        tid = _static_id(scenes[0], target)
        return [e for e in inputs[0] if e["type"] == "Collision" and tid in e["objects"][:2]]

    return handler


def _collide_list(target: str) -> Callable[..., Any]:
    one = _collide(target)
    return lambda var, scenes, graph, inputs, side: [one(var, scenes, graph, [x], side) for x in inputs[0]]


def _objects(events: list[dict[str, Any]]) -> list[int]:
    return list({o for e in events for o in (e["objects"][0], e["objects"][1])})


def _counterfact(var: dict[str, Any], uid: int) -> list[dict[str, Any]]:
    return CausalGraph(var["variations_outputs"][str(uid)]["causal_graph"]).sorted_events()


def _first(events: list[dict[str, Any]]) -> Any:
    assert len(events) > 0
    return events[0]


def _last(events: list[dict[str, Any]]) -> Any:
    assert len(events) > 0
    return events[-1]


def _partner(obj: int, event: dict[str, Any]) -> int:
    objs = event["objects"]
    assert len(objs) == 2
    return int(objs[0] if objs[0] != obj else objs[1])


HANDLERS: dict[str, Callable[..., Any]] = {
    "start_scene": lambda var, scenes, graph, inputs, side: [o["uniqueID"] for o in scenes[0]["objects"]],
    "end_scene": lambda var, scenes, graph, inputs, side: [o["uniqueID"] for o in scenes[-1]["objects"]],
    "start_scene_step": lambda var, scenes, graph, inputs, side: 0,
    "end_scene_step": lambda var, scenes, graph, inputs, side: -1,
    "filter_color": _filter_attr("color"),
    "filter_shape": _filter_attr("shape"),
    "filter_size": _filter_attr("size"),
    "unique": lambda var, scenes, graph, inputs, side: inputs[0][0] if len(inputs[0]) == 1 else INVALID,
    "union": lambda var, scenes, graph, inputs, side: sorted(set(inputs[0]) | set(inputs[1])),
    "intersect": lambda var, scenes, graph, inputs, side: sorted(set(inputs[0]) & set(inputs[1])),
    "intersect_list": lambda var, scenes, graph, inputs, side: [sorted(set(x) & set(inputs[1])) for x in inputs[0]],
    "difference": lambda var, scenes, graph, inputs, side: sorted(set(inputs[0]) - set(inputs[1])),
    "count": lambda var, scenes, graph, inputs, side: len(inputs[0]),
    "query_color": _query("color"),
    "query_shape": _query("shape"),
    "query_size": _query("size"),
    "exist": lambda var, scenes, graph, inputs, side: len(inputs[0]) > 0,
    "event_exist": lambda var, scenes, graph, inputs, side: len(inputs[0]) > 0,
    "exist_list": lambda var, scenes, graph, inputs, side: [len(x) > 0 for x in inputs[0]],
    "any_false": lambda var, scenes, graph, inputs, side: False in inputs[0],
    "any_true": lambda var, scenes, graph, inputs, side: True in inputs[0],
    "events": lambda var, scenes, graph, inputs, side: graph.sorted_events(),
    "filter_events": lambda var, scenes, graph, inputs, side: [e for e in inputs[0] if inputs[1] in e["objects"]],
    "filter_collision": lambda var, scenes, graph, inputs, side: [e for e in inputs[0] if e["type"] == "Collision"],
    "filter_collision_with_dynamics": lambda var, scenes, graph, inputs, side: [
        e for e in inputs[0] if e["type"] == "Collision" and _dynamic(scenes[0], e["objects"][0])
        and (len(e["objects"]) == 1 or _dynamic(scenes[0], e["objects"][1]))],
    "filter_enter_container": lambda var, scenes, graph, inputs, side: [
        e for e in inputs[0] if e["type"] == "ContainerEndUp"],
    "filter_enter_container_list": lambda var, scenes, graph, inputs, side: [
        [e for e in x if e["type"] == "ContainerEndUp"] for x in inputs[0]],
    "filter_collide_ground": _collide("ground"),
    "filter_collide_ground_list": _collide_list("ground"),
    "filter_collide_basket": _collide("basket"),
    "filter_collide_basket_list": _collide_list("basket"),
    "filter_first": lambda var, scenes, graph, inputs, side: _first(inputs[0]),
    "filter_last": lambda var, scenes, graph, inputs, side: _last(inputs[0]),
    "event_partner": lambda var, scenes, graph, inputs, side: _partner(inputs[0], inputs[1]),
    "filter_moving_objects": lambda var, scenes, graph, inputs, side: [
        i for i in inputs[0] if _moving(scenes[inputs[1]], i)],
    "filter_stationary_objects": lambda var, scenes, graph, inputs, side: [
        i for i in inputs[0] if not _moving(scenes[inputs[1]], i)],
    "filter_dynamic_objects": lambda var, scenes, graph, inputs, side: [
        i for i in inputs[0] if _dynamic(scenes[0], i)],
    "filter_objects_from_events": lambda var, scenes, graph, inputs, side: _objects(inputs[0]),
    "filter_objects_from_events_list": lambda var, scenes, graph, inputs, side: [_objects(x) for x in inputs[0]],
    "counterfact_events": lambda var, scenes, graph, inputs, side: _counterfact(var, inputs[0]),
    "counterfact_events_list": lambda var, scenes, graph, inputs, side: [_counterfact(var, o) for o in inputs[0]],
    "filter_before": lambda var, scenes, graph, inputs, side: [e for e in inputs[0] if e["step"] < inputs[1]["step"]],
    "filter_after": lambda var, scenes, graph, inputs, side: [e for e in inputs[0] if e["step"] > inputs[1]["step"]],
    "is_before": lambda var, scenes, graph, inputs, side: inputs[0]["step"] < inputs[1]["step"],
    "is_after": lambda var, scenes, graph, inputs, side: inputs[0]["step"] > inputs[1]["step"],
    "as_list": lambda var, scenes, graph, inputs, side: [inputs[0]],
}


class OriginalScene:
    """What the original engine is handed for one video: the dict, the two scene structs, the causal graph."""

    def __init__(self, data: dict[str, Any]) -> None:
        self.data = data
        states = data["original_video_output"]["scene_states"]
        start = next(s for s in states if s["step"] == 0)
        end = next(s for s in states if s["step"] != 0)
        self.scenes = [start["scene"], end["scene"]]
        self.graph = CausalGraph(data["original_video_output"]["causal_graph"])


def answer_question(scene: OriginalScene, program: list[dict[str, Any]]) -> Any:
    """Run a saved program (``value_inputs``) the original's way: copy the nodes, no output cache."""
    nodes = [{"type": n["type"], "inputs": list(n["inputs"]), "side_inputs": list(n.get("value_inputs") or [])}
             for n in program]
    outputs: list[Any] = []
    for node in nodes:
        handler = HANDLERS[node["type"]]
        output = handler(scene.data, scene.scenes, scene.graph, [outputs[i] for i in node["inputs"]],
                         node["side_inputs"])
        outputs.append(output)
        if isinstance(output, str) and output == INVALID:
            break
    return outputs[-1]
