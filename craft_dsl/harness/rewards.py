"""Verifiable rewards for reinforcement learning on CRAFT, as TRL's ``GRPOTrainer`` calls reward functions.

Every reward here is a callable ``f(prompts, completions, **kwargs) -> list[float]``: ``completions`` are strings
(standard format) or chat message lists (conversational format, ``[{"role": "assistant", "content": ...}]``), and
the dataset's other columns arrive as keyword arguments, one list entry per completion (TRL repeats a prompt's row
for each of its completions). The columns used are those of the dataset's Hugging Face rows
(``craft_dsl.dataset.hf.FEATURES``, also :func:`craft_dsl.harness.training_rows`): ``answer``, ``template_id``,
``video_index``. Each reward has a ``__name__`` (TRL logs the reward under it, ``rewards/<name>/mean``).

* :func:`answer_reward`: the completion's free-text answer (read by :func:`~craft_dsl.harness.parse_answer` for
  the question's answer kind) is the recorded answer: :data:`ANSWER_RIGHT` (1.0), else :data:`ANSWER_WRONG` (0.0;
  also for no answer).
* :class:`ProgramReward`: the completion holds a program (DSL text, a JSON node list, or tokens), which is run on
  the question's true simulation with :func:`craft_dsl.oracle.run_batch`; graded by its outcome,
  :data:`PROGRAM_SYNTAX_ERROR` < :data:`PROGRAM_TYPE_ERROR` < :data:`PROGRAM_INVALID` < :data:`PROGRAM_WRONG`
  < :data:`PROGRAM_RIGHT`.
* :class:`FormatReward`: the completion has the requested shape: :data:`FORMAT_EXACT` for exactly one answer
  word (or ``<answer>word</answer>`` after optional reasoning, in the ``tagged`` style), :data:`FORMAT_READABLE`
  when an answer can be read from it all the same, :data:`FORMAT_NONE` when none can.

docs/train.md shows them in a GRPO run.
"""

from __future__ import annotations

import json
import re
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal

from ..errors import CraftError
from ..oracle import run_batch
from ..oracle.forms import FORMS, detect_form
from ..oracle.outcome import OUTCOMES
from ..simulation import Simulation
from ..verify import answers_agree
from ..verify.annotations import Annotations, open_annotations
from .answers import check_kind, completion_text, kind_of_template, parse_answer

#: Answer reward: the read answer is the recorded one.
ANSWER_RIGHT = 1.0
#: Answer reward: another answer, or none could be read.
ANSWER_WRONG = 0.0

#: Program reward: the text holds no well-formed program (unknown module, unbalanced brackets, bad JSON, no text).
PROGRAM_SYNTAX_ERROR = 0.0
#: Program reward: well formed but ill typed (wrong argument type or count, a value outside the vocabulary, a
#: result that is not an answer).
PROGRAM_TYPE_ERROR = 0.1
#: Program reward: type-checks, but its value on the true simulation is INVALID (e.g. Unique of two objects).
PROGRAM_INVALID = 0.25
#: Program reward: answers, but not the recorded answer.
PROGRAM_WRONG = 0.5
#: Program reward: answers the recorded answer.
PROGRAM_RIGHT = 1.0
#: The program reward of each outcome of :data:`craft_dsl.oracle.OUTCOMES` ("answer" when it is wrong).
PROGRAM_GRADES: dict[str, float] = {"syntax_error": PROGRAM_SYNTAX_ERROR, "type_error": PROGRAM_TYPE_ERROR,
                                    "invalid": PROGRAM_INVALID, "wrong_answer": PROGRAM_WRONG,
                                    "right_answer": PROGRAM_RIGHT}

#: Format reward: exactly the requested shape.
FORMAT_EXACT = 1.0
#: Format reward: not the requested shape, but an answer can be read (``"The answer is 2 because ..."``).
FORMAT_READABLE = 0.5
#: Format reward: no answer can be read.
FORMAT_NONE = 0.0

FormatStyle = Literal["plain", "tagged"]
FORMAT_STYLES: tuple[FormatStyle, ...] = ("plain", "tagged")


def _column(kwargs: Mapping[str, Any], name: str, n: int, reward: str) -> list[Any]:
    """Column ``name`` of the batch, one entry per completion (a clear error when it is missing or short)."""
    if name not in kwargs:
        given = ", ".join(sorted(k for k in kwargs if not k.startswith("_"))) or "none"
        raise CraftError(f"{reward}: the dataset has no column {name!r} (columns given: {given}); use rows from "
                         "craft_dsl.harness.training_rows or the dataset's hf/ files")
    values = kwargs[name]
    if isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        values = [values] * n
    if len(values) != n:
        raise CraftError(f"{reward}: column {name!r} has {len(values)} entries for {n} completions")
    return list(values)


def _kinds(kwargs: Mapping[str, Any], n: int, reward: str) -> list[str]:
    if "answer_kind" in kwargs:
        return [check_kind(str(k)) for k in _column(kwargs, "answer_kind", n, reward)]
    return [kind_of_template(str(t)) for t in _column(kwargs, "template_id", n, reward)]


def answer_reward(prompts: Sequence[Any] | None, completions: Sequence[Any], **kwargs: Any) -> list[float]:
    """Per completion: :data:`ANSWER_RIGHT` when its free-text answer, read for the question's answer kind
    (column ``template_id``, or ``answer_kind``), is the recorded ``answer``; else :data:`ANSWER_WRONG`."""
    n = len(completions)
    golds = _column(kwargs, "answer", n, "answer_reward")
    kinds = _kinds(kwargs, n, "answer_reward")
    out = []
    for completion, gold, kind in zip(completions, golds, kinds):
        answer = parse_answer(completion_text(completion), kind)
        out.append(ANSWER_RIGHT if answer is not None and answers_agree(answer, gold) else ANSWER_WRONG)
    return out


answer_reward.__name__ = "craft_answer"

_FENCE = re.compile(r"```[\w-]*\s*\n?(.*?)```", re.S)
_PROGRAM_TAG = re.compile(r"<program>(.*?)(?:</program>|$)", re.S | re.I)
_THINK = re.compile(r"<think>.*?(?:</think>|$)", re.S | re.I)
_PROGRAM_LINE = re.compile(r"^\s*(?:program|answer|final program)\s*:\s*", re.I)


def extract_program(completion: Any, form: str | None = None) -> Any:
    """The program a completion holds, in a form :func:`craft_dsl.oracle.run_batch` reads: the content of the last
    ``<program>...</program>`` tag or fenced code block if any (after dropping a ``<think>`` block), else the whole
    text, without a leading ``Program:``; text that is a JSON list is read as a node list or token list (unless
    ``form`` says ``text``). A token string is split on white space when ``form`` is ``prefix`` or ``postfix``."""
    text = _THINK.sub(" ", completion_text(completion))
    tags = _PROGRAM_TAG.findall(text) or _FENCE.findall(text)
    body = (tags[-1] if tags else text).strip()
    body = _PROGRAM_LINE.sub("", body, count=1).strip()
    if form != "text" and body.startswith("["):
        try:
            value = json.loads(body)
        except (ValueError, RecursionError):
            return body  # read as text: a syntax error
        return value
    if form in ("prefix", "postfix"):
        return body.split()
    return body


class ProgramReward:
    """The graded program reward (see the module docstring): each completion's program (:func:`extract_program`)
    is run with :func:`craft_dsl.oracle.run_batch` on the simulation of the completion's video (column
    ``video_index``) and compared with the recorded ``answer``.

    ``simulations``: a dataset folder (its ``annotations.json`` or ``intermediates/``), an annotations file,
    an :class:`~craft_dsl.verify.annotations.Annotations`, or a mapping ``{video_index: Simulation}``.
    ``form``: the program form of every completion (``text``, ``nodes``, ``prefix``, ``postfix``), or None to
    detect it (a string is DSL text, a JSON list of objects a node list, a JSON list of strings prefix tokens).
    ``cache``: how many simulations read from annotations are kept between calls (the most recently used; each with
    the counterfactual runs computed on it).
    """

    def __init__(self, simulations: str | Path | Annotations | Mapping[int, Simulation],
                 form: str | None = None, name: str = "craft_program", cache: int = 256) -> None:
        if form is not None and form not in FORMS:
            raise CraftError(f"unknown program form {form!r}; allowed: {', '.join(FORMS)}, or None to detect it")
        self.form = form
        self.__name__ = name
        # simulations read from annotations, the most recently used kept (with their counterfactual runs)
        self._cache: OrderedDict[int, Simulation] = OrderedDict()
        self._cache_size = max(1, cache)
        self._sims: Mapping[int, Simulation] | None = None
        self._annotations: Annotations | None = None
        if isinstance(simulations, Mapping) and all(isinstance(v, Simulation) for v in simulations.values()):
            self._sims = {int(k): v for k, v in simulations.items()}
        elif isinstance(simulations, Annotations):
            self._annotations = simulations
        elif isinstance(simulations, (str, Path)):
            path = Path(simulations)
            if path.is_dir() and (path / "dataset_minimal.json").is_file():
                from ..dataset.folder import DatasetFolder

                self._annotations = DatasetFolder(path).annotations
            else:
                self._annotations = open_annotations(path)
        else:
            raise CraftError("ProgramReward: simulations must be a dataset folder, an annotations file, an "
                             "Annotations object or a mapping video_index -> Simulation, not "
                             f"{type(simulations).__name__}")

    def simulation(self, video_index: int) -> Simulation:
        """The true simulation of a video."""
        if self._sims is not None:
            if video_index not in self._sims:
                raise CraftError(f"{self.__name__}: no simulation for video {video_index}")
            return self._sims[video_index]
        assert self._annotations is not None
        if video_index in self._cache:
            self._cache.move_to_end(video_index)
            return self._cache[video_index]
        key = self._annotations.resolve(f"{video_index:06d}", video_index)
        if key is None:
            raise CraftError(f"{self.__name__}: {self._annotations.name} has no simulation for video {video_index}")
        sim = self._annotations.simulation(key)
        self._cache[video_index] = sim
        if len(self._cache) > self._cache_size:
            self._cache.popitem(last=False)
        return sim

    def outcomes(self, completions: Sequence[Any], video_index: Sequence[Any], answer: Sequence[Any]) -> list[str]:
        """Per completion: ``syntax_error``, ``type_error``, ``invalid``, ``wrong_answer`` or ``right_answer``."""
        programs: list[Any] = []
        sims: list[Simulation] = []
        readable: list[int] = []
        loaded: dict[int, Simulation] = {}
        for i, (completion, video) in enumerate(zip(completions, video_index)):
            program = extract_program(completion, self.form)
            try:
                form = self.form or detect_form(program)
            except CraftError:
                continue  # a JSON value that is no program: a syntax error
            if form == "text" and not isinstance(program, str):
                continue
            v = int(video)
            if v not in loaded:
                loaded[v] = self.simulation(v)
            programs.append(program)
            sims.append(loaded[v])
            readable.append(i)
        kinds = ["syntax_error"] * len(completions)
        if programs:
            result = run_batch(programs, sims, form=self.form)  # type: ignore[arg-type]
            for i, code, value in zip(readable, result.codes.tolist(), result.answers):
                outcome = OUTCOMES[code]
                if outcome == "answer":
                    outcome = "right_answer" if answers_agree(value, answer[i]) else "wrong_answer"
                kinds[i] = outcome
        return kinds

    def __call__(self, prompts: Sequence[Any] | None, completions: Sequence[Any], **kwargs: Any) -> list[float]:
        n = len(completions)
        videos = _column(kwargs, "video_index", n, self.__name__)
        golds = _column(kwargs, "answer", n, self.__name__)
        return [PROGRAM_GRADES[k] for k in self.outcomes(completions, videos, golds)]


_TAGGED = re.compile(r"^\s*(?:<think>.*?</think>\s*)?<answer>\s*([^<]*?)\s*</answer>\s*$", re.S | re.I)


def _exact(text: str, kind: str) -> bool:
    """Whether ``text`` is exactly one answer word of ``kind`` (any case, an optional final full stop)."""
    word = text.strip().removesuffix(".").strip()
    if not word or " " in word:
        return False
    answer = parse_answer(word, kind)
    if answer is None:
        return False
    return word.lower() == answer.lower() or (kind == "bool" and word.lower() in ("yes", "no"))


class FormatReward:
    """The format reward (see the module docstring). ``style``: ``plain``, the answer word alone (``"2"``,
    ``"True"``, ``"red"``; yes/no for booleans); ``tagged``, optional ``<think>...</think>`` reasoning then
    ``<answer>word</answer>`` and nothing else. The answer kind comes from column ``template_id`` (or
    ``answer_kind``)."""

    def __init__(self, style: str = "plain", name: str | None = None) -> None:
        if style not in FORMAT_STYLES:
            raise CraftError(f"unknown format style {style!r}; allowed: {', '.join(FORMAT_STYLES)}")
        self.style = style
        self.__name__ = name or f"craft_format_{style}"

    def __call__(self, prompts: Sequence[Any] | None, completions: Sequence[Any], **kwargs: Any) -> list[float]:
        n = len(completions)
        kinds = _kinds(kwargs, n, self.__name__)
        out = []
        for completion, kind in zip(completions, kinds):
            text = completion_text(completion)
            if self.style == "tagged":
                m = _TAGGED.match(text)
                exact = m is not None and _exact(m.group(1), kind)
            else:
                exact = _exact(text, kind)
            if exact:
                out.append(FORMAT_EXACT)
            else:
                out.append(FORMAT_READABLE if parse_answer(text, kind) is not None else FORMAT_NONE)
        return out


#: The plain format reward, ready to pass to TRL.
format_reward = FormatReward("plain")


__all__ = ["ANSWER_RIGHT", "ANSWER_WRONG", "FORMAT_EXACT", "FORMAT_NONE", "FORMAT_READABLE", "FORMAT_STYLES",
           "PROGRAM_GRADES", "PROGRAM_INVALID", "PROGRAM_RIGHT", "PROGRAM_SYNTAX_ERROR", "PROGRAM_TYPE_ERROR",
           "PROGRAM_WRONG", "FormatReward", "ProgramReward", "answer_reward", "extract_program", "format_reward"]
