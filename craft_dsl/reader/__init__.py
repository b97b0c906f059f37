"""The video reader: CRAFT questions answered from the video file and the question text alone.

>>> from craft_dsl.reader import perceive_video, answer_questions, Question     # doctest: +SKIP
>>> perception = perceive_video("videos/sid_3/000007.mpg")                      # doctest: +SKIP
>>> perception.scene                      # a craft_dsl.perception.PerceivedScene    # doctest: +SKIP
>>> answer_questions(perception.scene, [Question(7, 0, "How many objects fall to the ground?")])  # doctest: +SKIP

The video is derendered (layout, static poses, objects and attributes, tracks) and the simulation that reproduces it
is reconstructed; programs then run over the perceived scene. See ``docs/reader.md``.
"""

from __future__ import annotations

from .answer import Answer, Question, answer_questions, find_videos, read_questions
from .perceive import Perception, perceive_frames, perceive_video

__all__ = [
    "Answer",
    "Perception",
    "Question",
    "answer_questions",
    "find_videos",
    "perceive_frames",
    "perceive_video",
    "read_questions",
]
