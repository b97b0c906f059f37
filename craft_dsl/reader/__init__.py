"""The video reader: CRAFT questions answered from the video file and the question text alone.

>>> from craft_dsl.reader import perceive_video, answer_questions, Question     # doctest: +SKIP
>>> perception = perceive_video("videos/sid_3/000007.mpg")                      # doctest: +SKIP
>>> perception.scene                      # a craft_dsl.perception.PerceivedScene    # doctest: +SKIP
>>> answer_questions(perception.scene, [Question(7, 0, "How many objects fall to the ground?")])  # doctest: +SKIP

The video is derendered (layout, static poses, objects and attributes, tracks) and the simulation that reproduces it
is reconstructed; programs then run over the perceived scene. See ``docs/reader.md``. The names below load their
modules on first use, so that ``craft-dsl`` starts without scipy.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "Answer": "answer",
    "Question": "answer",
    "answer_questions": "answer",
    "find_videos": "answer",
    "read_questions": "answer",
    "Perception": "perceive",
    "perceive_frames": "perceive",
    "perceive_video": "perceive",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
