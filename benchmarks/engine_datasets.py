"""Dataset statistics side by side: folders generated with different engines, beside the paper's figures.

Run (each folder made by ``craft-dsl generate --size 2000 --engine E --out DIR``; ``craft-dsl stats DIR`` writes
the baselines this reads):

    python benchmarks/engine_datasets.py pymunk=DIR1 box2d=DIR2 original=DIR3

Prints Markdown tables: questions per video after each filter (from ``generation_report.json``), the answer
distribution of the final questions per answer type (from ``dataset_minimal.json``), and the heuristic baselines of
both splits (from ``stats/baselines.csv``) beside the paper's.
"""

from __future__ import annotations

import csv
import json
import sys
from collections import Counter
from pathlib import Path
from typing import Any

#: The paper's dataset: 57,524 questions over 9,917 videos.
PAPER_QUESTIONS_PER_VIDEO = 57524 / 9917


def _report(root: Path) -> dict[str, Any]:
    return json.loads((root / "generation_report.json").read_text())


def filters_table(folders: dict[str, Path]) -> str:
    rows = ["| engine | videos | generated | after perturbation | after post-process | final (balanced) |",
            "|---|---|---|---|---|---|"]
    for name, root in folders.items():
        rep = _report(root)
        q, v = rep["questions"], rep["videos"]["total"]
        cells = [f"{q[k] / v:.1f}" for k in ("generated", "after_perturbation", "after_post_process", "final")]
        rows.append(f"| {name} | {v} | " + " | ".join(cells) + " |")
    rows.append(f"| paper | 9,917 | | | | {PAPER_QUESTIONS_PER_VIDEO:.1f} |")
    return "\n".join(rows)


def _answer_row(records: list[dict[str, Any]]) -> str:
    """Boolean True share, the Count answers' distribution, and how many Color and Shape answers."""
    by_type: dict[str, Counter[str]] = {}
    for r in records:
        by_type.setdefault(r["answer_type"], Counter())[str(r["answer"])] += 1
    boolean = by_type.get("Boolean", Counter())
    count = by_type.get("Count", Counter())
    n_count = sum(count.values())
    counts = [count.get(str(k), 0) for k in range(4)]
    counts.append(n_count - sum(counts))
    share = " / ".join(f"{100 * c / n_count:.0f}%" for c in counts) if n_count else "-"
    n_bool = sum(boolean.values())
    true = f"{100 * boolean.get('True', 0) / n_bool:.0f}% of {n_bool}" if n_bool else "-"
    colors, shapes = (sum(by_type.get(t, Counter()).values()) for t in ("Color", "Shape"))
    return f"{len(records)} | {true} | {share} | {colors} | {shapes}"


def answers_table(folders: dict[str, Path]) -> str:
    rows = ["| engine | questions | Boolean: True | Count: 0 / 1 / 2 / 3 / 4+ | Color answers | Shape answers |",
            "|---|---|---|---|---|---|"]
    for name, root in folders.items():
        rows.append(f"| {name} | {_answer_row(json.loads((root / 'dataset_minimal.json').read_text()))} |")
    return "\n".join(rows)


def family_answers_table(folders: dict[str, Path]) -> str:
    """The answers of each template family (C: cause/enable/prevent, CF, D) per engine."""
    from craft_dsl.verify.categories import FAMILIES, family_of

    rows = ["| family | engine | questions | Boolean: True | Count: 0 / 1 / 2 / 3 / 4+ | Color answers | "
            "Shape answers |", "|---|---|---|---|---|---|---|"]
    records = {name: json.loads((root / "dataset_minimal.json").read_text()) for name, root in folders.items()}
    for family in FAMILIES:
        for name, rs in records.items():
            mine = [r for r in rs if family_of(r["template_id"]) == family]
            rows.append(f"| {family} | {name} | {_answer_row(mine)} |")
    return "\n".join(rows)


def baselines_table(folders: dict[str, Path]) -> str:
    head = " | ".join(f"{n} C / CF / D / All" for n in folders)
    rows = [f"| split | baseline | {head} | paper C / CF / D / All |", "|---|---|" + "---|" * (len(folders) + 1)]
    tables = {}
    for name, root in folders.items():
        with (root / "stats" / "baselines.csv").open() as f:
            tables[name] = {(r["split"], r["baseline"]): r for r in csv.DictReader(f)}
    first = next(iter(tables.values()))
    for key, paper in first.items():
        cells = [" / ".join(f"{float(tables[n][key][c]):.1f}" for c in ("C", "CF", "D", "All")) for n in tables]
        ref = " / ".join(f"{float(paper['paper_' + c]):.1f}" for c in ("C", "CF", "D", "All"))
        rows.append(f"| {key[0]} | {key[1]} | " + " | ".join(cells) + f" | {ref} |")
    return "\n".join(rows)


def main() -> None:
    folders = {}
    for arg in sys.argv[1:]:
        name, _, path = arg.partition("=")
        folders[name] = Path(path)
    if not folders:
        raise SystemExit(__doc__)
    print("Questions per video after each filter:\n")
    print(filters_table(folders))
    print("\nAnswers of the final questions:\n")
    print(answers_table(folders))
    print("\nAnswers of the final questions per template family:\n")
    print(family_answers_table(folders))
    print("\nHeuristic baselines, expected test accuracy (%):\n")
    print(baselines_table(folders))


if __name__ == "__main__":
    main()
