"""How exactly and how fast question texts invert to their programs (craft_dsl.question_parsing).

How the questions are made: for every scene layout 1-20 and seeds 0..S-1 (``--seeds``, default 3), one live
pymunk simulation ``simulate(scene, seed)``, then ``generate_questions`` on it with the generator
``numpy.random.default_rng([scene, seed])``: every one of the 67 templates (the 19 basket-collision ones included),
one instance each, paraphrases and synonyms drawn as the original generator draws them. The perturbation filter and
the dataset stages (post-process, balancing) are not run, so this is fast; their texts are the same forms.

Every question text is inverted with ``match_question``. Printed: questions, videos, scenes; the share whose
inverted program gives the recorded answer on the true simulation (target >= 99.9%), the share whose program equals
the saved one (``Program.from_nodes(record["program"])``), the share with the exact template id; every failure with
its text; and speed: questions inverted per second, first pass (empty program cache: every new (template,
parameters) pair builds its program) and later passes (programs cached), beside the speed of
``Program.from_nodes(saved program)`` over the same questions in the same run (the baseline), with the ratios.

    python benchmarks/question_inversion.py [--seeds 3] [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from craft_dsl.dataset.questions import generate_questions
from craft_dsl.physics import simulate
from craft_dsl.program import Program, to_json
from craft_dsl.question_parsing import _automaton, _program, match_question
from craft_dsl.simulation import Simulation


def make_questions(seeds: int) -> list[tuple[Simulation, dict[str, Any]]]:
    out: list[tuple[Simulation, dict[str, Any]]] = []
    for scene in range(1, 21):
        for seed in range(seeds):
            sim = simulate(scene, seed)
            index = scene * 1000 + seed
            records = generate_questions(sim, np.random.default_rng([scene, seed]), video_index=index,
                                         video_filename=f"{index:06d}.mpg")
            out += [(sim, rec) for rec in records]
    return out


def timed(work: Callable[[], object], repeat: int, before: Callable[[], object] = lambda: None) -> float:
    """Median seconds of ``work`` over ``repeat`` runs, ``before`` run untimed ahead of each."""
    times = []
    for _ in range(repeat):
        before()
        start = time.perf_counter()
        work()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="simulations per scene (default 3)")
    parser.add_argument("--repeat", type=int, default=3, help="timing repetitions, median reported (default 3)")
    args = parser.parse_args()

    start = time.perf_counter()
    questions = make_questions(args.seeds)
    made = time.perf_counter() - start
    texts = [rec["question"] for _, rec in questions]
    videos = {rec["video_index"] for _, rec in questions}
    print(f"questions: {len(questions)}  videos: {len(videos)}  scenes: 20  "
          f"templates: {len({rec['template_id'] for _, rec in questions})}  (generated in {made:.1f} s)")

    start = time.perf_counter()
    _automaton()
    print(f"automaton built in {1000 * (time.perf_counter() - start):.1f} ms "
          f"({len(_automaton().transitions)} states, {len(_automaton().paraphrases)} paraphrase forms)")

    answer_ok = program_ok = template_ok = 0
    failures = []
    bindings = set()
    for sim, rec in questions:
        try:
            match = match_question(rec["question"])
        except Exception as err:  # reported below, with the text
            failures.append(f"{rec['template_id']}: {rec['question']!r}: {err}")
            continue
        saved = Program.from_nodes(rec["program"])
        bindings.add((match.template_id, tuple(match.params.items())))
        same_answer = to_json(match.program.run(sim), original=True) == rec["answer"]
        answer_ok += same_answer
        program_ok += match.program == saved
        template_ok += match.template_id == rec["template_id"]
        if not (same_answer and match.program == saved and match.template_id == rec["template_id"]):
            failures.append(f"{rec['template_id']} -> {match.template_id}: {rec['question']!r}")
    n = len(questions)
    print(f"answer on the true simulation equals the recorded answer: {answer_ok}/{n} = {100 * answer_ok / n:.2f}% "
          "(target >= 99.9%)")
    print(f"program equals the saved program: {program_ok}/{n} = {100 * program_ok / n:.2f}%")
    print(f"exact template id: {template_ok}/{n} = {100 * template_ok / n:.2f}%")
    print(f"failures: {len(failures)}")
    for line in failures:
        print(f"  {line}")

    saved_nodes = [rec["program"] for _, rec in questions]
    baseline = timed(lambda: [Program.from_nodes(p) for p in saved_nodes], args.repeat)
    cold = timed(lambda: [match_question(t) for t in texts], args.repeat, before=_program.cache_clear)
    warm = timed(lambda: [match_question(t) for t in texts], args.repeat)
    rate = {name: n / seconds for name, seconds in
            (("baseline", baseline), ("cold", cold), ("warm", warm))}
    print(f"Program.from_nodes(saved program) (baseline): {rate['baseline']:,.0f} questions/s "
          f"({1e6 * baseline / n:.1f} us each)")
    print(f"match_question, first pass ({len(bindings)} distinct programs built): {rate['cold']:,.0f} questions/s "
          f"({1e6 * cold / n:.1f} us each), {rate['cold'] / rate['baseline']:.2f}x the baseline")
    print(f"match_question, programs cached: {rate['warm']:,.0f} questions/s ({1e6 * warm / n:.1f} us each), "
          f"{rate['warm'] / rate['baseline']:.1f}x the baseline")
    return 0 if 100 * answer_ok / n >= 99.9 else 1


if __name__ == "__main__":
    sys.exit(main())
