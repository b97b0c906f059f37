"""Where models are measured and trained: free-text answers, an lmms-eval task folder, verifiable rewards.

* :mod:`.answers`: :func:`parse_answer` reads a model's free text into the dataset's answer vocabulary, for the
  answer kind of the question's program (:func:`kind_of_template`, :func:`kind_of_record`);
* :mod:`.lmms_eval`: :func:`export_lmms_eval` writes a task folder lmms-eval loads with ``--include_path``
  (``craft-dsl export lmms-eval``), and the functions its tasks call; their accuracies are ``craft-dsl score``'s;
* :mod:`.rewards`: rewards with the signature of TRL's ``reward_funcs`` (:func:`answer_reward`,
  :class:`ProgramReward`, :class:`FormatReward`);
* :mod:`.training`: :func:`training_rows`, prompts and the columns the rewards read;
* :mod:`.cli`: ``craft-dsl export lmms-eval`` and ``craft-dsl parse-answers``.

docs/evaluate.md and docs/train.md show them at work.
"""

from __future__ import annotations

from .answers import (
    ANSWER_KINDS,
    AnswerKind,
    completion_text,
    kind_of_program,
    kind_of_record,
    kind_of_template,
    parse_answer,
)
from .lmms_eval import VisualSettings, export_lmms_eval
from .rewards import FormatReward, ProgramReward, answer_reward, extract_program, format_reward
from .training import training_rows

__all__ = [
    "ANSWER_KINDS", "AnswerKind", "FormatReward", "ProgramReward", "VisualSettings", "answer_reward",
    "completion_text", "export_lmms_eval", "extract_program", "format_reward", "kind_of_program", "kind_of_record",
    "kind_of_template", "parse_answer", "training_rows",
]
