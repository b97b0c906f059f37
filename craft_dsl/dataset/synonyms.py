"""The original generator's ``synonyms.json``: re-exported from :mod:`craft_dsl.synonyms`, where the question
reader (language layer) reads it without importing the dataset package."""

from __future__ import annotations

from ..synonyms import SYNONYMS

__all__ = ["SYNONYMS"]
