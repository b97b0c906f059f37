"""Verification of CRAFT datasets and scoring of model predictions.

Two tools for a researcher holding the published CRAFT dataset (or one written in its formats):

* :func:`verify_dataset` re-answers every question of a ``dataset.json`` by running its saved program
  (``Program.from_nodes``) over its video's simulation from ``annotations.json``, and lists the questions whose
  recorded answer differs, and those that could not be re-answered (unreadable program, missing simulation).
* :func:`score` scores a model's predictions against ``dataset_minimal.json`` (or ``dataset.json``): accuracy
  overall, per paper column (C, CF, D, All), per paper sub-category, per question type and per
  template, optionally on one part of a split file; :data:`PAPER_RESULTS` holds the published numbers.

Formats (those of the published CRAFT dataset):

* ``dataset.json``: list of videos ``{"simulation_id", "video_path", "questions": {"info", "questions": [...]}}``;
  each question has ``program`` (node list with ``value_inputs``; ``_output`` is ignored), ``answer`` (raw JSON:
  bool, int, lowercase string), ``template_filename``, ``question_family_index``, ``question_index``,
  ``video_index`` (and ``video``, the id6 file stem);
* ``dataset_minimal.json``: flat list of ``{"question", "answer" (a string: "True", "2", "Red"), "answer_type",
  "template_filename", "template_id", "video_index", "question_index", "question_family_index",
  "simulation_id", "question_type"}``;
* ``annotations.json``: ``{"<id6>": <simulation with variations>}``. It can be several gigabytes, so it is
  indexed in one streaming pass and each simulation is parsed only when asked for (a directory of
  ``<id6>.json`` files, or an in-memory mapping, work too);
* split files: ``{"train": [{"video_index", "question_index"}, ...], "validation": [...], "test": [...]}``;
* predictions: ``{"<video_index>_<question_index>": answer}`` or ``[{"video_index", "question_index",
  "answer"}, ...]``.

Answers are compared after :func:`normalise_answer` (case, whitespace, booleans, yes/no, numbers).

Modules: :mod:`.categories` (paper columns, sub-categories, question types), :mod:`.paper` (published
results), :mod:`.answers` (normalisation), :mod:`.formats` (file readers, :class:`Question`),
:mod:`.annotations` (streaming annotations index), :mod:`.check` (verification), :mod:`.scoring` (scoring),
:mod:`.fixture` (small datasets for tests and demos).
"""

from __future__ import annotations

from .annotations import Annotations, index_json_object, open_annotations
from .answers import answers_agree, normalise_answer
from .categories import CATEGORIES, FAMILIES, QUESTION_TYPES, category_of, family_of, question_type_of
from .check import Mismatch, Tally, VerifyError, VerifyReport, verify_dataset
from .fixture import build_dataset
from .formats import (
    PathLike,
    Question,
    parse_dataset,
    parse_minimal,
    parse_predictions,
    parse_questions,
    parse_split,
    read_dataset,
    read_minimal,
    read_predictions,
    read_questions,
    read_split,
)
from .paper import PAPER_HUMANS, PAPER_RESULTS, PaperRow
from .records import minimal_records, question_record, template_id_of, video_record
from .scoring import Score, ScoreReport, paper_table, score

__all__ = [
    "Annotations",
    "CATEGORIES",
    "FAMILIES",
    "Mismatch",
    "PAPER_HUMANS",
    "PAPER_RESULTS",
    "PaperRow",
    "PathLike",
    "QUESTION_TYPES",
    "Question",
    "Score",
    "ScoreReport",
    "Tally",
    "VerifyError",
    "VerifyReport",
    "answers_agree",
    "build_dataset",
    "category_of",
    "family_of",
    "index_json_object",
    "minimal_records",
    "question_record",
    "template_id_of",
    "video_record",
    "normalise_answer",
    "open_annotations",
    "paper_table",
    "parse_dataset",
    "parse_minimal",
    "parse_predictions",
    "parse_questions",
    "parse_split",
    "question_type_of",
    "read_dataset",
    "read_minimal",
    "read_predictions",
    "read_questions",
    "read_split",
    "score",
    "verify_dataset",
]
