"""Dataset generation and use: per-video questions (questions.py), the dataset pipeline (pipeline.py), the
published media layout (layout.py), reading a dataset folder (folder.py), Hugging Face files (hf.py), statistics
and baselines (stats.py) with their charts (charts.py)."""

from .pipeline import GenerationConfig as GenerationConfig
from .pipeline import generate_dataset as generate_dataset
from .questions import generate_questions as generate_questions
from .questions import instantiate_dfs as instantiate_dfs
from .questions import perturbation_filter as perturbation_filter
