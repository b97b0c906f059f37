"""Perceived scenes: run CRAFT programs over what a perception model saw, with its uncertainty.

>>> from craft_dsl.perception import load_perceived, most_likely_world      # doctest: +SKIP
>>> scene, dropped = load_perceived("perceived.json")                      # doctest: +SKIP
>>> program.run(most_likely_world(scene))                                   # doctest: +SKIP

See ``docs/perception.md``.
"""

from __future__ import annotations

from .export import export_perceived
from .schema import SCHEMA_VERSION, PerceivedEvent, PerceivedObject, PerceivedScene, Pose, Track, VideoInfo, json_schema
from .validation import Problem, check_scene, load_perceived, parse_scene, save_perceived
from .world import ExecutionOptions, PerceivedSimulation, SceneModel, most_likely_world

__all__ = [
    "SCHEMA_VERSION",
    "ExecutionOptions",
    "PerceivedEvent",
    "PerceivedObject",
    "PerceivedScene",
    "PerceivedSimulation",
    "Pose",
    "Problem",
    "SceneModel",
    "Track",
    "VideoInfo",
    "check_scene",
    "export_perceived",
    "json_schema",
    "load_perceived",
    "most_likely_world",
    "parse_scene",
    "save_perceived",
]
