"""Hugging Face files of a dataset folder: JSONL and Parquet per split and a dataset card.

``write_hf(folder)`` writes, under the dataset folder,

* ``hf/<split>/<part>.jsonl`` for the splits ``random`` (the paper's easy split) and ``hard`` and the parts
  ``train``, ``validation``, ``test``: one question per line (:data:`FEATURES`);
* ``hf/<split>/<part>.parquet``, the same rows, when pyarrow is installed (the ``hf`` extra);
* ``README.md``, the dataset card: YAML front matter with the ``configs:`` section (one config per split, its
  data files per part, Parquet when written, else JSONL) and the features of ``dataset_info``, then the counts,
  the generation settings, the statistics and the heuristic baselines.

so that ``datasets.load_dataset(folder, "random")`` (or ``"hard"``) loads it offline with these features. Rows
are in ``dataset_minimal.json`` order; the same folder gives the same bytes.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..atomic import atomic_path
from ..errors import CraftError, MissingExtraError
from .folder import PARTS, SPLITS, DatasetFolder, as_recorded
from .layout import frame_relpath

HF_FOLDER = "hf"
CARD = "README.md"

#: The columns of every row: (name, Hugging Face dtype). ``program_nodes`` is a list of
#: ``{"type", "inputs", "value_inputs"}`` (the CLEVR/CRAFT node list without cached outputs).
FEATURES: tuple[tuple[str, str], ...] = (
    ("video_index", "int64"),
    ("question_index", "int64"),
    ("question", "string"),
    ("answer", "string"),
    ("answer_type", "string"),
    ("question_type", "string"),
    ("category", "string"),
    ("family", "string"),
    ("template_id", "string"),
    ("template_filename", "string"),
    ("question_family_index", "int64"),
    ("simulation_id", "string"),
    ("video_file_path", "string"),
    ("first_frame_path", "string"),
    ("last_frame_path", "string"),
    ("program", "string"),
    ("program_nodes", "nodes"),
)


@dataclass(frozen=True)
class HfResult:
    """What :func:`write_hf` wrote: files (relative to the folder), rows per split and part, Parquet or not."""

    files: tuple[str, ...]
    counts: dict[str, dict[str, int]]
    parquet: bool


def _program_text(nodes: Sequence[Mapping[str, Any]], where: str) -> str:
    from ..program import Program

    try:
        return str(Program.from_nodes(nodes))
    except CraftError as err:
        raise CraftError(f"{where}: program: {err}") from None


def rows(folder: DatasetFolder) -> list[dict[str, Any]]:
    """One row per question (see :data:`FEATURES`), in ``dataset_minimal.json`` order."""
    programs = folder.programs
    out = []
    for rec in folder.records:
        key = (int(rec["video_index"]), int(rec["question_index"]))
        out.append(row(rec, programs.get(key, []), folder.video_relpath(rec)))
    return out


def row(rec: Mapping[str, Any], nodes: Sequence[Mapping[str, Any]], video: str,
        program_text: str | None = None) -> dict[str, Any]:
    """The row of one question: ``rec`` a :attr:`DatasetFolder.records` record, ``nodes`` its program's node
    list from ``dataset.json``, ``video`` its video path; ``program_text`` the program's text form when known
    (else read from ``nodes``)."""
    key = (int(rec["video_index"]), int(rec["question_index"]))
    if program_text is None:
        program_text = _program_text(nodes, f"dataset.json: video {key[0]}, question {key[1]}") if nodes else ""
    return {
        "video_index": key[0],
        "question_index": key[1],
        "question": str(rec.get("question", "")),
        "answer": str(rec["answer"]),
        "answer_type": str(rec.get("answer_type", "")),
        "question_type": str(rec["question_type"]),
        "category": rec["category"],
        "family": rec["family"],
        "template_id": rec["template_id"],
        "template_filename": str(rec.get("template_filename") or rec["template_id"].rsplit("_", 1)[0] + ".json"),
        "question_family_index": int(rec.get("question_family_index", rec["template_id"].rsplit("_", 1)[1])),
        "simulation_id": rec["simulation_id"],
        "video_file_path": video,
        "first_frame_path": frame_relpath(video, "first"),
        "last_frame_path": frame_relpath(video, "last"),
        "program": program_text,
        "program_nodes": [{"type": str(n.get("type", n.get("function", ""))),
                           "inputs": [int(x) for x in n.get("inputs", [])],
                           "value_inputs": [str(x) for x in n.get("value_inputs", [])]} for n in nodes],
    }


def row_text(row: Mapping[str, Any]) -> str:
    """A row as one JSONL line (without the newline)."""
    return json.dumps(row, ensure_ascii=False)


# -- files ----------------------------------------------------------------------------------------------------


def _arrow_schema() -> Any:
    import pyarrow as pa

    node = pa.struct([("type", pa.string()), ("inputs", pa.list_(pa.int64())), ("value_inputs", pa.list_(pa.string()))])
    types = {"int64": pa.int64(), "string": pa.string(), "nodes": pa.list_(node)}
    return pa.schema([(name, types[kind]) for name, kind in FEATURES])


def _have_pyarrow() -> bool:
    try:
        import pyarrow  # noqa: F401
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        return False
    return True


def _write_jsonl(items: Iterable[Mapping[str, Any]], path: Path) -> None:
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8") as fh:
        for item in items:
            fh.write(row_text(item) + "\n")


def _write_parquet(items: Sequence[Mapping[str, Any]], path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist(list(items), schema=_arrow_schema())
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp, compression="zstd")


def write_hf(root: str | os.PathLike[str], parquet: bool | None = None, card: bool = True) -> HfResult:
    """Write the JSONL (and Parquet) files of both splits and the dataset card into the folder ``root``.

    ``parquet``: ``None`` writes Parquet when pyarrow is installed; ``True`` requires it (a
    :class:`~craft_dsl.errors.MissingExtraError` says how to install it); ``False`` writes JSONL only. The card
    points at the Parquet files when written.
    """
    folder = DatasetFolder(root)
    if parquet is None:
        parquet = _have_pyarrow()
    elif parquet and not _have_pyarrow():
        raise MissingExtraError("writing Parquet files", "hf", "pyarrow", "or write JSONL only: --no-parquet")
    all_rows = rows(folder)
    files: list[str] = []
    counts: dict[str, dict[str, int]] = {}
    for split in SPLITS:
        part_of = folder.part_of(split)
        counts[split] = {}
        for part in PARTS:
            selected = [r for r in all_rows if part_of.get((r["video_index"], r["question_index"])) == part]
            counts[split][part] = len(selected)
            base = folder.root / HF_FOLDER / split / part
            if not selected:  # an empty part is left out (datasets cannot read an empty Parquet file)
                for ext in (".jsonl", ".parquet"):
                    base.with_suffix(ext).unlink(missing_ok=True)
                continue
            _write_jsonl(selected, base.with_suffix(".jsonl"))
            files.append(f"{HF_FOLDER}/{split}/{part}.jsonl")
            if parquet:
                _write_parquet(selected, base.with_suffix(".parquet"))
                files.append(f"{HF_FOLDER}/{split}/{part}.parquet")
            else:
                base.with_suffix(".parquet").unlink(missing_ok=True)  # a stale one would disagree with the card
    if card:
        text = card_text(folder, counts, "parquet" if parquet else "jsonl")
        with atomic_path(folder.root / CARD) as tmp:
            tmp.write_text(text, encoding="utf-8")
        files.append(CARD)
    return HfResult(tuple(files), counts, bool(parquet))


def _parquet_from_jsonl(source: Path, target: Path, batch: int = 2000) -> None:
    """The Parquet file of a JSONL part, read ``batch`` rows at a time into Arrow (a few hundred bytes per row
    instead of a few kilobytes as Python objects); the combined table gives the bytes :func:`_write_parquet`
    writes."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = _arrow_schema()
    batches, rows = [], []
    with source.open(encoding="utf-8") as fh:
        for line in fh:
            rows.append(json.loads(line))
            if len(rows) == batch:
                batches.append(pa.RecordBatch.from_pylist(rows, schema=schema))
                rows = []
    if rows:
        batches.append(pa.RecordBatch.from_pylist(rows, schema=schema))
    table = pa.Table.from_batches(batches, schema=schema).combine_chunks()
    del batches
    with atomic_path(target) as tmp:
        pq.write_table(table, tmp, compression="zstd")


def finish_streamed(root: str | os.PathLike[str], counts: Mapping[str, Mapping[str, int]],
                    parquet: bool | None = None) -> HfResult:
    """The Parquet files and the card of JSONL part files already written (``craft-dsl generate`` streams them):
    the same files :func:`write_hf` writes from the folder, without reading ``dataset.json`` again. Parquet
    tables are built one part at a time from its JSONL file."""
    folder = DatasetFolder(root)
    if parquet is None:
        parquet = _have_pyarrow()
    files: list[str] = []
    for split in SPLITS:
        for part in PARTS:
            base = folder.root / HF_FOLDER / split / part
            if not counts[split][part]:
                for ext in (".jsonl", ".parquet"):
                    base.with_suffix(ext).unlink(missing_ok=True)
                continue
            files.append(f"{HF_FOLDER}/{split}/{part}.jsonl")
            if parquet:
                _parquet_from_jsonl(base.with_suffix(".jsonl"), base.with_suffix(".parquet"))
                files.append(f"{HF_FOLDER}/{split}/{part}.parquet")
            else:
                base.with_suffix(".parquet").unlink(missing_ok=True)
    text = card_text(folder, counts, "parquet" if parquet else "jsonl")
    with atomic_path(folder.root / CARD) as tmp:
        tmp.write_text(text, encoding="utf-8")
    files.append(CARD)
    return HfResult(tuple(files), {k: dict(v) for k, v in counts.items()}, bool(parquet))


# -- the card -------------------------------------------------------------------------------------------------


def _features_yaml(indent: str) -> list[str]:
    lines = []
    for name, kind in FEATURES:
        lines.append(f"{indent}- name: {name}")
        if kind == "nodes":
            lines += [f"{indent}  list:", f"{indent}  - name: type", f"{indent}    dtype: string",
                      f"{indent}  - name: inputs", f"{indent}    list: int64",
                      f"{indent}  - name: value_inputs", f"{indent}    list: string"]
        else:
            lines.append(f"{indent}  dtype: {kind}")
    return lines


def card_yaml(file_format: str, counts: Mapping[str, Mapping[str, int]]) -> str:
    """The card's YAML front matter (without the ``---`` fences): a config per split with questions, listing
    its parts with questions."""
    lines = ["license: mit", "task_categories:", "- visual-question-answering", "language:", "- en",
             "pretty_name: CRAFT-style causal video question answering (craft-dsl)", "configs:"]
    splits = [s for s in SPLITS if any(counts[s][p] for p in PARTS)]
    for i, split in enumerate(splits):
        lines.append(f"- config_name: {split}")
        if i == 0:
            lines.append("  default: true")
        lines.append("  data_files:")
        for part in PARTS:
            if counts[split][part]:
                lines += [f"  - split: {part}", f"    path: {HF_FOLDER}/{split}/{part}.{file_format}"]
    lines.append("dataset_info:")
    for split in splits:
        lines += [f"- config_name: {split}", "  features:"]
        lines += _features_yaml("  ")
    return "\n".join(lines) + "\n"


def _md_table(header: Sequence[str], body: Iterable[Sequence[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join("" if v is None else str(v) for v in row) + " |" for row in body]
    return lines


def _setting_cell(name: str, value: Any) -> str:
    """A generation setting in the card: templates counted, custom scene layouts by id and hash."""
    from .custom_scenes import recorded_scenes_text

    if name == "templates":
        return f"{len(value)} templates"
    if name == "scenes" and any(isinstance(e, dict) for e in value or ()):
        return "`" + recorded_scenes_text(value) + "`"
    return "`" + json.dumps(value) + "`"


def card_text(folder: DatasetFolder, counts: Mapping[str, Mapping[str, int]], file_format: str) -> str:
    """The whole dataset card: front matter, then counts, settings, statistics and baselines."""
    from .stats import BASELINES, COLUMNS, heuristic_baselines, paper_baselines

    records = folder.records
    videos = sorted({int(r["video_index"]) for r in records})
    out = ["---", card_yaml(file_format, counts).rstrip("\n"), "---", "",
           "# CRAFT-style causal video question answering", "",
           "Questions about short 2D physics videos (20 scene layouts), in the formats of the CRAFT dataset "
           "(Ates et al.): descriptive, counterfactual and causal (cause, enable, prevent) questions, each with its "
           "functional program. Generated by `craft-dsl generate`; the folder also holds the published CRAFT "
           "files (`dataset.json`, `dataset_minimal.json`, `split_info_*.json`, `annotations.json`).", "",
           "## Loading", "", "```python", "from datasets import load_dataset", "",
           'ds = load_dataset("path/to/this/folder", "random")   # or "hard"',
           'ds["train"][0]["question"], ds["train"][0]["answer"], ds["train"][0]["program"]', "```", "",
           "`random` is the paper's easy split (whole videos, 60/20/20), `hard` holds out scene layouts "
           "(train 1-7, 9, 10, 15, 19, 20; validation 8, 12, 14, 16; test 11, 13, 17, 18). "
           f"Rows are in `{HF_FOLDER}/<split>/<part>.jsonl`" + (" and `.parquet`" if file_format == "parquet" else "")
           + ". Paths (`video_file_path`, "
           "`first_frame_path`, `last_frame_path`) are relative to this folder.", "",
           "## Counts", ""]
    out += _md_table(["split", *PARTS, "all"],
                     [[s, *(counts[s][p] for p in PARTS), sum(counts[s].values())] for s in SPLITS])
    empty = [f"{s}/{p}" for s in SPLITS for p in PARTS if not counts[s][p]]
    out += ["", f"{len(records)} questions over {len(videos)} videos."
            + (f" Parts without questions ({', '.join(empty)}) have no data files." if empty else ""), ""]
    if folder.config:
        out += ["## Generation settings", ""]
        out += _md_table(["setting", "value"], [[k, _setting_cell(k, v)]
                                                    for k, v in sorted(as_recorded(folder.config).items())])
        customs = [e for e in folder.config.get("scenes") or () if isinstance(e, dict)]
        if customs:
            ids = ", ".join(str(e.get("scene")) for e in customs)
            out += ["", (f"Scenes {ids} are custom layouts" if len(customs) > 1 else f"Scene {ids} is a custom layout")
                    + ", recorded in full in `generation_config.json`; the `hard` split holds custom layouts out "
                    "(test)."]
        out.append("")
    out += ["## Statistics", "", "Questions per paper category and answer type:", ""]
    per_cat: Counter[tuple[str, str]] = Counter((r["category"], str(r.get("answer_type"))) for r in records)
    out += _md_table(["category", "answer type", "questions"], [[c, t, n] for (c, t), n in sorted(per_cat.items())])
    answers: Counter[str] = Counter(str(r["answer"]) for r in records)
    out += ["", "Answers: " + ", ".join(f"{a} {n}" for a, n in sorted(answers.items(), key=lambda x: (-x[1], x[0]))),
            "", "`craft-dsl stats` writes every table as CSV with charts (answers per template, question types per "
            "scene, events per video, objects per scene).", "",
            "## Heuristic baselines", "",
            "Expected test accuracy (%) of the paper's answer-bias baselines, this dataset / the paper (lower "
            "means less answer bias): Random answers uniformly from the training answers, AT-Random from those of "
            "the question's answer type, MFA gives the most frequent training answer, AT-MFA the most frequent of "
            "the answer type.", ""]
    body = []
    for split in SPLITS:
        ours = heuristic_baselines(records, folder.part_of(split))
        paper = paper_baselines(split)
        for name in BASELINES:
            cells = []
            for c, p in zip(COLUMNS, paper[name], strict=True):
                acc = ours[name][c][0]
                cells.append(f"{'-' if acc is None else f'{acc:.1f}'} / {p:.1f}")
            body.append([split, name, *cells])
    out += _md_table(["split", "baseline", *COLUMNS], body)
    return "\n".join(out) + "\n"


__all__ = ["CARD", "FEATURES", "HF_FOLDER", "HfResult", "card_text", "card_yaml", "rows", "write_hf"]
