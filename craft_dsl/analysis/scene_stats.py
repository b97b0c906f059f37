"""Scene statistics over seeds: how often bodies reach the basket and the ground, events per run, speed."""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from ..physics.engine import PhysicsEngine
from ..physics.live import get_engine, simulate
from ..simulation import Simulation
from ..vocabulary import COLLISION, DEFAULT_ENGINE, ENTER_BASKET, ORIGINAL_ENGINE
from ..world import DEFAULT_STEPS, WorldSpec


@dataclass(frozen=True)
class SceneStats:
    """Averages over ``runs`` seeds of one scene."""

    #: The scene id, or the layout file's name.
    scene: int | str
    runs: int
    dynamic_objects: float  # mean dynamic objects per run
    basket_share: float  # share of dynamic objects with an EnterBasket
    ground_share: float  # share of dynamic objects with a Collision with the ground
    events_per_run: float  # mean events per run (Start and End included)
    sims_per_second: float

    @property
    def degenerate(self) -> bool:
        """Nothing ever reaches the basket the layout is built around."""
        return self.basket_share == 0.0


def scene_label(scene: int | str | Path | WorldSpec) -> int | str:
    """How a table names a scene: its id, a layout file's name, or a WorldSpec's scene id (0 if it has none)."""
    if isinstance(scene, int):
        return scene
    if isinstance(scene, (str, Path)):
        return Path(scene).stem
    return scene.scene_id or 0


def run_outcomes(sim: Simulation) -> tuple[int, int, int, int]:
    """One run's dynamic objects, those entering the basket, those hitting the ground (a Collision with it), and
    its events (Start and End included)."""
    basket = len({e.objects[1] for e in sim.events if e.type == ENTER_BASKET})
    ground = len({o for e in sim.events if e.type == COLLISION and sim.ground_id in e.objects
                  for o in e.objects if o in sim.dynamic_ids})
    return len(sim.dynamic_ids), basket, ground, len(sim.events)


def scene_stats(scene: int | str | Path | WorldSpec, seeds: Iterable[int], engine: str | PhysicsEngine = DEFAULT_ENGINE,
                steps: int = DEFAULT_STEPS) -> SceneStats:
    """Averages over ``seeds`` of a scene (an id, a layout file, or one concrete WorldSpec); ``engine`` may also be
    "original", the original simulator."""
    eng: str | PhysicsEngine = engine if engine == ORIGINAL_ENGINE else get_engine(engine)
    runs = dyn = basket = ground = events = 0
    start = time.perf_counter()
    for seed in seeds:
        sim = simulate(scene, seed=seed, steps=steps, engine=eng)
        runs += 1
        d, b, g, e = run_outcomes(sim)
        dyn, basket, ground, events = dyn + d, basket + b, ground + g, events + e
    elapsed = time.perf_counter() - start
    if runs == 0:
        raise ValueError("scene_stats needs at least one seed")
    return SceneStats(scene_label(scene), runs, dyn / runs, basket / max(dyn, 1), ground / max(dyn, 1), events / runs,
                      runs / elapsed if elapsed > 0 else float("inf"))


def format_table(rows: Iterable[SceneStats], markdown: bool = False) -> str:
    """A table of scene statistics (Markdown or aligned plain text)."""
    head = ["scene", "runs", "dynamic", "basket", "ground", "events/run", "sims/s", "note"]
    body = [[str(r.scene), str(r.runs), f"{r.dynamic_objects:.2f}", f"{r.basket_share:.2f}",
             f"{r.ground_share:.2f}", f"{r.events_per_run:.1f}", f"{r.sims_per_second:.1f}",
             "DEGENERATE: no basket entry" if r.degenerate else ""] for r in rows]
    return text_table(head, body, markdown)


def text_table(head: list[str], body: list[list[str]], markdown: bool = False) -> str:
    """A table as Markdown or as right-aligned plain-text columns."""
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(row) + " |" for row in body]
        return "\n".join(lines)
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    return "\n".join("  ".join(x.rjust(w) for x, w in zip(row, widths)).rstrip() for row in [head, *body])
