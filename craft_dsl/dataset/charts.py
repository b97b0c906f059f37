"""Charts of the statistics tables (matplotlib, the ``stats`` extra), written as PNG and SVG.

One chart per table of :mod:`craft_dsl.dataset.stats`; the files carry no date or random ids, so the same
tables give the same SVG bytes.
"""

from __future__ import annotations

import os
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from ..errors import MissingExtraError
from .stats import BASELINES, COLUMNS, EVENT_TYPES, Table

#: Colours of the answer types (as the original's charts grouped them).
TYPE_COLOURS = {"Boolean": "#8dd3c7", "Count": "#e5c494", "Color": "#bebada", "Shape": "#fb8072", "Size": "#80b1d3"}
FORMATS: tuple[str, ...] = ("png", "svg")


def _pyplot() -> Any:
    try:
        import matplotlib
    except ImportError:
        raise MissingExtraError("drawing the charts", "stats", "matplotlib", "or write the CSV tables only: "
                                "--no-charts") from None
    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "craft-dsl"
    import matplotlib.pyplot as plt

    return plt


def _answers_per_category(table: Table, plt: Any) -> Any:
    by_cat: dict[str, list[tuple[str, str, int]]] = defaultdict(list)
    for cat, kind, answer, n in table.rows:
        by_cat[cat].append((answer, kind, n))
    cats = list(by_cat)
    cols = 4
    rows = max(1, (len(cats) + cols - 1) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 2.8 * rows), squeeze=False)
    for ax in axes.flat[len(cats):]:
        ax.axis("off")
    for ax, cat in zip(axes.flat, cats, strict=False):
        items = by_cat[cat]
        ax.bar(range(len(items)), [n for _, _, n in items], color=[TYPE_COLOURS.get(k, "#999999") for _, k, _ in items])
        ax.set_xticks(range(len(items)), [a for a, _, _ in items], rotation=60, fontsize=7)
        ax.set_title(cat, fontsize=10)
    fig.suptitle(table.title)
    return fig


def _answers_per_template(table: Table, plt: Any) -> Any:
    import numpy as np

    tids = list(dict.fromkeys(r[0] for r in table.rows))
    answers = list(dict.fromkeys(r[3] for r in sorted(table.rows, key=lambda r: (r[2], r[3]))))
    grid = np.zeros((len(tids), len(answers)))
    for tid, _cat, _kind, answer, n in table.rows:
        grid[tids.index(tid), answers.index(answer)] = n
    fig, ax = plt.subplots(figsize=(max(6.0, 0.35 * len(answers) + 3), max(4.0, 0.2 * len(tids) + 2)))
    image = ax.imshow(grid, aspect="auto", cmap="viridis")
    ax.set_xticks(range(len(answers)), answers, rotation=70, fontsize=7)
    ax.set_yticks(range(len(tids)), tids, fontsize=6)
    fig.colorbar(image, ax=ax, label="questions")
    ax.set_title(table.title)
    return fig


def _question_types_per_scene(table: Table, plt: Any) -> Any:
    scenes = sorted({r[0] for r in table.rows})
    types = list(dict.fromkeys(r[1] for r in table.rows))
    counts = {(s, t): n for s, t, n in table.rows}
    fig, ax = plt.subplots(figsize=(max(5.0, 0.45 * len(scenes) + 2), 4))
    bottom = [0] * len(scenes)
    for t in types:
        values = [counts.get((s, t), 0) for s in scenes]
        ax.bar([str(s) for s in scenes], values, bottom=bottom, label=t)
        bottom = [b + v for b, v in zip(bottom, values, strict=True)]
    ax.set_xlabel("scene")
    ax.set_ylabel("questions")
    ax.legend(fontsize=8)
    ax.set_title(table.title)
    return fig


def _events_per_video(table: Table, plt: Any) -> Any:
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    totals = [r[-1] for r in table.rows]
    left.hist(totals, bins=min(30, max(1, len(set(totals)))), color="#80b1d3")
    left.set_xlabel("events per video")
    left.set_ylabel("videos")
    by_scene: dict[int, list[tuple[int, ...]]] = defaultdict(list)
    for r in table.rows:
        by_scene[int(r[1])].append(tuple(r[2:2 + len(EVENT_TYPES)]))
    scenes = sorted(by_scene)
    bottom = [0.0] * len(scenes)
    for k, etype in enumerate(EVENT_TYPES):
        means = [sum(v[k] for v in by_scene[s]) / len(by_scene[s]) for s in scenes]
        right.bar([str(s) for s in scenes], means, bottom=bottom, label=etype)
        bottom = [b + m for b, m in zip(bottom, means, strict=True)]
    right.set_xlabel("scene")
    right.set_ylabel("mean events per video")
    right.legend(fontsize=8)
    fig.suptitle(table.title)
    return fig


def _objects_per_scene(table: Table, plt: Any) -> Any:
    scenes = [str(r[0]) for r in table.rows]
    means = [r[3] for r in table.rows]
    low = [r[3] - r[2] for r in table.rows]
    high = [r[4] - r[3] for r in table.rows]
    fig, ax = plt.subplots(figsize=(max(5.0, 0.45 * len(scenes) + 2), 4))
    ax.bar(scenes, means, yerr=[low, high], capsize=3, color="#fdb462")
    ax.set_xlabel("scene")
    ax.set_ylabel("dynamic objects (mean, min-max)")
    ax.set_title(table.title)
    return fig


def _baselines(table: Table, plt: Any) -> Any:
    splits = list(dict.fromkeys(r[0] for r in table.rows))
    fig, axes = plt.subplots(1, len(splits), figsize=(6 * len(splits), 4), squeeze=False)
    width = 0.38
    for ax, split in zip(axes.flat, splits, strict=True):
        rows = {r[1]: r for r in table.rows if r[0] == split}
        xs = range(len(BASELINES))
        ours = [rows[b][2 + COLUMNS.index("All")] or 0.0 for b in BASELINES]
        paper = [rows[b][2 + len(COLUMNS) + 1 + COLUMNS.index("All")] for b in BASELINES]
        ax.bar([x - width / 2 for x in xs], ours, width, label="this dataset", color="#8dd3c7")
        ax.bar([x + width / 2 for x in xs], paper, width, label="paper", color="#bebada", hatch="//")
        ax.set_xticks(list(xs), BASELINES)
        ax.set_ylabel("expected test accuracy, All (%)")
        ax.set_title(f"{split} split" + (" (paper: easy)" if split == "random" else ""))
        ax.legend(fontsize=8)
    fig.suptitle("Heuristic baselines (lower = less answer bias)")
    return fig


DRAWERS: dict[str, Callable[[Table, Any], Any]] = {
    "answers_per_category": _answers_per_category,
    "answers_per_template": _answers_per_template,
    "question_types_per_scene": _question_types_per_scene,
    "events_per_video": _events_per_video,
    "objects_per_scene": _objects_per_scene,
    "baselines": _baselines,
}


def write_charts(tables: Sequence[Table], out: str | os.PathLike[str],
                 formats: Sequence[str] = FORMATS) -> list[Path]:
    """Draw every table that has rows into ``out/<name>.png`` and ``.svg``; returns the files written."""
    plt = _pyplot()
    written: list[Path] = []
    for table in tables:
        drawer = DRAWERS.get(table.name)
        if drawer is None or not table.rows:
            continue
        fig = drawer(table, plt)
        fig.tight_layout()
        for fmt in formats:
            path = Path(out) / f"{table.name}.{fmt}"
            with atomic_path(path) as tmp:
                metadata = {"Date": None} if fmt == "svg" else {"Software": None}
                fig.savefig(tmp, format=fmt, dpi=100, metadata=metadata)
            written.append(path)
        plt.close(fig)
    return written


__all__ = ["DRAWERS", "FORMATS", "TYPE_COLOURS", "write_charts"]
