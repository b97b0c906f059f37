"""The original CRAFT simulator's own scene sampler against craft_dsl's (``scenes/*.json`` read by
:func:`craft_dsl.scenes.sample_world`), layout by layout.

Run: ``python benchmarks/sampler_compare.py [--runs 200] [--workers 2] [--layouts 1-20] [--out FILE]``.

For each layout, ``--runs`` start states come from the original's sampler (a fresh scene of the built binary, seeded
through ``CRAFT_ORIGINAL_SEED``, seeds ``100000 * layout + k``) and as many from craft_dsl's (seeds ``k``), for
k = ``--first`` (default 0) onwards. Compared:

- categorical, chi-square test of homogeneity (Fisher's exact test for 2x2 tables): the number of objects, every
  static element's shape, every dynamic object's shape, size and colour (matched by creation order) and the pooled
  shapes, sizes and colours of the layout, and per run the number of distinct colours and of distinct
  (shape, colour, size) triples among the dynamic objects;
- continuous, two-sample Kolmogorov-Smirnov test: every coordinate of the basket's and each static element's
  position and angle (platform angles modulo pi: the box is the same turned half a turn), and each dynamic object's
  start position, velocity, angle and spin, matched by creation order. Values are rounded to single precision
  first (the original writes floats); a quantity with at most 12 distinct values in the two samples together
  (a constant, or a choice among a few speeds) is compared as categorical;
- outcomes, two-sided Mann-Whitney U test: per run, the number of dynamic objects that enter the basket, the number
  that collide with the ground, and the number of Collision events. Both sets of start states are simulated by the
  same engine (craft_dsl's default, Box2D, 600 steps), so only the sampler differs.

A difference is listed when its p-value is below 0.05 divided by the number of tests made (Bonferroni); tests whose
two samples are one and the same constant are not counted. The original's samples can be kept in a JSON file
(``--cache``) and read back instead of rerun.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from craft_dsl.physics import simulate
from craft_dsl.physics.original import scene_file
from craft_dsl.physics.original_sampler import sample_original_many, world_from_scene
from craft_dsl.scenes import sample_world
from craft_dsl.vocabulary import COLLISION, ENTER_BASKET
from craft_dsl.world import WorldSpec

ALPHA = 0.05
#: A quantity with at most this many distinct (single-precision) values in both samples is compared as categorical.
FEW_VALUES = 12
OUTCOMES = ("enter", "ground", "collisions")


def original_seed(layout: int, k: int) -> int:
    return 100_000 * layout + k


# -- sampling ------------------------------------------------------------------------------------------------


def original_worlds(layouts: Sequence[int], ks: Sequence[int], workers: int,
                    cache: Path | None) -> dict[int, list[WorldSpec]]:
    """The start states of runs ``ks`` of each layout from the original's sampler (read from ``cache`` where it
    has them)."""
    stored: dict[str, Any] = json.loads(cache.read_text()) if cache is not None and cache.is_file() else {}
    todo = [(layout, original_seed(layout, k)) for layout in layouts for k in ks
            if f"{layout}:{original_seed(layout, k)}" not in stored]
    if todo:
        start = time.perf_counter()
        fresh = sample_original_many(todo, workers=workers)
        print(f"# original sampler: {len(todo)} runs in {time.perf_counter() - start:.0f} s", file=sys.stderr)
        for (layout, seed), world in zip(todo, fresh):
            stored[f"{layout}:{seed}"] = scene_file(world)["scene_states"][0]["scene"]["objects"]
        if cache is not None:
            cache.write_text(json.dumps(stored))
    return {layout: [world_from_scene(stored[f"{layout}:{original_seed(layout, k)}"], layout,
                                      original_seed(layout, k), f"cached layout {layout}")
                     for k in ks]
            for layout in layouts}


def our_worlds(layouts: Sequence[int], ks: Sequence[int]) -> dict[int, list[WorldSpec]]:
    return {layout: [sample_world(layout, k) for k in ks] for layout in layouts}


def outcome(world: WorldSpec) -> tuple[int, int, int]:
    """(objects entering the basket, objects hitting the ground, Collision events) of one 600-step Box2D run."""
    sim = simulate(world, engine="box2d")
    dynamic = set(world.dynamic_uids)
    entered = {o for e in sim.events if e.type == ENTER_BASKET for o in e.objects if o in dynamic}
    collisions = [e for e in sim.events if e.type == COLLISION]
    grounded = {o for e in collisions if sim.ground_id in e.objects for o in e.objects if o in dynamic}
    return len(entered), len(grounded), len(collisions)


def outcomes(worlds: Sequence[WorldSpec], workers: int) -> list[tuple[int, int, int]]:
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(outcome, worlds, chunksize=16))


# -- features ------------------------------------------------------------------------------------------------


def _f32(x: float) -> float:
    return float(np.float32(x))


def _platform_angle(angle: float) -> float:
    """A platform's angle modulo pi, in [-pi/2, pi/2)."""
    return (angle + math.pi / 2) % math.pi - math.pi / 2


def _wrapped(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@dataclass
class Features:
    """Per-run values by name: ``cat`` compared as categories, ``num`` as numbers; ``group`` names each's column."""

    cat: dict[str, list[str]] = field(default_factory=dict)
    num: dict[str, list[float]] = field(default_factory=dict)
    group: dict[str, str] = field(default_factory=dict)

    def add_cat(self, name: str, group: str, value: str) -> None:
        self.cat.setdefault(name, []).append(value)
        self.group[name] = group

    def add_num(self, name: str, group: str, value: float) -> None:
        self.num.setdefault(name, []).append(_f32(value))
        self.group[name] = group


def features(worlds: Sequence[WorldSpec]) -> Features:
    out = Features()
    for world in worlds:
        dynamic = [b for b in world.bodies if b.dynamic]
        static = [b for b in world.bodies if not b.dynamic]
        out.add_cat("objects", "count", str(len(world.bodies)))
        for i, b in enumerate(static):
            name = f"static[{i}]" if b.shape != "basket" else "basket"
            out.add_cat(f"{name}.shape", "static", b.shape)
            out.add_num(f"{name}.x", "static", b.position[0])
            out.add_num(f"{name}.y", "static", b.position[1])
            angle = _platform_angle(b.angle) if b.shape == "platform" else _wrapped(b.angle)
            out.add_num(f"{name}.angle", "static", angle)
        for i, b in enumerate(dynamic):
            out.add_cat(f"dyn[{i}].shape", "shape", b.shape)
            out.add_cat(f"dyn[{i}].size", "size", b.size)
            out.add_cat(f"dyn[{i}].color", "color", b.color)
            out.add_num(f"dyn[{i}].x", "position", b.position[0])
            out.add_num(f"dyn[{i}].y", "position", b.position[1])
            out.add_num(f"dyn[{i}].angle", "position", _wrapped(b.angle))
            out.add_num(f"dyn[{i}].vx", "velocity", b.velocity[0])
            out.add_num(f"dyn[{i}].vy", "velocity", b.velocity[1])
            out.add_num(f"dyn[{i}].spin", "velocity", b.angular_velocity)
        out.add_cat("distinct colours", "distinct", str(len({b.color for b in dynamic})))
        out.add_cat("distinct triples", "distinct", str(len({(b.shape, b.color, b.size) for b in dynamic})))
    return out


def pooled(worlds: Sequence[WorldSpec], attribute: Callable[[Any], str]) -> list[str]:
    return [attribute(b) for w in worlds for b in w.bodies if b.dynamic]


# -- tests ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Test:
    layout: int
    group: str
    name: str
    method: str
    p: float
    detail: str


def categorical(a: Sequence[str], b: Sequence[str]) -> tuple[float, str, str] | None:
    """(p, method, detail) of a test of homogeneity; None when both samples are the one same value."""
    ca, cb = Counter(a), Counter(b)
    cats = sorted(set(ca) | set(cb))
    if len(cats) == 1:
        return None
    table = np.array([[ca[c] for c in cats], [cb[c] for c in cats]])
    if table.shape == (2, 2):
        p = float(stats.fisher_exact(table).pvalue)
        method = "Fisher"
    else:
        p = float(stats.chi2_contingency(table, correction=False).pvalue)
        method = "chi2"
    top = ", ".join(f"{c}: {ca[c]}/{cb[c]}" for c in cats[:10]) + (" ..." if len(cats) > 10 else "")
    return p, method, f"original/ours counts {top}"


def numerical(a: Sequence[float], b: Sequence[float]) -> tuple[float, str, str] | None:
    values = set(a) | set(b)
    if len(values) <= FEW_VALUES:
        if len(values) == 2 and max(values) - min(values) <= 1e-5 * max(1.0, max(abs(v) for v in values)):
            return None  # one constant, written once in single and once in double precision
        found = categorical([f"{v:.6g}" for v in a], [f"{v:.6g}" for v in b])
        return found
    ks = stats.ks_2samp(a, b)
    detail = (f"original {np.min(a):.4g}..{np.max(a):.4g} (median {np.median(a):.4g}), "
              f"ours {np.min(b):.4g}..{np.max(b):.4g} (median {np.median(b):.4g}), D={ks.statistic:.3f}")
    return float(ks.pvalue), "KS", detail


def compare_layout(layout: int, orig: Sequence[WorldSpec], ours: Sequence[WorldSpec],
                   out_orig: Sequence[tuple[int, int, int]] | None,
                   out_ours: Sequence[tuple[int, int, int]] | None) -> list[Test]:
    fa, fb = features(orig), features(ours)
    tests: list[Test] = []
    for name in sorted(set(fa.cat) | set(fb.cat)):
        found = categorical(fa.cat.get(name, []), fb.cat.get(name, []))
        if found is not None:
            tests.append(Test(layout, fa.group.get(name) or fb.group[name], name, found[1], found[0], found[2]))
    for name in sorted(set(fa.num) | set(fb.num)):
        a, b = fa.num.get(name, []), fb.num.get(name, [])
        if not a or not b:
            tests.append(Test(layout, fa.group.get(name) or fb.group[name], name, "present", 0.0,
                              f"only in {'ours' if not a else 'the original'}"))
            continue
        found = numerical(a, b)
        if found is not None:
            tests.append(Test(layout, fa.group.get(name) or fb.group[name], name, found[1], found[0], found[2]))
    for what, attribute in (("shape", lambda b: b.shape), ("size", lambda b: b.size), ("color", lambda b: b.color)):
        found = categorical(pooled(orig, attribute), pooled(ours, attribute))
        if found is not None:
            tests.append(Test(layout, what, f"pooled {what}", found[1], found[0], found[2]))
    if out_orig is not None and out_ours is not None:
        for i, name in enumerate(OUTCOMES):
            a = [o[i] for o in out_orig]
            b = [o[i] for o in out_ours]
            if len(set(a) | set(b)) == 1:
                continue
            p = float(stats.mannwhitneyu(a, b, alternative="two-sided").pvalue)
            tests.append(Test(layout, name, name, "Mann-Whitney", p,
                              f"mean original {np.mean(a):.3f}, ours {np.mean(b):.3f}"))
    return tests


# -- report --------------------------------------------------------------------------------------------------

COLUMNS = ("count", "static", "shape", "size", "color", "distinct", "position", "velocity") + OUTCOMES


def _p(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.0e}" if value < 1e-3 else f"{value:.3f}"


def report(layouts: Sequence[int], runs: int, first: int, tests: Sequence[Test],
           means: dict[int, tuple[np.ndarray, np.ndarray]] | None, seconds: float) -> str:
    threshold = ALPHA / max(1, len(tests))
    lines = [f"Original CRAFT sampler vs craft_dsl sampler: {runs} runs of each per layout (k = {first}.."
             f"{first + runs - 1}: original seeds 100000*layout + k, ours k); {len(tests)} tests; "
             f"Bonferroni threshold p < {threshold:.2e}",
             "Each cell: the smallest p-value of that column's tests for the layout ('-': nothing varies). "
             "Outcomes: both sets simulated by craft_dsl's Box2D engine, 600 steps.", ""]
    header = f"{'layout':>6} " + " ".join(f"{c:>10}" for c in COLUMNS) + "  " + "tests  sig"
    lines.append(header)
    for layout in layouts:
        mine = [t for t in tests if t.layout == layout]
        cells = []
        for column in COLUMNS:
            ps = [t.p for t in mine if t.group == column]
            cells.append(_p(min(ps)) if ps else "-")
        sig = sum(t.p < threshold for t in mine)
        lines.append(f"{layout:>6} " + " ".join(f"{c:>10}" for c in cells) + f"  {len(mine):>5}  {sig:>3}")
    if means is not None:
        lines += ["", "Mean outcomes per run, original sampler / craft_dsl sampler (Box2D engine for both):",
                  f"{'layout':>6} " + " ".join(f"{c:>17}" for c in OUTCOMES)]
        for layout in layouts:
            a, b = means[layout]
            lines.append(f"{layout:>6} " + " ".join(f"{x:>8.3f}/{y:<8.3f}" for x, y in zip(a, b)))
    significant = sorted((t for t in tests if t.p < threshold), key=lambda t: (t.layout, t.p))
    lines += ["", f"Differences significant after Bonferroni (p < {threshold:.2e}): {len(significant)}"]
    for t in significant:
        lines.append(f"  layout {t.layout:>2}  {t.name:<22} {t.method:<12} p={t.p:.2e}  {t.detail}")
    nominal = sorted((t for t in tests if threshold <= t.p < 0.01), key=lambda t: (t.layout, t.p))
    lines += ["", f"Not significant after correction but p < 0.01 (expected by chance about "
                  f"{0.01 * len(tests):.0f}): {len(nominal)}"]
    for t in nominal:
        lines.append(f"  layout {t.layout:>2}  {t.name:<22} {t.method:<12} p={t.p:.2e}  {t.detail}")
    lines += ["", f"wall time {seconds:.0f} s, load average {os.getloadavg()[0]:.1f}"]
    return "\n".join(lines)


def _layouts(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200, help="start states per layout and sampler (default 200)")
    parser.add_argument("--workers", type=int, default=2, help="parallel runs (default 2)")
    parser.add_argument("--layouts", default="1-20", help="layouts, e.g. 1-20 or 2,7,13 (default 1-20)")
    parser.add_argument("--first", type=int, default=0,
                        help="first run number k (default 0; a replication takes fresh seeds from a higher one)")
    parser.add_argument("--no-outcomes", action="store_true", help="compare start states only")
    parser.add_argument("--cache", type=Path, help="JSON file keeping the original's samples between runs")
    parser.add_argument("--out", type=Path, help="also write the report to this file")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    layouts = _layouts(args.layouts)
    ks = range(args.first, args.first + args.runs)
    orig = original_worlds(layouts, ks, args.workers, args.cache)
    ours = our_worlds(layouts, ks)
    results: dict[int, tuple[list[tuple[int, int, int]], list[tuple[int, int, int]]]] = {}
    if not args.no_outcomes:
        t0 = time.perf_counter()
        flat = [w for layout in layouts for w in orig[layout] + ours[layout]]
        done = outcomes(flat, args.workers)
        print(f"# outcomes: {len(flat)} Box2D runs in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
        for i, layout in enumerate(layouts):
            chunk = done[2 * args.runs * i: 2 * args.runs * (i + 1)]
            results[layout] = (chunk[:args.runs], chunk[args.runs:])
    tests: list[Test] = []
    for layout in layouts:
        pair = results.get(layout)
        tests += compare_layout(layout, orig[layout], ours[layout], pair[0] if pair else None,
                                pair[1] if pair else None)
    means = ({layout: (np.mean(results[layout][0], axis=0), np.mean(results[layout][1], axis=0))
              for layout in layouts} if results else None)
    text = report(layouts, args.runs, args.first, tests, means, time.perf_counter() - start)
    print(text)
    if args.out is not None:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
