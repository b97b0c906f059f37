"""Dataset generation: per-video questions (questions.py) and the dataset pipeline (pipeline.py)."""

from .pipeline import GenerationConfig as GenerationConfig
from .pipeline import generate_dataset as generate_dataset
from .questions import generate_questions as generate_questions
from .questions import instantiate_dfs as instantiate_dfs
from .questions import perturbation_filter as perturbation_filter
