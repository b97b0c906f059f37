"""The video reader as an lmms-eval model: ``lmms-eval --model craft_reader --tasks craft --include_path DIR``.

craft-dsl registers the model with lmms-eval through lmms-eval's entry-point group ``lmms_eval.models``
(:func:`manifest`, named in pyproject.toml): installing craft-dsl where lmms-eval runs is all it takes. The tasks are
the ones ``craft-dsl export lmms-eval`` writes (:mod:`craft_dsl.harness.lmms_eval`).

Each request's row names its video and question; the model reads every video once, answering all the video's
questions of the run together (:func:`craft_dsl.reader.cli.read_video`, as ``craft-dsl read`` does), and keeps its
perceived scene for questions asked later. The answer text is the reader's answer as ``dataset_minimal.json``
spells it (``"2"``, ``"True"``, ``"Red"``); a question the reader cannot answer, or a video it cannot read, gets
``""`` (scored wrong, as a missing prediction is). So the task's accuracies are those of ``craft-dsl read`` then
``craft-dsl score`` on the same videos.

Model arguments (``--model_args key=value,...``): ``dataset`` (the dataset folder; default: the environment
variable ``CRAFT_DATASET``, else the folder the task folder's ``craft_task.json`` names), ``workers`` (processes
reading videos, default 1), and ``craft-dsl read``'s ``votes``, ``steps``, ``engine``, ``decoder``,
``distribution`` and ``samples``.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import CraftError
from ..reader.video import DECODERS, RUN_STEPS
from ..reader.votes import VOTES

#: The name lmms-eval knows the model by (``--model craft_reader``).
MODEL_ID = "craft_reader"
#: ``engine``: as ``craft-dsl read --engine``.
ENGINES: tuple[str, ...] = ("auto", "box2d", "pymunk")
#: What lmms-eval passes every model besides ``--model_args`` (unused: the reader reads on the CPU, one video at a
#: time per worker).
_HARNESS_ARGS = ("batch_size", "max_batch_size", "device")
_INSTALL = "pip install 'craft-dsl[lmms-eval]' (docs/evaluate.md)"


def manifest() -> Any:
    """The model's registration, loaded by lmms-eval from the entry-point group ``lmms_eval.models``."""
    from lmms_eval.models.registry_v2 import ModelManifest

    return ModelManifest(model_id=MODEL_ID, simple_class_path=f"{__name__}.CraftReader")


@dataclass(frozen=True)
class ReadSettings:
    """How videos are read: ``craft-dsl read``'s options of the same names."""

    votes: int = VOTES
    steps: int = RUN_STEPS
    engine: str = "auto"
    decoder: str = "auto"
    distribution: bool = False
    samples: int = 64

    def __post_init__(self) -> None:
        for name, least in (("votes", 0), ("steps", 1), ("samples", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise CraftError(f"{name} must be a whole number of at least {least}, not {value!r}")
        if self.engine not in ENGINES:
            raise CraftError(f"unknown engine {self.engine!r}; allowed: {', '.join(ENGINES)}")
        if self.decoder not in DECODERS:
            raise CraftError(f"unknown decoder {self.decoder!r}; allowed: {', '.join(DECODERS)}")


@dataclass
class _Video:
    """What one reading of a video left: its perceived scene (JSON), why it is not whole, its answers so far, or
    why it could not be read."""

    scene: str | None = None
    warning: str | None = None
    error: str | None = None
    answers: dict[int, str | None] | None = None


class VideoAnswers:
    """Answers to questions about videos, each video read once (its scene kept for questions asked later)."""

    def __init__(self, settings: ReadSettings | None = None, workers: int = 1,
                 report: Callable[[str], None] | None = None) -> None:
        self.settings = settings or ReadSettings()
        self.workers = max(1, int(workers))
        self.report = report or (lambda message: print(message, file=sys.stderr))
        self._videos: dict[str, _Video] = {}
        #: Videos read (perceived and reconstructed) so far.
        self.readings = 0

    def answer(self, asked: Sequence[tuple[str | os.PathLike[str], Any]],
               first_engine: Callable[[str], str | None] | None = None) -> list[str | None]:
        """The answer to each ``(video path, craft_dsl.reader.Question)``, in order (None: no answer); videos not
        read before are read now, all their questions here together, ``workers`` at a time. ``first_engine(path)``:
        the engine the video's dataset names (``engine`` ``auto`` tries it first)."""
        from ..reader.cli import read_video
        from ..reader.runs import run_tasks

        by_video: dict[str, dict[int, Any]] = {}
        for path, question in asked:
            by_video.setdefault(str(Path(path).resolve()), {})[int(question.question_index)] = question
        new = [p for p in by_video if p not in self._videos]
        s = self.settings
        jobs = [(i, (p, [by_video[p][q] for q in sorted(by_video[p])], s.decoder, s.distribution, s.samples, s.votes,
                     s.steps, s.engine, None if first_engine is None else first_engine(p)))
                for i, p in enumerate(new)]

        def finished(index: int, result: dict[str, Any]) -> None:
            path = new[index]
            if "error" in result:
                self._failed(path, result["error"])
                return
            if "warning" in result:
                self.report(f"warning: {path}: {result['warning']}")
            self._videos[path] = _Video(result["scene"], result.get("warning"), None,
                                        {a.question.question_index: a.answer for a in result["answers"]})

        def crashed(index: int, message: str) -> None:
            self._failed(new[index], message)

        from tqdm import tqdm

        with tqdm(total=len(jobs), unit="video", desc="reading", file=sys.stderr, disable=not jobs) as bar:
            def step(fn: Callable[[int, Any], None]) -> Callable[[int, Any], None]:
                def done(index: int, value: Any) -> None:
                    fn(index, value)
                    self.readings += 1
                    bar.update(1)
                return done

            run_tasks(read_video, jobs, min(self.workers, len(jobs)), step(finished), step(crashed))
        for path, questions in by_video.items():
            self._answer_later(path, [q for i, q in sorted(questions.items())
                                      if i not in (self._videos[path].answers or {})])
        out: list[str | None] = []
        for path, question in asked:
            video = self._videos[str(Path(path).resolve())]
            out.append((video.answers or {}).get(int(question.question_index)))
        return out

    def _failed(self, path: str, message: str) -> None:
        self.report(f"error: {path}: {message} (its questions are scored wrong)")
        self._videos[path] = _Video(error=message)

    def _answer_later(self, path: str, questions: Sequence[Any]) -> None:
        """Questions of a video read before, answered from its kept scene as its reading would have answered them."""
        video = self._videos[path]
        if not questions or video.scene is None or video.answers is None:
            return
        from dataclasses import replace

        from ..perception.schema import PerceivedScene
        from ..reader.answer import answer_questions
        from ..reader.confidence import rescore

        s = self.settings
        answers = answer_questions(PerceivedScene.model_validate_json(video.scene), questions, s.distribution,
                                   s.samples, votes=s.votes)
        if video.warning is not None:
            answers = [rescore(replace(a, warning=video.warning)) for a in answers]
        video.answers.update({a.question.question_index: a.answer for a in answers})


def _settings_from_args(args: Mapping[str, Any]) -> tuple[ReadSettings, int, str | None]:
    """The read settings, workers and dataset folder of ``--model_args`` (an unknown argument is refused)."""
    known = {"dataset", "workers", "votes", "steps", "engine", "decoder", "distribution", "samples"}
    unknown = sorted(set(args) - known - set(_HARNESS_ARGS))
    if unknown:
        raise CraftError(f"{MODEL_ID}: unknown model argument {', '.join(unknown)}; "
                         f"allowed: {', '.join(sorted(known))}")

    def whole(name: str, default: int) -> int:
        value = args.get(name, default)
        try:
            return int(str(value))
        except ValueError:
            raise CraftError(f"{MODEL_ID}: {name} must be a whole number, not {value!r}") from None

    distribution = args.get("distribution", False)
    if not isinstance(distribution, bool):
        raise CraftError(f"{MODEL_ID}: distribution must be true or false, not {distribution!r}")
    settings = ReadSettings(whole("votes", VOTES), whole("steps", RUN_STEPS), str(args.get("engine", "auto")),
                            str(args.get("decoder", "auto")), distribution, whole("samples", 64))
    workers = whole("workers", 1)
    if workers < 1:
        raise CraftError(f"{MODEL_ID}: workers must be at least 1, not {workers}")
    dataset = args.get("dataset")
    return settings, workers, None if dataset is None else str(dataset)


def task_dataset_root(doc_to_visual: Any) -> Path | None:
    """The dataset folder of the task a request comes from: the folder its exported ``utils.py`` read from
    ``craft_task.json`` (``CRAFT_DATASET`` overriding), found through the task's ``doc_to_visual``; None for a task
    that ``craft-dsl export lmms-eval`` did not write."""
    candidates = [doc_to_visual, getattr(getattr(getattr(doc_to_visual, "__self__", None), "config", None),
                                         "doc_to_visual", None)]
    for fn in candidates:
        root = getattr(fn, "__globals__", {}).get("_ROOT")
        if isinstance(root, Path):
            return root
    return None


def _model_class() -> type:
    try:
        from lmms_eval.api.model import lmms
    except ImportError:
        raise CraftError(f"the reader's lmms-eval model needs lmms-eval: {_INSTALL}") from None
    from tqdm import tqdm

    from ..reader.answer import Question
    from ..reader.cli import dataset_engine
    from .lmms_eval import video_path

    class CraftReader(lmms):
        """craft-dsl's video reader as an lmms-eval model (``--model craft_reader``; see the module docstring)."""

        is_simple = True

        def __init__(self, **model_args: Any) -> None:
            super().__init__()
            settings, workers, dataset = _settings_from_args(model_args)
            self.reader = VideoAnswers(settings, workers, report=lambda m: tqdm.write(m, file=sys.stderr))
            self.dataset = Path(dataset) if dataset is not None else None
            self._engines: dict[str, str | None] = {}

        def _root(self, doc_to_visual: Any, task: str) -> Path:
            if self.dataset is not None:
                return self.dataset
            if os.environ.get("CRAFT_DATASET"):
                return Path(os.environ["CRAFT_DATASET"])
            root = task_dataset_root(doc_to_visual)
            if root is None:
                raise CraftError(f"{MODEL_ID}: task {task} was not written by craft-dsl export lmms-eval; give the "
                                 "dataset folder: --model_args dataset=DIR")
            return root

        def _first_engine(self, root: Path) -> str | None:
            """The engine the dataset's generation_config.json names, as craft-dsl read finds it."""
            key = str(root)
            if key not in self._engines:
                self._engines[key] = dataset_engine([key])
            return self._engines[key]

        def generate_until(self, requests: Sequence[Any]) -> list[str]:
            asked: list[tuple[Path, Question]] = []
            engines: dict[str, str | None] = {}
            for request in requests:
                _context, _gen_kwargs, doc_to_visual, doc_id, task, split = request.args
                doc = self.task_dict[task][split][doc_id]
                missing = [f for f in ("video_index", "question_index", "question", "video") if f not in doc]
                if missing:
                    raise CraftError(f"{MODEL_ID}: task {task} rows lack {', '.join(missing)}: run it on the tasks "
                                     "craft-dsl export lmms-eval writes")
                root = self._root(doc_to_visual, task)
                path = video_path(doc, root)
                engines[str(path.resolve())] = self._first_engine(root)
                asked.append((path, Question(int(doc["video_index"]), int(doc["question_index"]),
                                             str(doc["question"]))))
            answers = self.reader.answer(asked, engines.get)
            out = ["" if a is None else a for a in answers]
            for request, text in zip(requests, out):
                self.cache_hook.add_partial("generate_until", (request.args[0], request.args[1]), text)
            return out

        def generate_until_multi_round(self, requests: Sequence[Any]) -> list[str]:
            return self.generate_until(requests)

        def loglikelihood(self, requests: Sequence[Any]) -> list[tuple[float, bool]]:
            raise CraftError(f"{MODEL_ID} answers questions (generate_until tasks such as craft); it gives no "
                             "log-likelihoods")

    CraftReader.__module__ = __name__
    CraftReader.__qualname__ = "CraftReader"
    return CraftReader


def __getattr__(name: str) -> Any:
    """``CraftReader``, the lmms-eval model class, made on first use (lmms-eval must be installed)."""
    if name == "CraftReader":
        cls = _model_class()
        globals()[name] = cls
        return cls
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["ENGINES", "MODEL_ID", "ReadSettings", "VideoAnswers", "manifest", "task_dataset_root"]
