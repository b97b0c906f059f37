"""How much do question answers, events and end states depend on the physics engine?

For every scene and seed, the same WorldSpec is simulated by a *reference* engine and by each compared engine
(e.g. reference "original", the original CRAFT simulator, against pymunk and Box2D). Every template is
instantiated on the reference's simulation (:func:`craft_dsl.templates.instantiate`, first valid binding) and the
*same* program (same parameters) is run on each compared simulation; answers agree if they are equal (INVALID
counts as an answer). Optionally the reference is also run from the original's 2% perturbation of the start
state: its agreement with itself is the floor that chaos sets.

Besides answers, each compared run's factual events are matched against the reference's (same type, same
objects, steps at most :data:`EVENT_STEP_TOLERANCE` apart, one to one in step order) for collisions between
dynamic objects, ground hits and basket entries, and its end positions are compared body by body.

>>> cmp = compare_engines([3], range(2), engines=("box2d", "pymunk"))   # doctest: +SKIP
>>> print(format_comparison(cmp, markdown=True))                         # doctest: +SKIP
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..simulation import Simulation
from ..templates import instantiate, templates
from ..types import INVALID
from ..verify.categories import CATEGORIES as PAPER_CATEGORIES
from ..verify.categories import FAMILIES, category_of, family_of
from ..vocabulary import COLLISION, ENGINES, ENTER_BASKET, ORIGINAL_ENGINE
from ..world import DEFAULT_STEPS
from .scene_stats import SceneStats, run_outcomes, scene_label, text_table

#: Template families, in the templates file's order.
CATEGORIES = ("descriptive", "counterfactual", "cause", "enable", "prevent")
#: Event kinds matched between runs.
EVENT_KINDS = ("collision", "ground", "basket")
#: Two events match if their steps are at most this far apart (a quarter second at 60 steps per second).
EVENT_STEP_TOLERANCE = 15


def _share(part: int, whole: int) -> float:
    """``part / whole``, nan if ``whole`` is 0."""
    return part / whole if whole else float("nan")


def wilson_halfwidth(part: int, whole: int, z: float = 1.96) -> float:
    """Half the width of the Wilson score interval (95% by default) of the share ``part / whole``."""
    if whole == 0:
        return float("nan")
    p = part / whole
    return z * math.sqrt(p * (1 - p) / whole + z * z / (4 * whole * whole)) / (1 + z * z / whole)


def same_answer(a: Any, b: Any) -> bool:
    """Answers agree if they have the same type and value (INVALID equals only itself)."""
    return type(a) is type(b) and a == b


def default_reference(engines: Sequence[str]) -> str:
    """The original simulator when it is among ``engines``, else the first engine."""
    return ORIGINAL_ENGINE if ORIGINAL_ENGINE in engines else engines[0]


def run_labels(engines: Sequence[str], reference: str, perturb: float) -> tuple[str, ...]:
    """The compared runs' names: every engine but the reference, then ``reference~AMOUNT`` if perturbing.

    With one engine listed twice (``pymunk,pymunk``), the second is compared with the first."""
    others = list(engines)
    others.remove(reference)
    labels = tuple(others)
    return labels + ((f"{reference}~{perturb:g}",) if perturb > 0 else ())


# -- one (scene, seed) --------------------------------------------------------------------------------


@dataclass(frozen=True)
class EventCounts:
    """Events of one kind in the reference run and in a compared run, and how many matched one to one."""

    reference: int
    compared: int
    matched: int


@dataclass(frozen=True)
class TaskResult:
    """One (scene, seed).

    ``answers[template] = (asked, reference answer as text, agree per run, INVALID per run)``; ``events[run][kind]``;
    ``position_errors[run]``: end-position distance (m) of each dynamic body present in both runs; ``stats``: scene
    statistics of the reference, then of each run; ``seconds``: simulation time of the reference, then each run."""

    scene: int | str | Path
    seed: int
    answers: dict[str, tuple[bool, str, tuple[bool, ...], tuple[bool, ...]]]
    events: tuple[dict[str, EventCounts], ...]
    position_errors: tuple[tuple[float, ...], ...]
    stats: tuple[SceneStats, ...]
    seconds: tuple[float, ...]


def event_keys(sim: Simulation) -> dict[str, list[tuple[frozenset[int], int]]]:
    """The events matched between runs, by kind: (objects, step), in step order."""
    out: dict[str, list[tuple[frozenset[int], int]]] = {k: [] for k in EVENT_KINDS}
    for e in sim.events:
        objs = frozenset(e.objects)
        if e.type == ENTER_BASKET:
            out["basket"].append((objs, e.step))
        elif e.type == COLLISION:
            if sim.ground_id in objs:
                out["ground"].append((objs, e.step))
            elif all(o in sim.dynamic_ids for o in objs):
                out["collision"].append((objs, e.step))
    return out


def match_events(ref: list[tuple[frozenset[int], int]], run: list[tuple[frozenset[int], int]],
                 tolerance: int = EVENT_STEP_TOLERANCE) -> int:
    """How many events of ``ref`` and ``run`` pair up one to one (same objects, steps within ``tolerance``),
    pairing greedily in step order with the nearest unused event."""
    used: set[int] = set()
    matched = 0
    for objs, step in ref:
        best, best_gap = -1, tolerance + 1
        for j, (objs2, step2) in enumerate(run):
            gap = abs(step2 - step)
            if j not in used and objs2 == objs and gap < best_gap:
                best, best_gap = j, gap
        if best >= 0:
            used.add(best)
            matched += 1
    return matched


def end_position_errors(ref: Simulation, run: Simulation) -> tuple[float, ...]:
    """Distance between the end positions of each dynamic body present in both runs (ascending id)."""
    out = []
    for o in ref.objects:
        if o.dynamic and run.has_object(o.id):
            (x1, y1), (x2, y2) = o.end.position, run.object(o.id).end.position
            out.append(math.hypot(x1 - x2, y1 - y2))
    return tuple(out)


def _stats_of(sim: Simulation, scene: int | str | Path, seconds: float) -> SceneStats:
    dyn, basket, ground, events = run_outcomes(sim)
    return SceneStats(scene_label(scene), 1, float(dyn), basket / max(dyn, 1), ground / max(dyn, 1), float(events),
                      1 / seconds if seconds > 0 else float("inf"))


def compare_task(scene: int | str | Path, seed: int, engines: Sequence[str] = (ENGINES[0], ENGINES[1]),
                 steps: int = DEFAULT_STEPS, perturb: float = 0.0, reference: str | None = None) -> TaskResult:
    """Simulate one (scene, seed) with every engine and compare each with the reference.

    ``perturb > 0`` adds the reference run from the original's perturbation of the world (amount ``perturb``,
    perturbation seed = ``seed``): the chaos floor."""
    from ..physics.live import simulate

    ref_name = reference or default_reference(engines)
    labels = run_labels(engines, ref_name, perturb)
    seconds = []
    start = time.perf_counter()
    ref = simulate(scene, seed=seed, steps=steps, engine=ref_name)
    seconds.append(time.perf_counter() - start)
    runs: list[Simulation] = []
    for label in labels:
        start = time.perf_counter()
        if "~" in label:
            runs.append(ref.perturbed(seed, perturb))
        else:
            run: Simulation = simulate(scene, seed=seed, steps=steps, engine=label)
            if run.world != ref.world:  # pragma: no cover - the sampler does not know the engine
                raise RuntimeError(f"scene {scene} seed {seed}: the engines were given different worlds")
            runs.append(run)
        seconds.append(time.perf_counter() - start)
    answers: dict[str, tuple[bool, str, tuple[bool, ...], tuple[bool, ...]]] = {}
    for tid, template in templates().items():
        inst = instantiate(template, ref)
        if inst is None:
            answers[tid] = (False, "", (False,) * len(runs), (False,) * len(runs))
            continue
        params, answer = inst
        program = template.program(params)
        others = [program.run(run) for run in runs]
        answers[tid] = (True, repr(answer), tuple(same_answer(answer, b) for b in others),
                        tuple(b is INVALID for b in others))
    ref_keys = event_keys(ref)
    events = []
    for run in runs:
        run_keys = event_keys(run)
        events.append({k: EventCounts(len(ref_keys[k]), len(run_keys[k]), match_events(ref_keys[k], run_keys[k]))
                       for k in EVENT_KINDS})
    stats = tuple(_stats_of(sim, scene, s) for sim, s in zip([ref, *runs], seconds))
    return TaskResult(scene, seed, answers, tuple(events), tuple(end_position_errors(ref, run) for run in runs),
                      stats, tuple(seconds))


def _task(args: tuple[int | str | Path, int, tuple[str, ...], int, float, str]) -> TaskResult:
    return compare_task(*args)


# -- pooled over tasks --------------------------------------------------------------------------------


@dataclass(frozen=True)
class TemplateRow:
    """Agreement of one template over all (scene, seed) pairs where it could be instantiated on the reference.

    ``agree[i]`` / ``invalid[i]``: of those, same answer / INVALID on run ``i``."""

    template: str
    category: str  # template family (descriptive, counterfactual, cause, enable, prevent)
    paper_category: str  # the paper's sub-category (D/2Q ... C/N)
    paper: bool  # one of the paper's 48 tasks (not dropped by the original pipeline)
    questions: int
    agree: tuple[int, ...]
    invalid: tuple[int, ...]
    majority: int = 0  # how many have the reference's most frequent answer (a trivial baseline)

    def rate(self, run: int = 0) -> float:
        """Agreement rate with run ``run`` in [0, 1] (nan without questions)."""
        return _share(self.agree[run], self.questions)

    @property
    def majority_rate(self) -> float:
        """Share of the most frequent answer on the reference: agreement by always guessing it."""
        return _share(self.majority, self.questions)


@dataclass(frozen=True)
class CategoryRow:
    category: str
    templates: int
    questions: int
    agree: tuple[int, ...]

    def rate(self, run: int = 0) -> float:
        return _share(self.agree[run], self.questions)

    def halfwidth(self, run: int = 0) -> float:
        """Half-width of the 95% interval of the agreement with run ``run``."""
        return wilson_halfwidth(self.agree[run], self.questions)


@dataclass(frozen=True)
class Comparison:
    """A reference engine against compared runs (``runs``: engine names, and ``reference~AMOUNT`` for the
    reference's perturbed run) over scenes x seeds."""

    reference: str
    runs: tuple[str, ...]
    scenes: tuple[int | str | Path, ...]
    seeds: tuple[int, ...]
    steps: int
    templates: tuple[TemplateRow, ...]
    results: tuple[TaskResult, ...]
    seconds: float = 0.0
    meta: dict[str, Any] = field(default_factory=dict)

    def categories(self, paper_only: bool = False) -> list[CategoryRow]:
        """Per template family (and ``all``), pooled over questions."""
        rows = [t for t in self.templates if t.paper or not paper_only]
        return [self._pool(cat, [t for t in rows if cat == "all" or t.category == cat])
                for cat in (*CATEGORIES, "all")]

    def paper_categories(self) -> list[CategoryRow]:
        """Over the paper's 48 tasks: its columns C, CF, D, its 11 sub-categories, and ``all``."""
        rows = [t for t in self.templates if t.paper]
        out = [self._pool(fam, [t for t in rows if family_of(t.template) == fam]) for fam in FAMILIES]
        out += [self._pool(cat, [t for t in rows if t.paper_category == cat]) for cat in PAPER_CATEGORIES]
        return out + [self._pool("all", rows)]

    def _pool(self, name: str, rows: Sequence[TemplateRow]) -> CategoryRow:
        agree = tuple(sum(t.agree[i] for t in rows) for i in range(len(self.runs)))
        return CategoryRow(name, len(rows), sum(t.questions for t in rows), agree)

    def agreement(self, run: int = 0) -> float:
        """Pooled agreement with run ``run`` over every question of every template."""
        return self.categories()[-1].rate(run)

    def scene_list(self) -> list[int | str | Path]:
        return [sc for sc in self.scenes if any(r.scene == sc for r in self.results)]

    def scene_rows(self) -> list[tuple[SceneStats, ...]]:
        """Per scene: pooled statistics of the reference, then of each run."""
        out = []
        for sc in self.scene_list():
            per = [r for r in self.results if r.scene == sc]
            out.append(tuple(merge_stats([r.stats[i] for r in per]) for i in range(len(self.runs) + 1)))
        return out

    def scene_agreement(self, scene: int | str | Path, run: int = 0, paper_only: bool = True) -> tuple[int, int]:
        """(agreeing, asked) questions of one scene with run ``run``."""
        paper = {t.template for t in self.templates if t.paper or not paper_only}
        asked = agree = 0
        for r in self.results:
            if r.scene != scene:
                continue
            for tid, (was_asked, _, ok, _) in r.answers.items():
                if was_asked and tid in paper:
                    asked += 1
                    agree += ok[run]
        return agree, asked

    def event_counts(self, run: int = 0, scene: int | str | Path | None = None) -> dict[str, EventCounts]:
        """Events per kind pooled over tasks (of one scene if given)."""
        out = {}
        for kind in EVENT_KINDS:
            sel = [r.events[run][kind] for r in self.results if scene is None or r.scene == scene]
            out[kind] = EventCounts(sum(c.reference for c in sel), sum(c.compared for c in sel),
                                    sum(c.matched for c in sel))
        return out

    def position_errors(self, run: int = 0, scene: int | str | Path | None = None) -> list[float]:
        return [e for r in self.results if scene is None or r.scene == scene for e in r.position_errors[run]]


def event_f1(c: EventCounts) -> float:
    """F1 of the matched events (1 when neither run has any)."""
    total = c.reference + c.compared
    return 1.0 if total == 0 else 2 * c.matched / total


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
    engines: Sequence[str] = (ENGINES[0], ENGINES[1]),
    steps: int = DEFAULT_STEPS,
    jobs: int = 1,
    progress: Callable[[TaskResult, int, int], None] | None = None,
    perturb: float = 0.0,
    reference: str | None = None,
) -> Comparison:
    """Compare engines over ``scenes`` x ``seeds`` (``jobs`` worker processes; results are the same for any
    ``jobs``). ``reference``: the engine questions are instantiated on (default: the original simulator if listed,
    else the first engine). ``progress(result, done, total)`` is called after each (scene, seed).
    ``perturb``: see :func:`compare_task`."""
    engine_list = tuple(engines)
    ref_name = reference or default_reference(engine_list)
    if ref_name not in engine_list:
        raise ValueError(f"the reference engine {ref_name!r} is not among the engines {', '.join(engine_list)}")
    labels = run_labels(engine_list, ref_name, perturb)
    if not labels:
        raise ValueError("nothing to compare: give two engines, or one engine and a perturbation amount")
    scene_list, seed_list = tuple(scenes), tuple(seeds)
    tasks = [(sc, sd, engine_list, steps, perturb, ref_name) for sc in scene_list for sd in seed_list]
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
        counts = Counter(a[1] for a in asked)
        rows.append(TemplateRow(
            tid, template.family, category_of(tid), not template.dropped, len(asked),
            tuple(sum(1 for a in asked if a[2][i]) for i in range(len(labels))),
            tuple(sum(1 for a in asked if a[3][i]) for i in range(len(labels))),
            max(counts.values(), default=0)))
    return Comparison(ref_name, labels, scene_list, seed_list, steps, tuple(rows), tuple(results),
                      time.perf_counter() - start, {"perturb": perturb})


# -- formatting --------------------------------------------------------------------------------------

#: The sections :func:`format_comparison` can print.
SECTIONS = ("summary", "paper", "categories", "events", "templates", "scenes")


def _pct(x: float) -> str:
    return "-" if x != x else f"{100 * x:.1f}%"


def _pct_ci(part: int, whole: int) -> str:
    if whole == 0:
        return "-"
    return f"{100 * part / whole:.1f} ± {100 * wilson_halfwidth(part, whole):.1f}"


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):.2f}" if values else "-"


def format_comparison(cmp: Comparison, markdown: bool = False, sections: Sequence[str] = SECTIONS) -> str:
    """The comparison as readable tables (plain text or Markdown)."""
    ref, runs = cmp.reference, cmp.runs
    parts: list[str] = []
    if "summary" in sections:
        pooled = "; ".join(f"{run} {_pct(cmp.agreement(i))}" for i, run in enumerate(runs))
        parts.append(f"reference {ref} against {', '.join(runs)}: {len(cmp.scenes)} scenes x {len(cmp.seeds)} "
                     f"seeds = {len(cmp.results)} runs per engine, {cmp.steps} steps; questions instantiated on "
                     f"{ref}, re-run on each; pooled answer agreement: {pooled}")
    if "paper" in sections:
        body = [[r.category, str(r.questions), *(_pct_ci(r.agree[i], r.questions) for i in range(len(runs)))]
                for r in cmp.paper_categories()]
        parts.append(text_table(["paper category", "questions", *(f"agreement {run} (%, 95% CI)" for run in runs)],
                                body, markdown))
    if "categories" in sections:
        all_rows, paper_rows = cmp.categories(), cmp.categories(paper_only=True)
        body = [[r.category, str(r.templates), str(r.questions), *(_pct(r.rate(i)) for i in range(len(runs))),
                 str(p.templates), str(p.questions), *(_pct(p.rate(i)) for i in range(len(runs)))]
                for r, p in zip(all_rows, paper_rows)]
        parts.append(text_table(["category", "templates", "questions", *(f"agreement {run}" for run in runs),
                                 "paper templates", "paper questions", *(f"paper agreement {run}" for run in runs)],
                                body, markdown))
    if "events" in sections:
        body = []
        for i, run in enumerate(runs):
            counts = cmp.event_counts(i)
            errors = cmp.position_errors(i)
            body.append([run, *(f"{c.reference}/{c.compared}: {_pct(event_f1(c))}" for c in counts.values()),
                         _median(errors), f"{statistics.fmean(errors):.2f}" if errors else "-"])
        parts.append(text_table(["run", *(f"{k} events {ref}/run: F1" for k in EVENT_KINDS),
                                 "end position error median (m)", "mean (m)"], body, markdown))
    if "templates" in sections:
        body = [[t.template, t.paper_category, "yes" if t.paper else "no", str(t.questions),
                 *(_pct(t.rate(i)) for i in range(len(runs))), _pct(t.majority_rate),
                 *(str(t.invalid[i]) for i in range(len(runs)))] for t in cmp.templates]
        parts.append(text_table(["template", "category", "paper", "questions", *(f"agreement {run}" for run in runs),
                                 "majority answer", *(f"INVALID on {run}" for run in runs)], body, markdown))
    if "scenes" in sections:
        body = []
        for sc, stats in zip(cmp.scene_list(), cmp.scene_rows()):
            row = [str(stats[0].scene), str(stats[0].runs), f"{stats[0].dynamic_objects:.2f}"]
            for i in range(len(runs)):
                agree, asked = cmp.scene_agreement(sc, i)
                f1 = [event_f1(c) for c in cmp.event_counts(i, sc).values()]
                row += [_pct(_share(agree, asked)), _pct(statistics.fmean(f1)),
                        _median(cmp.position_errors(i, sc))]
            row += [f"{s.basket_share:.2f}" for s in stats] + [f"{s.ground_share:.2f}" for s in stats]
            row += [f"{s.events_per_run:.1f}" for s in stats]
            body.append(row)
        names = (ref, *runs)
        head = ["scene", "runs", "dynamic"]
        for run in runs:
            head += [f"answers {run}", f"events F1 {run}", f"end error (m) {run}"]
        head += [f"basket {n}" for n in names] + [f"ground {n}" for n in names] + [f"events/run {n}" for n in names]
        parts.append(text_table(head, body, markdown))
    return "\n\n".join(parts)


def stderr_progress(res: TaskResult, done: int, total: int) -> None:
    """A one-line progress report per (scene, seed) on stderr."""
    print(f"[{done}/{total}] scene {res.scene} seed {res.seed}: {sum(res.seconds):.2f} s of simulation",
          file=sys.stderr, flush=True)
