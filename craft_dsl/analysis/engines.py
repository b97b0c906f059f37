"""How much do question answers depend on the physics engine?

For every scene and seed, the same WorldSpec is simulated with two engines (by default pymunk and Box2D).
Every template is instantiated on the first engine's simulation (:func:`craft_dsl.templates.instantiate`,
first valid binding) and the *same* program (same parameters) is run on the second engine's simulation;
the two answers agree if they are equal (INVALID counts as an answer). Per scene, the outcome statistics
of :mod:`craft_dsl.analysis.scene_stats` are computed for both engines side by side.

>>> cmp = compare_engines([3], range(2))          # doctest: +SKIP
>>> print(format_comparison(cmp, markdown=True))  # doctest: +SKIP
"""

from __future__ import annotations

import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..templates import instantiate, templates
from ..types import INVALID
from ..vocabulary import ENGINES
from ..world import DEFAULT_STEPS
from .scene_stats import SceneStats, scene_stats, text_table

#: Template families, in the templates file's order.
CATEGORIES = ("descriptive", "counterfactual", "cause", "enable", "prevent")


def _share(part: int, whole: int) -> float:
    """``part / whole``, nan if ``whole`` is 0."""
    return part / whole if whole else float("nan")


def same_answer(a: Any, b: Any) -> bool:
    """Answers agree if they have the same type and value (INVALID equals only itself)."""
    return type(a) is type(b) and a == b


@dataclass(frozen=True)
class TemplateRow:
    """Agreement of one template over all (scene, seed) pairs where it could be instantiated."""

    template: str
    category: str
    paper: bool  # one of the paper's 48 tasks (not dropped by the original pipeline)
    questions: int  # (scene, seed) pairs with a valid binding on the first engine
    agree: int  # of those, same answer on the second engine
    invalid_b: int  # of those, INVALID on the second engine (the binding's referent is gone there)
    majority: int = 0  # of those, how many have the first engine's most frequent answer (a trivial baseline)

    @property
    def rate(self) -> float:
        """Agreement rate in [0, 1] (nan without questions)."""
        return _share(self.agree, self.questions)

    @property
    def majority_rate(self) -> float:
        """Share of the most frequent answer on the first engine: agreement by always guessing it."""
        return _share(self.majority, self.questions)


@dataclass(frozen=True)
class CategoryRow:
    category: str
    templates: int
    questions: int
    agree: int

    @property
    def rate(self) -> float:
        return _share(self.agree, self.questions)


@dataclass(frozen=True)
class TaskResult:
    """One (scene, seed): per template (asked, agreed, INVALID on B, the first engine's answer as text) and
    both engines' scene statistics."""

    scene: int | str | Path
    seed: int
    answers: dict[str, tuple[bool, bool, bool, str]]
    stats: tuple[SceneStats, SceneStats]
    seconds: float


@dataclass(frozen=True)
class Comparison:
    engines: tuple[str, str]
    scenes: tuple[int | str | Path, ...]
    seeds: tuple[int, ...]
    steps: int
    templates: tuple[TemplateRow, ...]
    scene_rows: tuple[tuple[SceneStats, SceneStats], ...]
    seconds: float = 0.0
    meta: dict[str, Any] = field(default_factory=dict)

    def categories(self, paper_only: bool = False) -> list[CategoryRow]:
        """Per category (and ``all``), pooled over questions."""
        rows = [t for t in self.templates if t.paper or not paper_only]
        out = []
        for cat in (*CATEGORIES, "all"):
            sel = [t for t in rows if cat == "all" or t.category == cat]
            out.append(CategoryRow(cat, len(sel), sum(t.questions for t in sel), sum(t.agree for t in sel)))
        return out

    @property
    def agreement(self) -> float:
        """Pooled agreement over every question of every template."""
        return self.categories()[-1].rate


def compare_task(scene: int | str | Path, seed: int, engines: tuple[str, str] = (ENGINES[0], ENGINES[1]),
                 steps: int = DEFAULT_STEPS, perturb: float = 0.0) -> TaskResult:
    """Simulate one (scene, seed) with both engines and compare every template's answer.

    ``perturb > 0``: the second run starts from the original's perturbation of the world (amount
    ``perturb``, perturbation seed = ``seed``) -- a chaos baseline when both engines are the same."""
    from ..physics.live import get_engine, simulate

    start = time.perf_counter()
    eng_a, eng_b = get_engine(engines[0]), get_engine(engines[1])
    sim_a = simulate(scene, seed=seed, steps=steps, engine=eng_a)
    sim_b = simulate(scene, seed=seed, steps=steps, engine=eng_b)
    if perturb > 0:
        sim_b = sim_b.perturbed(seed, perturb)
    elif sim_a.world != sim_b.world:  # pragma: no cover - the sampler does not know the engine
        raise RuntimeError(f"scene {scene} seed {seed}: the engines were given different worlds")
    answers: dict[str, tuple[bool, bool, bool, str]] = {}
    for tid, template in templates().items():
        inst = instantiate(template, sim_a)
        if inst is None:
            answers[tid] = (False, False, False, "")
            continue
        params, answer_a = inst
        answer_b = template.program(params).run(sim_b)
        answers[tid] = (True, same_answer(answer_a, answer_b), answer_b is INVALID, repr(answer_a))
    # scene_stats passes its scene to simulate(), which also takes the (perturbed) WorldSpec itself
    stats_a = scene_stats(scene, [seed], engine=eng_a, steps=steps)
    stats = (stats_a,
             replace(scene_stats(sim_b.world_spec, [seed], engine=eng_b, steps=steps), scene=stats_a.scene))
    return TaskResult(scene, seed, answers, stats, time.perf_counter() - start)


def _task(args: tuple[int | str | Path, int, tuple[str, str], int, float]) -> TaskResult:
    return compare_task(*args)


def merge_stats(rows: Sequence[SceneStats]) -> SceneStats:
    """Pool per-seed statistics of one scene (weighted like a single :func:`scene_stats` call)."""
    runs = sum(r.runs for r in rows)
    dyn = sum(r.dynamic_objects * r.runs for r in rows)
    elapsed = sum(r.runs / r.sims_per_second for r in rows if r.sims_per_second > 0)
    return SceneStats(
        rows[0].scene, runs, dyn / runs,
        sum(r.basket_share * r.dynamic_objects * r.runs for r in rows) / max(dyn, 1),
        sum(r.ground_share * r.dynamic_objects * r.runs for r in rows) / max(dyn, 1),
        sum(r.events_per_run * r.runs for r in rows) / runs,
        runs / elapsed if elapsed > 0 else float("inf"),
    )


def compare_engines(
    scenes: Iterable[int | str | Path],
    seeds: Iterable[int],
    engines: tuple[str, str] = (ENGINES[0], ENGINES[1]),
    steps: int = DEFAULT_STEPS,
    jobs: int = 1,
    progress: Callable[[TaskResult, int, int], None] | None = None,
    perturb: float = 0.0,
) -> Comparison:
    """Compare two engines over ``scenes`` x ``seeds`` (``jobs`` worker processes; results are the same
    for any ``jobs``). ``progress(result, done, total)`` is called after each (scene, seed).
    ``perturb``: see :func:`compare_task`."""
    scene_list, seed_list = tuple(scenes), tuple(seeds)
    tasks = [(sc, sd, engines, steps, perturb) for sc in scene_list for sd in seed_list]
    start = time.perf_counter()
    results: list[TaskResult] = []

    def collect(it: Iterable[TaskResult]) -> None:
        for res in it:
            results.append(res)
            if progress is not None:
                progress(res, len(results), len(tasks))

    if jobs > 1 and len(tasks) > 1:
        from multiprocessing import get_context

        with get_context("spawn").Pool(jobs) as pool:
            collect(pool.imap(_task, tasks))
    else:
        collect(map(_task, tasks))
    rows = []
    for tid, template in templates().items():
        asked = [r.answers[tid] for r in results if r.answers[tid][0]]
        counts = Counter(a[3] for a in asked)
        rows.append(TemplateRow(tid, template.family, not template.dropped, len(asked),
                                sum(1 for a in asked if a[1]), sum(1 for a in asked if a[2]),
                                max(counts.values(), default=0)))
    scene_rows = []
    for sc in scene_list:
        per = [r for r in results if r.scene == sc]
        if per:
            scene_rows.append((merge_stats([r.stats[0] for r in per]), merge_stats([r.stats[1] for r in per])))
    return Comparison(engines, scene_list, seed_list, steps, tuple(rows), tuple(scene_rows),
                      time.perf_counter() - start, {"perturb": perturb})


# -- formatting --------------------------------------------------------------------------------------


def _pct(x: float) -> str:
    return "-" if x != x else f"{100 * x:.1f}%"


def format_comparison(cmp: Comparison, markdown: bool = False, sections: Sequence[str] = ("summary", "categories",
                      "templates", "scenes")) -> str:
    """The comparison as readable tables (plain text or Markdown)."""
    a, b = cmp.engines
    if cmp.meta.get("perturb"):
        b = f"{b}~{cmp.meta['perturb']:g}"
    parts: list[str] = []
    if "summary" in sections:
        parts.append(f"engines {a} vs {b}: {len(cmp.scenes)} scenes x {len(cmp.seeds)} seeds = "
                     f"{len(cmp.scenes) * len(cmp.seeds)} runs per engine, {cmp.steps} steps; "
                     f"questions instantiated on {a}, re-run on {b}; pooled agreement {_pct(cmp.agreement)}")
    if "categories" in sections:
        all_rows, paper_rows = cmp.categories(), cmp.categories(paper_only=True)
        body = [[r.category, str(r.templates), str(r.questions), _pct(r.rate), str(p.templates), str(p.questions),
                 _pct(p.rate)] for r, p in zip(all_rows, paper_rows)]
        parts.append(text_table(["category", "templates", "questions", "agreement", "paper templates",
                             "paper questions", "paper agreement"], body, markdown))
    if "templates" in sections:
        body = [[t.template, t.category, "yes" if t.paper else "no", str(t.questions), _pct(t.rate),
                 _pct(t.majority_rate), str(t.invalid_b)] for t in cmp.templates]
        parts.append(text_table(["template", "category", "paper", "questions", "agreement", "majority answer",
                             f"INVALID on {b}"], body, markdown))
    if "scenes" in sections:
        body = []
        for sa, sb in cmp.scene_rows:
            body.append([str(sa.scene), str(sa.runs), f"{sa.dynamic_objects:.2f}",
                         f"{sa.basket_share:.2f}", f"{sb.basket_share:.2f}",
                         f"{sa.ground_share:.2f}", f"{sb.ground_share:.2f}",
                         f"{sa.events_per_run:.1f}", f"{sb.events_per_run:.1f}"])
        parts.append(text_table(["scene", "runs", "dynamic", f"basket {a}", f"basket {b}", f"ground {a}",
                             f"ground {b}", f"events/run {a}", f"events/run {b}"], body, markdown))
    return "\n\n".join(parts)


def stderr_progress(res: TaskResult, done: int, total: int) -> None:
    """A one-line progress report per (scene, seed) on stderr."""
    print(f"[{done}/{total}] scene {res.scene} seed {res.seed}: {res.seconds:.2f} s", file=sys.stderr, flush=True)
