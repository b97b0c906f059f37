"""How fast :func:`craft_dsl.oracle.run_batch` scores batches of programs, against the original CRAFT engine
measured in the same run (a re-implementation of its executor, benchmarks/original_engine.py).

Three workloads, each printed in programs per second and as a ratio to the original engine's rate:

* **template programs**: every template with a valid instance on each of N live simulations plus E1 (1,228
  programs over 21 simulations by default), fresh (never seen by the oracle), in every form, as one batch
  with one simulation per program; also one ``run_batch`` call per program;
* **sampled, one simulation**: 1,000 prefix token sequences over one simulation, drawn the way a half-trained
  parser samples (see :func:`sample_programs`), for each of several simulations;
* **sampled, many simulations**: S simulations (1,000 by default, loaded from the recorded files in turn, each
  a separate object with its own caches) x 8 sampled programs of one of its questions, as one batch;
* **edited node lists**: every template node list of every simulation, 8 times, 7 of the 8 copies with one
  random edit (a module renamed, an input index changed, an argument dropped: see :func:`edit_nodes`), as one
  batch; also the unedited lists alone and the renamed-module copies alone (an error costs no more than an
  answer: their ratio >= 1);
* **duplicates**: the unedited node lists once, and 8 equal copies of each (other list objects, as a sampler
  gives them) in a row, as one batch: the 8-copy batch's rate over the one-copy batch's (>= 6x: a duplicate
  costs nearly nothing); also the same list object 8 times.

The original engine runs the node lists of the sampled programs that type-check and return an answer type (it
has no checker: the others are given to it for free); its rate is those programs per second. Our rate is the
whole batch's programs per second, errors included. Simulations' own caches (event filters) are emptied
before every timed pass; recorded files carry their counterfactual runs, which both engines read.

    python benchmarks/oracle_batch.py [--sims 20] [--sampled-sims 1000] [--repeat 5] [--json OUT]
    python benchmarks/oracle_batch.py --hash-seeds 5

The ratios depend on the interpreter's string hashing (``PYTHONHASHSEED``, random per process unless set: it orders
the sets and dicts both engines iterate, hence how soon the original stops at an INVALID and how our tables lay
out); on one machine the 1,000 x 8 ratio ran from 7.8x to 9.9x over four hash seeds. ``--hash-seeds N`` runs the
whole benchmark once per hash seed 1..N, each in its own process, and prints each target's median, lowest and
highest ratio over them.

Targets: sampled on one simulation >= 20x, 1,000 simulations x 8 >= 8x, fresh template programs as node lists
>= 3x, as tokens and text >= 2x, edited node lists >= 8x, errors / answers >= 1, 8 copies / one copy >= 6x.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from oracle_speed import recorded, same
from original_engine import OriginalScene, answer_question

from craft_dsl import CraftError, Program, Simulation, load_simulation
from craft_dsl.oracle import run_batch
from craft_dsl.oracle.outcome import check_outcome
from craft_dsl.registry import REGISTRY
from craft_dsl.templates import first_instances
from craft_dsl.tokens import program_vocabulary
from craft_dsl.vocabulary import COLORS, SHAPES, SIZES

#: Share of samples that are the gold program unchanged, and how many token edits the others get.
P_GOLD = 0.7
EDITS = ((1, 0.7), (2, 0.3))


def _token_kinds() -> dict[str, list[str]]:
    vocab = program_vocabulary()
    kinds: dict[str, list[str]] = {"color": list(COLORS), "shape": list(SHAPES), "size": list(SIZES),
                                   "integer": ["0", "-1"]}
    words = {w for ws in kinds.values() for w in ws}
    kinds["module"] = [t for t in vocab if t not in words]
    return kinds


KINDS = _token_kinds()
KIND_OF = {t: k for k, ts in KINDS.items() for t in ts}
VOCABULARY = program_vocabulary()


def sample_programs(gold: Sequence[str], n: int, rng: random.Random) -> list[list[str]]:
    """``n`` token sequences as a half-trained parser samples them for one question: the gold sequence with
    probability :data:`P_GOLD`, else the gold with 1 (70%) or 2 (30%) random edits, each at a uniformly drawn
    position: a token of the same kind (a module for a module, a colour for a colour...) 60%, any vocabulary
    token 20%, a deleted token 10%, an inserted vocabulary token 10%."""
    out = []
    for _ in range(n):
        tokens = list(gold)
        if rng.random() >= P_GOLD:
            edits = 1 if rng.random() < EDITS[0][1] else 2
            for _ in range(edits):
                pos = rng.randrange(len(tokens))
                op = rng.random()
                if op < 0.6:
                    tokens[pos] = rng.choice(KINDS[KIND_OF[tokens[pos]]])
                elif op < 0.8:
                    tokens[pos] = rng.choice(VOCABULARY)
                elif op < 0.9 and len(tokens) > 1:
                    del tokens[pos]
                else:
                    tokens.insert(pos, rng.choice(VOCABULARY))
        out.append(tokens)
    return out


#: The edits of :func:`edit_nodes`.
NODE_EDITS = ("rename", "input", "drop")


def edit_nodes(nodes: Sequence[dict[str, Any]], edit: str, rng: random.Random) -> list[dict[str, Any]]:
    """A copy of a node list with one random edit at a uniformly drawn node: ``rename`` its module to another
    module's name, ``input`` changes one of its input indexes to another index below the list's length, ``drop``
    deletes one of its arguments (an input or a side input; a node with none is renamed instead)."""
    out = [dict(node, inputs=list(node["inputs"]), value_inputs=list(node.get("value_inputs", [])))
           for node in nodes]
    node = out[rng.randrange(len(out))]
    args = [("inputs", k) for k in range(len(node["inputs"]))] + [
        ("value_inputs", k) for k in range(len(node["value_inputs"]))]
    if edit == "input" and node["inputs"] and len(out) > 1:
        k = rng.randrange(len(node["inputs"]))
        node["inputs"][k] = rng.choice([j for j in range(len(out)) if j != node["inputs"][k]])
    elif edit == "drop" and args:
        key, k = rng.choice(args)
        del node[key][k]
    else:
        node["type"] = rng.choice([name for name in MODULE_NAMES if name != node["type"]])
    return out


MODULE_NAMES = sorted(REGISTRY)


def clear_caches(sims: Sequence[Simulation]) -> None:
    """Empty the event-filter memos of the simulations and their counterfactual runs (kept: the runs)."""
    for sim in {id(s): s for s in sims}.values():
        sim.memo.clear()
        for cf in sim._cf_cache.values():
            cf.memo.clear()


Path_ = tuple[Callable[[], Any], Callable[[], None] | None]


def best_times(paths: dict[str, Path_], repeat: int) -> dict[str, float]:
    """The best time of every path over ``repeat`` rounds. The paths take turns within each round, so that a
    machine busy with other work slows them alike; a path's ``before`` (untimed) runs before each of its turns."""
    best = dict.fromkeys(paths, float("inf"))
    for _ in range(repeat):
        for label, (fn, before) in paths.items():
            if before is not None:
                before()
            t0 = time.perf_counter()
            fn()
            best[label] = min(best[label], time.perf_counter() - t0)
    return best


def original_nodes(programs: Sequence[Sequence[str]]) -> list[list[dict[str, Any]] | None]:
    """The node list of every sample that type-checks to an answer (None for the others)."""
    out: list[list[dict[str, Any]] | None] = []
    for tokens in programs:
        _outcome, program = check_outcome(list(tokens), "prefix")
        try:
            out.append(None if program is None else program.to_nodes())
        except CraftError:  # an integer literal (FilterMoving(..., 0)): the original's node lists have none
            out.append(None)
    return out


def run_original(scene: OriginalScene, nodes: list[dict[str, Any]]) -> Any:
    """The original engine's answer; a program it fails on (FilterObjectsFromEvents of the Start event, ...)
    counts as run."""
    try:
        return answer_question(scene, nodes)
    except (IndexError, AssertionError, KeyError, TypeError):
        return None


def row(label: str, n: int, seconds: float, base: float, target: float | None = None) -> None:
    rate = n / seconds
    goal = f">= {target:g}x" if target else ""
    print(f"  {label:44} {rate:11,.0f} {rate / base:9.2f}x  {goal}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sims", type=int, default=20, help="live simulations to record besides E1 (default 20)")
    ap.add_argument("--sampled-sims", type=int, default=1000, help="simulations of the many-simulation batch")
    ap.add_argument("--samples", type=int, default=1000, help="programs of the one-simulation batch")
    ap.add_argument("--one-sim-batches", type=int, default=21,
                    help="simulations to draw one-simulation batches on (default 21: all)")
    ap.add_argument("--repeat", type=int, default=5, help="passes per measurement; the best is kept (default 5)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", help="write the ratios the targets are about here")
    ap.add_argument("--hash-seeds", type=int, default=0,
                    help="run the benchmark once per PYTHONHASHSEED 1..N (own processes) and summarise the ratios")
    args = ap.parse_args()
    if args.hash_seeds:
        return over_hash_seeds(args)
    figures: dict[str, float] = {}
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        datas = recorded(args.sims, Path(tmp))
    sims = [load_simulation(d) for d in datas]
    scenes = [OriginalScene(d) for d in datas]
    questions: list[list[Program]] = [[p for _t, _p, p, _a in first_instances(s, include_dropped=True)] for s in sims]

    # -- template programs -----------------------------------------------------------------------------------
    items = [(sim, scene, p) for sim, scene, ps in zip(sims, scenes, questions) for p in ps]
    work_sims = [sim for sim, _s, _p in items]
    nodes = [p.to_nodes() for _s, _sc, p in items]
    forms: dict[str, list[Any]] = {
        "nodes": nodes, "prefix": [p.to_tokens("prefix") for *_x, p in items],
        "postfix": [p.to_tokens("postfix") for *_x, p in items], "text": [str(p) for *_x, p in items]}
    for (sim, scene, p), n_list in zip(items, nodes):
        assert same(p.run(sim), answer_question(scene, n_list)), str(p)
    for form, programs in forms.items():  # the batch agrees with the original before anything is timed
        result = run_batch(programs, work_sims, form=form)  # type: ignore[arg-type]
        assert result.counts()["answer"] == len(items), form
        for (_sim, scene, _p), n_list, answer in zip(items, nodes, result.answers):
            assert same(answer, answer_question(scene, n_list)), form
    n = len(items)
    print(f"template programs: {n} over {len(sims)} simulations, best of {args.repeat} interleaved passes")
    print(f"  {'path':44} {'programs/s':>11} {'x original':>10}")
    paths: dict[str, Path_] = {"original engine (node lists)": (
        lambda: [answer_question(scene, n_list) for (_s, scene, _p), n_list in zip(items, nodes)], None)}
    fresh = lambda: clear_caches(work_sims)  # noqa: E731
    for form, programs in forms.items():
        paths[f"run_batch, fresh {form}, one batch"] = (
            lambda programs=programs, form=form: run_batch(programs, work_sims, form=form), fresh)  # type: ignore[misc]
    for form in ("nodes", "prefix", "text"):
        paths[f"run_batch, fresh {form}, one call each"] = (
            lambda programs=forms[form], form=form: [  # type: ignore[misc]
                run_batch([p], s, form=form) for p, s in zip(programs, work_sims)], fresh)
    times = best_times(paths, args.repeat)
    base = n / times["original engine (node lists)"]
    for label, t in times.items():
        form = label.split()[2].rstrip(",") if label.endswith("one batch") else ""
        figure = f"fresh {form}, one batch"
        row(label, n, t, base, target_of(figure) if form else None)
        if form:
            figures[figure] = n / t / base

    # -- sampled, one simulation ---------------------------------------------------------------------------------
    print(f"\nsampled prefix tokens, one simulation: {args.samples} programs per batch; (a) samples of all the "
          "simulation's questions, (b) samples of one question")
    print(f"  {'simulation':30} {'(a) programs/s':>15} {'x original':>10} {'distinct':>9} {'not answers':>12}   "
          f"{'(b) x original':>14} {'distinct':>9}")
    ratios: dict[str, list[float]] = {"a": [], "b": []}
    for k in range(min(args.one_sim_batches, len(sims))):
        sim, scene = sims[k], scenes[k]
        golds = [p.to_tokens("prefix") for p in questions[k]]
        row_out = []
        for variant in ("a", "b"):
            if variant == "a":
                batch = [sample_programs(rng.choice(golds), 1, rng)[0] for _ in range(args.samples)]
            else:
                batch = sample_programs(rng.choice(golds), args.samples, rng)
            orig = [x for x in original_nodes(batch) if x is not None]
            result = run_batch(batch, sim, form="prefix")
            times = best_times({
                "original": (lambda orig=orig, scene=scene: [run_original(scene, x) for x in orig], None),  # type: ignore[misc]
                "ours": (lambda batch=batch, sim=sim: run_batch(batch, sim, form="prefix"),  # type: ignore[misc]
                         lambda sim=sim: clear_caches([sim]))}, args.repeat)  # type: ignore[misc]
            ours, theirs = len(batch) / times["ours"], len(orig) / times["original"]
            ratios[variant].append(ours / theirs)
            row_out.append((ours, ours / theirs, len({tuple(b) for b in batch}),
                            1 - result.counts()["answer"] / len(batch)))
        (a_rate, a_ratio, a_distinct, a_not), (_b_rate, b_ratio, b_distinct, _b_not) = row_out
        print(f"  {k:<3} ({len(golds)} questions){'':13} {a_rate:15,.0f} {a_ratio:9.2f}x {a_distinct:9} "
              f"{a_not:12.0%}   {b_ratio:13.2f}x {b_distinct:9}")
    for variant, values in ratios.items():
        values.sort()
        print(f"  ({variant}) median {values[len(values) // 2]:.2f}x, lowest {values[0]:.2f}x, highest "
              f"{values[-1]:.2f}x   target >= 20x")
        figures[f"one simulation ({variant}), median"] = values[len(values) // 2]

    # -- sampled, many simulations ---------------------------------------------------------------------------------
    s_count = args.sampled_sims
    print(f"\nsampled prefix tokens, {s_count} simulations x 8 programs (loading the simulations...)")
    many_sims: list[Simulation] = []
    many_scenes: list[OriginalScene] = []
    sampled: list[list[str]] = []
    prog_sims: list[Simulation] = []
    prog_scenes: list[OriginalScene] = []
    for k in range(s_count):
        j = k % len(datas)
        sim = load_simulation(datas[j])
        scene = OriginalScene(datas[j])
        many_sims.append(sim)
        many_scenes.append(scene)
        gold = rng.choice(questions[j]).to_tokens("prefix")
        for tokens in sample_programs(gold, 8, rng):
            sampled.append(tokens)
            prog_sims.append(sim)
            prog_scenes.append(scene)
    orig_work = [(scene, x) for scene, x in zip(prog_scenes, original_nodes(sampled)) if x is not None]
    result = run_batch(sampled, prog_sims, form="prefix")
    times = best_times({
        "original": (lambda: [run_original(scene, x) for scene, x in orig_work], None),
        "ours": (lambda: run_batch(sampled, prog_sims, form="prefix"), lambda: clear_caches(many_sims))},
        args.repeat)
    ours, theirs = len(sampled) / times["ours"], len(orig_work) / times["original"]
    counts = result.counts()
    print(f"  {len(sampled)} programs, {len({tuple(p) for p in sampled})} distinct, "
          f"{1 - counts['answer'] / len(sampled):.0%} not answers")
    print(f"  original engine: {theirs:,.0f} programs/s   run_batch: {ours:,.0f} programs/s   "
          f"{ours / theirs:.2f}x   target >= 8x")
    figures[f"{s_count} simulations x 8"] = ours / theirs
    edited_workloads(args, rng, sims, scenes, questions, figures)
    if args.json:
        Path(args.json).write_text(json.dumps({"hash_seed": os.environ.get("PYTHONHASHSEED"), "ratios": figures,
                                               "targets": {k: target_of(k) for k in figures}}, indent=1))
    return 0


def edited_workloads(args: argparse.Namespace, rng: random.Random, sims: Sequence[Simulation],
                     scenes: Sequence[OriginalScene], questions: Sequence[Sequence[Program]],
                     figures: dict[str, float]) -> None:
    """The edited node lists and duplicates workloads (see the module docstring)."""
    gold: list[tuple[Simulation, OriginalScene, list[dict[str, Any]]]] = [
        (sim, scene, p.to_nodes()) for sim, scene, ps in zip(sims, scenes, questions) for p in ps]
    edited: list[tuple[Simulation, OriginalScene, list[dict[str, Any]], str]] = []
    for sim, scene, nodes in gold:
        edited.append((sim, scene, nodes, "none"))
        edited.extend((sim, scene, edit_nodes(nodes, e, rng), e) for e in (rng.choice(NODE_EDITS) for _ in range(7)))
    batch = [x[2] for x in edited]
    batch_sims = [x[0] for x in edited]
    result = run_batch(batch, batch_sims, form="nodes")
    orig_work = [(scene, nodes) for (_s, scene, nodes, _e), code in zip(edited, result.kinds)
                 if code in ("answer", "invalid")]
    once = [x[2] for x in gold]
    once_sims = [x[0] for x in gold]
    eight = [copy.deepcopy(n) for n in once for _ in range(8)]  # equal lists, other objects (as sampled)
    same = [n for n in once for _ in range(8)]
    eight_sims = [s for s in once_sims for _ in range(8)]
    renamed = [x[2] for x in edited if x[3] == "rename"]
    renamed_sims = [x[0] for x in edited if x[3] == "rename"]
    fresh = lambda: clear_caches(sims)  # noqa: E731
    times = best_times({
        "original": (lambda: [run_original(scene, x) for scene, x in orig_work], None),
        "edited": (lambda: run_batch(batch, batch_sims, form="nodes"), fresh),
        "once": (lambda: run_batch(once, once_sims, form="nodes"), fresh),
        "eight": (lambda: run_batch(eight, eight_sims, form="nodes"), fresh),
        "same": (lambda: run_batch(same, eight_sims, form="nodes"), fresh),
        "renamed": (lambda: run_batch(renamed, renamed_sims, form="nodes"), fresh)}, args.repeat)
    base = len(orig_work) / times["original"]
    rates = {"edited": len(batch) / times["edited"], "once": len(once) / times["once"],
             "eight": len(eight) / times["eight"], "same": len(same) / times["same"],
             "renamed": len(renamed) / times["renamed"]}
    counts = result.counts()
    print(f"\nedited node lists: {len(gold)} template node lists x 8, 7 of 8 edited; {len(batch)} programs, "
          f"{counts['answer'] + counts['invalid']} valid; best of {args.repeat} interleaved passes")
    print(f"  {'path':44} {'programs/s':>11} {'x original':>10}")
    row("original engine (valid node lists)", len(orig_work), times["original"], base)
    row("run_batch, edited node lists", len(batch), times["edited"], base, target_of("edited node lists"))
    row("run_batch, unedited, one copy", len(once), times["once"], base)
    row("run_batch, unedited, 8 equal copies each", len(eight), times["eight"], base)
    row("run_batch, unedited, the same list 8 times", len(same), times["same"], base)
    row("run_batch, renamed-module copies only", len(renamed), times["renamed"], base)
    figures["edited node lists"] = rates["edited"] / base
    figures["errors / answers"] = rates["renamed"] / rates["once"]
    figures["8 copies / one copy"] = rates["eight"] / rates["once"]
    print(f"  renamed-module copies / unedited: {figures['errors / answers']:.2f}   target >= 1")
    print(f"  8 copies / one copy: {figures['8 copies / one copy']:.2f}x   target >= 6x   (the same list 8 times: "
          f"{rates['same'] / rates['once']:.2f}x)")


def target_of(figure: str) -> float | None:
    """The issue's target for one of the printed ratios (None: a case of our own, (a))."""
    if figure.startswith("fresh "):
        return 3.0 if figure.startswith("fresh nodes") else 2.0
    if figure.startswith("one simulation (b)"):
        return 20.0
    if figure.endswith("simulations x 8") or figure == "edited node lists":
        return 8.0
    if figure == "errors / answers":
        return 1.0
    if figure == "8 copies / one copy":
        return 6.0
    return None


def over_hash_seeds(args: argparse.Namespace) -> int:
    """The whole benchmark once per hash seed 1..``args.hash_seeds``, one after another in child processes; each
    seed's ratios, then per ratio its median, lowest and highest against its target."""
    forwarded = ["--sims", str(args.sims), "--sampled-sims", str(args.sampled_sims), "--samples", str(args.samples),
                 "--one-sim-batches", str(args.one_sim_batches), "--repeat", str(args.repeat), "--seed", str(args.seed)]
    runs: list[dict[str, float]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for hash_seed in range(1, args.hash_seeds + 1):
            out = Path(tmp) / f"{hash_seed}.json"
            env = {**os.environ, "PYTHONHASHSEED": str(hash_seed)}
            subprocess.run([sys.executable, __file__, *forwarded, "--json", str(out)], env=env, check=True,
                           stdout=subprocess.DEVNULL)
            ratios = json.loads(out.read_text())["ratios"]
            runs.append(ratios)
            print(f"PYTHONHASHSEED={hash_seed}: " + ", ".join(f"{k} {v:.2f}x" for k, v in ratios.items()), flush=True)
    print(f"\nover {len(runs)} hash seeds, best of {args.repeat} passes each")
    print(f"  {'ratio':40} {'median':>8} {'lowest':>8} {'highest':>8}  target")
    summary: dict[str, dict[str, float | None]] = {}
    for key in runs[0]:
        values = sorted(r[key] for r in runs)
        median = statistics.median(values)
        target = target_of(key)
        verdict = "" if target is None else f">= {target:g}x: " + (
            "met by every seed" if values[0] >= target else "met at the median" if median >= target else "not met")
        print(f"  {key:40} {median:7.2f}x {values[0]:7.2f}x {values[-1]:7.2f}x  {verdict}")
        summary[key] = {"median": median, "lowest": values[0], "highest": values[-1], "target": target}
    if args.json:
        Path(args.json).write_text(json.dumps({"hash_seeds": len(runs), "runs": runs, "summary": summary}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
