"""The CRAFT paper's published test accuracies (models and humans)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PaperRow:
    """One row of the paper's main table: accuracies (%) as (C, CF, D, All) on the easy and hard splits."""

    group: str
    model: str
    easy: tuple[float, float, float, float]
    hard: tuple[float, float, float, float]


#: The CRAFT paper's test accuracies (Ates et al., tables of results), columns (C, CF, D, All).
PAPER_RESULTS: tuple[PaperRow, ...] = (
    PaperRow("heuristic", "Random", (5.95, 5.25, 5.09, 5.24), (5.37, 4.62, 5.08, 4.98)),
    PaperRow("heuristic", "AT-Random", (36.67, 44.34, 33.95, 37.47), (33.67, 46.06, 34.16, 37.52)),
    PaperRow("heuristic", "MFA", (32.68, 43.28, 23.53, 30.72), (30.09, 43.94, 23.20, 29.98)),
    PaperRow("heuristic", "AT-MFA", (49.62, 47.21, 37.57, 42.03), (49.28, 47.17, 36.55, 41.12)),
    PaperRow("text-only", "LSTM", (53.04, 53.14, 38.29, 44.69), (52.51, 56.24, 37.25, 44.52)),
    PaperRow("text-only", "BERT", (48.43, 50.59, 37.55, 42.90), (49.28, 52.12, 36.52, 42.52)),
    PaperRow("single frame", "LSTM-CNN-F", (53.11, 55.23, 44.86, 49.07), (48.07, 48.12, 35.54, 40.64)),
    PaperRow("single frame", "LSTM-CNN-L", (54.86, 55.63, 43.12, 48.42), (49.86, 54.44, 38.88, 44.66)),
    PaperRow("single frame", "MAC-F", (53.18, 52.88, 44.40, 48.10), (51.86, 53.5, 42.12, 46.55)),
    PaperRow("single frame", "MAC-L", (49.97, 53.08, 44.54, 47.83), (50.21, 53.8, 41.46, 46.05)),
    PaperRow("video", "LSTM-CNN-V", (54.65, 61.42, 48.12, 53.01), (51.86, 54.89, 41.36, 46.50)),
    PaperRow("video", "MAC-V", (53.95, 57.72, 44.51, 49.74), (51.22, 54.71, 42.94, 47.31)),
    PaperRow("video", "TVQA", (53.67, 55.57, 36.89, 44.71), (51.00, 55.12, 36.31, 43.46)),
    PaperRow("video", "TVQA+", (54.86, 60.02, 40.22, 48.11), (51.00, 55.12, 39.09, 45.12)),
    PaperRow("video", "G-SWM", (53.54, 55.29, 37.05, 44.69), (51.00, 48.68, 37.77, 42.47)),
    PaperRow("oracle", "LSTM-D", (51.71, 55.89, 63.22, 59.53), (51.93, 56.00, 59.57, 57.64)),
    PaperRow("oracle", "BERT-D", (68.44, 80.05, 93.41, 86.20), (66.33, 79.34, 91.30, 84.90)),
)
#: Humans (481 questions, one study, not split-specific): (C, CF, D, All).
PAPER_HUMANS: tuple[float, float, float, float] = (71.27, 83.07, 87.45, 76.60)
