"""Rows for training with the rewards of :mod:`craft_dsl.harness.rewards` (TRL's ``GRPOTrainer``, or any loop).

:func:`training_rows` gives one row per question of a part of a split: a ``prompt`` (a string, or a chat
conversation ``[{"role": "user", "content": ...}]`` with ``chat=True``) and the columns the rewards read
(``answer``, ``template_id``, ``answer_kind``, ``video_index``), plus ``question_index``, ``question``,
``program`` (the recorded program as DSL text, empty when the folder has no ``dataset.json``) and ``video`` (the
video's path relative to the dataset folder). ``task="answer"`` asks for the answer in words (the prompt of the
lmms-eval export, :func:`craft_dsl.harness.lmms_eval.doc_to_text`); ``task="program"`` asks for the program that
answers the question, in the DSL (:data:`PROGRAM_PROMPT`), for :class:`~craft_dsl.harness.rewards.ProgramReward`.
"""

from __future__ import annotations

import os
from typing import Any

from ..errors import CraftError
from .lmms_eval import doc_to_text, question_rows

#: The instruction of ``task="program"`` prompts; ``{question}`` is replaced by the question.
PROGRAM_PROMPT = ("Write the CRAFT DSL program that answers this question about a 2D physics video, e.g. "
                  "Count(FilterColor(SceneAtStart(), \"red\")). Question: {question}\nProgram:")
TASKS: tuple[str, ...] = ("answer", "program")


def training_rows(dataset: str | os.PathLike[str], split: str = "random", part: str = "train",
                  task: str = "answer", chat: bool = False) -> list[dict[str, Any]]:
    """One row per question of ``part`` (train, validation, test) of ``split`` (random, hard), in
    ``dataset_minimal.json`` order (see the module docstring)."""
    from ..dataset.folder import PARTS, DatasetFolder
    from ..program import Program

    if task not in TASKS:
        raise CraftError(f"unknown task {task!r}; allowed: {', '.join(TASKS)}")
    if part not in PARTS:
        raise CraftError(f"unknown part {part!r}; allowed: {', '.join(PARTS)}")
    folder = DatasetFolder(dataset)

    def program(key: tuple[int, int], _tid: str) -> dict[str, Any]:
        nodes = folder.programs.get(key)
        return {"program": str(Program.from_nodes(nodes)) if nodes else ""}

    rows = question_rows(folder, split, part, program)
    for row in rows:
        text = doc_to_text(row) if task == "answer" else PROGRAM_PROMPT.format(question=row["question"])
        row["prompt"] = [{"role": "user", "content": text}] if chat else text
    return rows


__all__ = ["PROGRAM_PROMPT", "TASKS", "training_rows"]
