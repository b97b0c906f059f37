"""A local web viewer of a CRAFT-format dataset folder (``craft-dsl view DIR``).

Browse videos and their questions with filters (scene, template, category, answer), play the video, see each
question's program with every node's value, the causal graph of the video's events, and the counterfactual run
without one object beside the factual one. Standard library only (``http.server``); see docs/dataset-users.md.
"""

from __future__ import annotations

from .data import ViewerData, ViewerError
from .server import Viewer

__all__ = ["Viewer", "ViewerData", "ViewerError"]
