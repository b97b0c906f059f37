"""The oracle for model predictions: predicted programs in any form, their outcome, traces, and scores."""

from __future__ import annotations

from .forms import FORMS, ProgramCache, ProgramForm, detect_form, read_program

__all__ = ["FORMS", "ProgramCache", "ProgramForm", "detect_form", "read_program"]
