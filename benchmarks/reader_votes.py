"""Counterfactual votes: what voting over perturbed replays changes in the reader's answers, and what it costs.

Each perceived scene of a folder written by ``craft-dsl read --perceived DIR`` (``<id6>.json``, one per video) is
answered twice in the same run, as ``craft-dsl read`` answers (confidences included): with ``--votes 0`` (the replay
against the perceived run alone) and with ``--votes N`` (default: the reader's). Perception is deterministic, so these
are the answers ``craft-dsl read`` gives with either option. Printed per paper column (C, CF, D) and in all: the
questions, how many are right without and with the votes, the answers the votes changed (wrong to right, right to
wrong, wrong to another wrong), and the answering time per video of each with their ratio. The truth comes from the
dataset's ``dataset_minimal.json``; figures are printed, never asserted.

    python benchmarks/reader_votes.py --perceived DIR --questions Q.json --dataset DATASET [--votes 6]
        [--workers 2] [--json F]

``--questions``: the questions file the read was given (only the records of the videos in ``--perceived`` count).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from craft_dsl.errors import CraftError
from craft_dsl.perception.schema import PerceivedScene
from craft_dsl.question_parsing import match_question
from craft_dsl.reader.answer import Question, answer_questions, read_questions
from craft_dsl.reader.votes import VOTES
from craft_dsl.verify.categories import family_of

COLUMNS = ("C", "CF", "D")


def column_of(text: str) -> str:
    """The paper column (``C``, ``CF``, ``D``) of a question's text, ``?`` where no template matches it."""
    try:
        return family_of(match_question(text).template_id)
    except CraftError:
        return "?"


def answer_both(path: str, questions: list[Question], votes: int) -> dict[str, Any]:
    """One video's answers without and with votes, and the seconds each took (the order alternates by video, so
    neither always runs on a warm cache)."""
    scene = PerceivedScene.model_validate_json(Path(path).read_text(encoding="utf-8"))
    order = (0, votes) if questions[0].video_index % 2 == 0 else (votes, 0)
    answers: dict[int, list[str | None]] = {}
    seconds: dict[int, float] = {}
    for n in order:
        start = time.perf_counter()
        answers[n] = [a.answer for a in answer_questions(scene, questions, votes=n)]
        seconds[n] = time.perf_counter() - start
    return {"plain": answers[0], "voted": answers[votes], "plain_s": seconds[0], "voted_s": seconds[votes]}


def summarize(records: list[dict[str, Any]]) -> dict[str, Counter[str]]:
    """Per column (and ``All``): questions, right without (``plain``) and with (``voted``) votes, and the changes
    (``to_right``, ``to_wrong``, ``to_other``). ``records``: one per question with ``column``, ``truth``, ``plain``,
    ``voted``."""
    out: dict[str, Counter[str]] = defaultdict(Counter)
    for r in records:
        truth = str(r["truth"]).lower()
        plain, voted = str(r["plain"]).lower(), str(r["voted"]).lower()
        for column in (r["column"], "All"):
            c = out[column]
            c["questions"] += 1
            c["plain"] += plain == truth
            c["voted"] += voted == truth
            if plain != voted:
                c["to_right" if voted == truth else "to_wrong" if plain == truth else "to_other"] += 1
    return out


def table(summary: dict[str, Counter[str]], plain_s: float, voted_s: float, videos: int, votes: int) -> str:
    lines = ["| column | questions | right, replay alone | right, voted | changed to right | to wrong | "
             "wrong to wrong |", "|---|---|---|---|---|---|---|"]
    for column in (*COLUMNS, "All"):
        c = summary.get(column, Counter())
        lines.append(f"| {column} | {c['questions']} | {c['plain']} | {c['voted']} | {c['to_right']} | "
                     f"{c['to_wrong']} | {c['to_other']} |")
    per_plain, per_voted = plain_s / max(videos, 1), voted_s / max(videos, 1)
    ratio = per_voted / per_plain if per_plain else float("nan")
    lines.append("")
    lines.append(f"answering, {videos} videos: {per_plain:.3f} s a video with the replay alone, {per_voted:.3f} s "
                 f"with {votes} votes: x{ratio:.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--perceived", required=True, help="a folder of <id6>.json perceived scenes")
    parser.add_argument("--questions", required=True, help="the questions file the read was given")
    parser.add_argument("--dataset", required=True, help="the dataset the videos are from (its answers)")
    parser.add_argument("--votes", type=int, default=VOTES, help=f"perturbed replays (default {VOTES})")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--json", help="write the per-question records and the figures here")
    args = parser.parse_args(argv)
    if args.votes < 1:
        parser.error("--votes must be at least 1 (0 is the baseline this compares with)")
    truth = {(r["video_index"], r["question_index"]): r["answer"]
             for r in json.loads((Path(args.dataset) / "dataset_minimal.json").read_text(encoding="utf-8"))}
    by_video: dict[int, list[Question]] = defaultdict(list)
    for q in read_questions(args.questions):
        by_video[q.video_index].append(q)
    scenes = {int(p.stem): p for p in sorted(Path(args.perceived).glob("[0-9]" * 6 + ".json"))}
    videos = [v for v in sorted(scenes) if v in by_video]
    if not videos:
        print(f"error: no perceived scene in {args.perceived} has questions in {args.questions}", file=sys.stderr)
        return 2
    records: list[dict[str, Any]] = []
    plain_s = voted_s = 0.0
    with ProcessPoolExecutor(args.workers) as pool:
        results = pool.map(answer_both, [str(scenes[v]) for v in videos], [by_video[v] for v in videos],
                           [args.votes] * len(videos))
        for v, result in zip(videos, results):
            plain_s += result["plain_s"]
            voted_s += result["voted_s"]
            for q, plain, voted in zip(by_video[v], result["plain"], result["voted"]):
                records.append({"video_index": v, "question_index": q.question_index, "column": column_of(q.text),
                                "truth": truth.get((v, q.question_index)), "plain": plain, "voted": voted})
    summary = summarize([r for r in records if r["truth"] is not None])
    print(table(summary, plain_s, voted_s, len(videos), args.votes))
    if args.json:
        Path(args.json).write_text(json.dumps({"votes": args.votes, "videos": len(videos), "plain_s": plain_s,
                                               "voted_s": voted_s, "summary": summary, "records": records}, indent=1),
                                   encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
