"""The confidence of each reader answer: the probability that it is right, from what the reading itself shows.

For each answer the reader records its *inputs* (:func:`confidence_inputs`), measured on the perceived scene alone:

* the question: its paper sub-category (``D/N-V``, ``CF/O``, ...; :func:`craft_dsl.verify.categories.category_of`
  of the template its text matches), its answer type and whether the answer is ``True`` / ``0``;
* the perceived scene's uncertainty: the probability of the answer over every reading of the scene's attribute,
  moving and event distributions (:func:`craft_dsl.perception.distribution.answer_distributions`), and the least
  probable attribute value chosen for any object;
* the reconstruction's agreement with the frames (``PerceivedScene.meta``): mean and largest distance in pixels of
  the kept run from the tracks, re-anchored bodies, refits, the layout fit's RMS, whether a second physics engine
  was tried and which one was kept (and the video's frame rate, recorded, not yet a feature: no labelled videos
  below 60 fps were fitted);
* for a counterfactual question, the share of the perturbed replays' votes its answer got
  (:mod:`craft_dsl.reader.votes`; recorded, not yet a feature);
* how stable the answer is under the reader's other ways of executing the same scene: the answer again with the
  other physics engine (pymunk / box2d), with the counterfactuals re-simulated from the fitted start instead of
  replayed, and with the events derived from the tracks instead of the reconstructed run's. An answer near a
  decision threshold (a marginal contact, an event near the end, a chaotic counterfactual) changes under them.

:class:`ConfidenceModel` maps the inputs to a probability with a logistic model (Platt scaling) fitted on labelled
read-details (``benchmarks/reader_calibration.py``); its parameters are ``confidence.json`` beside this module.
A fallback answer (a guess of the answer type, ``Answer.fallback``) gets the rate at which such guesses were right
in the fitting data, per answer type; an answer read from a video that is not whole (``Answer.warning``) gets at most
that rate too (no labelled cut videos were fitted: a rule, not a fit).

A measurement that fails never raises the confidence. Its input is recorded as not measured, with the reason, in
``failed`` (``{"engine": "RuntimeError: ...", "scene_p": "..."}``), and the confidence is the least the model gives
over every value the input could have taken: an alternative that raises, for the whole scene or for one program,
counts as agreeing or differing, whichever says less; a scene probability that fails, as any probability from 1 down
to that of the scene's most likely reading (``scene_p_floor``; the answer holds in that reading). An alternative
that cannot run in this install at all (the other engine's package missing: ``unavailable``) is not a failure of
this answer's measurement but a different install, the same for every answer: its agreement is weighed at the rate
the fitting data's answers agreed (the feature's mean), which keeps the confidences calibrated there, and is never
more than counting it as agreeing.
"""

from __future__ import annotations

import importlib
import itertools
import json
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import CraftError
from ..perception.schema import PerceivedScene
from ..program import Program
from ..question_parsing import match_question
from ..verify.categories import CATEGORIES, category_of
from ..vocabulary import DEFAULT_ENGINE
from .records import Answer, Question, format_answer

if TYPE_CHECKING:
    from ..perception.world import SceneModel

#: The fitted parameters shipped with the package.
MODEL_PATH = Path(__file__).with_name("confidence.json")
#: The ways of executing a scene whose answers are compared with the reader's (``ExecutionOptions`` fields).
ALTERNATIVES: dict[str, dict[str, str]] = {"engine": {}, "resimulate": {"counterfactual": "resimulate"},
                                           "derived": {"events": "derived"}}
#: The other engine of each engine the reader keeps.
OTHER_ENGINE = {"pymunk": "box2d", "box2d": "pymunk"}
#: The package each physics engine needs.
ENGINE_PACKAGES = {"pymunk": "pymunk", "box2d": "Box2D"}
#: The confidence of an answer taken from the reading its question names (:mod:`craft_dsl.perception.premise`): the
#: share of such answers that were right on development videos (43 of 51, 128-px copies; the reader's measurement
#: history, ``git show 32f3360:docs/reader-history.md``), rounded down.
PREMISE_RATE = 0.8
#: Answer types by the program's result type name.
ANSWER_TYPES: tuple[str, ...] = ("bool", "count", "color", "shape", "size")
#: The chance that a guess of each answer type is right (uniform over its values; counts: over 0-3): the prior of
#: the fitted guess rates, and the rate of a type the fitting data had no guess of.
CHANCE: dict[str, float] = {"bool": 1 / 2, "count": 1 / 4, "color": 1 / 8, "shape": 1 / 3, "size": 1 / 2, "*": 1 / 2}
_TYPE_NAMES = {"BOOL": "bool", "INTEGER": "count", "COLOR": "color", "SHAPE": "shape", "SIZE": "size"}


def answer_type(program: Program) -> str:
    """``"bool"``, ``"count"``, ``"color"``, ``"shape"`` or ``"size"``: the type of the program's answer."""
    return _TYPE_NAMES.get(program.type.name, "bool")


def _category(text: str) -> str | None:
    try:
        return category_of(match_question(text).template_id)
    except CraftError:
        return None


def engine_missing(engine: str) -> str | None:
    """Why the physics ``engine`` cannot run in this install (its package is not installed); None where it can."""
    package = ENGINE_PACKAGES.get(engine)
    if package is None:
        return f"no physics engine {engine!r}"
    try:
        importlib.import_module(package)
    except ImportError as err:
        return f"{engine} is not installed here ({err})"
    return None


def _reason(err: BaseException) -> str:
    return f"{type(err).__name__}: {err}"


@dataclass(frozen=True)
class _Outcome:
    """One program's answer under one alternative execution (``"INVALID"`` where it has none), or why it was not
    measured: ``failed`` (the execution raised) or ``unavailable`` (it cannot run in this install)."""

    answer: str | None = None
    failed: str | None = None
    unavailable: str | None = None


def _alternative_answers(scene: PerceivedScene, programs: Sequence[Program | None], base: SceneModel | None = None
                         ) -> dict[str, list[_Outcome | None]]:
    """Each program's outcome under each of :data:`ALTERNATIVES` (None for no program). ``base``: the scene's model
    as answered, whose fitted physics the alternatives with the same engine reuse."""
    from ..perception.world import ExecutionOptions, SceneModel

    out: dict[str, list[_Outcome | None]] = {}
    for name, fields in ALTERNATIVES.items():
        options: dict[str, Any] = dict(fields)
        whole: _Outcome | None = None  # the outcome of every program where the execution does not run at all
        if name == "engine":
            physics = scene.physics or DEFAULT_ENGINE
            other = OTHER_ENGINE.get(physics)
            missing = f"no other engine than {physics}" if other is None else engine_missing(other)
            if missing is not None:
                whole = _Outcome(unavailable=missing)
            options["engine"] = other
        sim = None
        if whole is None:
            try:
                model = SceneModel(scene, ExecutionOptions(**options))
                if base is not None and "engine" not in options and "physics" in base.__dict__:
                    model.__dict__["physics"] = base.physics  # the same fit (a cached_property's value): not redone
                sim = model.simulation()
            except Exception as err:  # noqa: BLE001 - not measured: counted as whichever says less
                whole = _Outcome(failed=_reason(err))
        answers: list[_Outcome | None] = []
        for program in programs:
            if program is None:
                answers.append(None)
            elif whole is not None or sim is None:
                answers.append(whole)
            else:
                try:
                    answers.append(_Outcome(format_answer(program.run(sim)) or "INVALID"))
                except Exception as err:  # noqa: BLE001 - not measured for this program
                    answers.append(_Outcome(failed=_reason(err)))
        out[name] = answers
    return out


def _scene_probabilities(scene: PerceivedScene | SceneModel, programs: Sequence[Program | None],
                         answers: Sequence[str | None], samples: int, seed: int
                         ) -> tuple[list[float | None], str | None]:
    """The probability of each answer over the readings of the scene (None where not computed), and why none was
    computed where the distributions raised (None where they did not)."""
    from ..perception.distribution import answer_distributions

    valid = [i for i, p in enumerate(programs) if p is not None and answers[i] is not None]
    out: list[float | None] = [None] * len(programs)
    if not valid:
        return out, None
    try:
        dists = answer_distributions(scene, [programs[i] for i in valid], samples=samples,  # type: ignore[misc]
                                     seed=seed)
        for i, d in zip(valid, dists):
            out[i] = float(d.p(answers[i]))
    except Exception as err:  # noqa: BLE001 - not measured: counted as the least probability it can have
        return [None] * len(programs), _reason(err)
    return out, None


def _reading_floor(scene: PerceivedScene | SceneModel) -> float:
    """The probability of the scene's most likely reading (the product of its factors' largest probabilities): the
    least probability an answer that holds in that reading can have; 0 where it cannot be computed."""
    from ..perception.distribution import scene_factors
    from ..perception.world import SceneModel

    try:
        model = scene if isinstance(scene, SceneModel) else SceneModel(scene)
        return float(math.prod(max(f.probabilities) for f in scene_factors(model)))
    except Exception:  # noqa: BLE001 - nothing known: any probability
        return 0.0


def _least_attribute(scene: PerceivedScene) -> float:
    """The smallest probability of the most likely colour, shape or size of any dynamic object (1 when certain)."""
    least = 1.0
    for obj in scene.objects:
        if obj.dynamic is not None and obj.dynamic < 0.5:
            continue
        for dist in (obj.color, obj.shape, obj.size):
            if dist:
                least = min(least, max(dist.values()))
    return least


def confidence_inputs(scene: PerceivedScene, questions: Sequence[Question], answers: Sequence[Answer],
                      samples: int = 64, seed: int = 0, base: SceneModel | None = None) -> list[dict[str, Any]]:
    """The inputs of each answer's confidence (see the module docstring), as JSON-ready dicts; ``samples`` and
    ``seed`` are those of the answer distributions (exact while the readings are few). ``base``: the model the
    answers were computed on (``SceneModel(scene)``), whose physics and counterfactual runs are reused. An input
    that could not be measured is named in ``failed`` or ``unavailable`` with the reason (the module docstring)."""
    from ..question_parsing import question_to_program

    programs: list[Program | None] = []
    for q, a in zip(questions, answers):
        if a.answer is None or a.fallback or a.premise is not None:
            programs.append(None)
            continue
        try:
            programs.append(question_to_program(q.text))
        except CraftError:
            programs.append(None)
    texts = [a.answer for a in answers]
    alternatives = _alternative_answers(scene, programs, base)
    measured = base if base is not None else scene
    scene_p, scene_failed = _scene_probabilities(measured, programs, texts, samples, seed)
    floor = _reading_floor(measured) if scene_failed is not None else None
    meta = scene.meta or {}
    shared = {"mean_stray_px": float(meta.get("mean_stray_px", 0.0)),
              "max_stray_px": float(meta.get("max_stray_px", 0.0)),
              "anchors": int(meta.get("anchors", 0)), "refits": int(meta.get("refits", 0)),
              "layout_rms": float(meta.get("layout_rms", 0.0)),
              "engines_tried": len(meta.get("engines_tried", [])) or 1, "physics": scene.physics or DEFAULT_ENGINE,
              "least_attribute": round(_least_attribute(scene), 6), "video_fps": float(meta.get("video_fps", 60.0))}
    out = []
    for i, (q, a) in enumerate(zip(questions, answers)):
        program = programs[i]
        record: dict[str, Any] = {"category": _category(q.text)}
        if program is not None:
            record["type"] = answer_type(program)
        else:
            try:
                record["type"] = answer_type(question_to_program(q.text))
            except CraftError:
                record["type"] = None
        record["answer"] = a.answer
        record.update(shared)
        if program is not None:
            p = scene_p[i]
            record["scene_p"] = None if p is None else round(p, 6)
            agree: dict[str, bool] = {}
            failed: dict[str, str] = {}
            unavailable: dict[str, str] = {}
            for name, outcomes in alternatives.items():
                outcome = outcomes[i]
                if outcome is None:
                    continue
                if outcome.unavailable is not None:
                    unavailable[name] = outcome.unavailable
                elif outcome.failed is not None:
                    failed[name] = outcome.failed
                else:
                    agree[name] = outcome.answer == a.answer
            record["agree"] = agree
            if scene_failed is not None:
                failed["scene_p"] = scene_failed
                record["scene_p_floor"] = round(floor or 0.0, 6)
            if failed:
                record["failed"] = failed
            if unavailable:
                record["unavailable"] = unavailable
        if a.votes and a.answer in a.votes:  # recorded, not yet a feature: no labelled voted answers were fitted
            record["vote_share"] = round(a.votes[a.answer] / sum(a.votes.values()), 6)
        out.append(record)
    return out


# -- the model ---------------------------------------------------------------------------------------------------


def _completions(inputs: Mapping[str, Any]) -> Iterator[dict[str, Any]]:
    """``inputs`` with each of its ``failed`` inputs given each value it could have taken: an alternative agreeing
    or differing, the scene probability 1 or its ``scene_p_floor`` (the model is monotone in each feature, so the
    least confidence is at one of them). Just ``inputs`` where none failed."""
    failed = inputs.get("failed") or {}
    names = [n for n in failed if n in ALTERNATIVES]
    probabilities = ((1.0, float(inputs.get("scene_p_floor") or 0.0)) if "scene_p" in failed
                     else (inputs.get("scene_p"),))
    for values in itertools.product((True, False), repeat=len(names)):
        for p in probabilities:
            yield {**inputs, "agree": {**(inputs.get("agree") or {}), **dict(zip(names, values))}, "scene_p": p}


def _log1p(value: Any) -> float:
    return math.log1p(max(float(value or 0.0), 0.0))


def feature_vector(inputs: Mapping[str, Any]) -> dict[str, float]:
    """The model's features of one answer's inputs (named; a missing input counts as its neutral value)."""
    out: dict[str, float] = {}
    category = inputs.get("category")
    for c in CATEGORIES:
        out[f"category={c}"] = float(category == c)
    kind = inputs.get("type")
    answer = inputs.get("answer")
    out["bool_true"] = float(kind == "bool" and answer == "True")
    out["count_zero"] = float(kind == "count" and answer == "0")
    out["count_value"] = float(answer) if kind == "count" and isinstance(answer, str) and answer.isdigit() else 0.0
    agree: Mapping[str, Any] = inputs.get("agree") or {}
    for name in ALTERNATIVES:
        out[f"differs:{name}"] = float(agree.get(name, True) is False)
    p = inputs.get("scene_p")
    out["scene_doubt"] = 1.0 - float(p) if p is not None else 0.0
    out["attribute_doubt"] = 1.0 - float(inputs.get("least_attribute", 1.0))
    out["log_mean_stray_px"] = _log1p(inputs.get("mean_stray_px"))
    out["log_max_stray_px"] = _log1p(inputs.get("max_stray_px"))
    out["log_anchors"] = _log1p(inputs.get("anchors"))
    out["refits"] = float(inputs.get("refits", 0) or 0)
    out["log_layout_rms"] = _log1p(inputs.get("layout_rms"))
    out["second_engine_tried"] = float((inputs.get("engines_tried") or 1) > 1)
    out["box2d_kept"] = float(inputs.get("physics") == "box2d")
    return out


@dataclass(frozen=True)
class ConfidenceModel:
    """A logistic model over :func:`feature_vector` (standardised by ``mean`` and ``scale``), and the probability
    that a fallback guess is right per answer type (``fallback``; ``"*"``: any type)."""

    features: tuple[str, ...]
    weights: tuple[float, ...]
    bias: float
    mean: tuple[float, ...]
    scale: tuple[float, ...]
    fallback: dict[str, float] = field(default_factory=lambda: dict(CHANCE))
    meta: dict[str, Any] = field(default_factory=dict)

    def logit(self, inputs: Mapping[str, Any]) -> float:
        named = feature_vector(inputs)
        x = np.array([named.get(f, 0.0) for f in self.features])
        z = (x - np.array(self.mean)) / np.array(self.scale)
        return float(self.bias + z @ np.array(self.weights))

    def agree_rate(self, name: str) -> float:
        """The share of the fitting data's answers that agreed under alternative ``name`` (1 where it is not a
        feature: then it does not matter)."""
        feature = f"differs:{name}"
        return 1.0 - self.mean[self.features.index(feature)] if feature in self.features else 1.0

    def probability(self, inputs: Mapping[str, Any]) -> float:
        """The model's probability for ``inputs``: the least over every value the ``failed`` inputs could have
        taken, of the expectation over the ``unavailable`` alternatives' agreement at :meth:`agree_rate`."""
        return min(self._expected(filled) for filled in _completions(inputs))

    def _expected(self, inputs: Mapping[str, Any]) -> float:
        missing = [n for n in (inputs.get("unavailable") or {}) if n in ALTERNATIVES]
        total = 0.0
        for values in itertools.product((True, False), repeat=len(missing)):
            weight = math.prod(self.agree_rate(n) if v else 1.0 - self.agree_rate(n) for n, v in zip(missing, values))
            if weight > 0.0:
                z = self.logit({**inputs, "agree": {**(inputs.get("agree") or {}), **dict(zip(missing, values))}})
                total += weight * (1.0 / (1.0 + math.exp(-z)) if z > -700 else 0.0)
        return total

    def guess_rate(self, kind: str | None) -> float:
        """The probability that a fallback guess of answer type ``kind`` is right."""
        key = kind or "*"
        if key in self.fallback:
            return float(self.fallback[key])
        return CHANCE.get(key, float(self.fallback.get("*", CHANCE["*"])))

    def confidence(self, inputs: Mapping[str, Any] | None, fallback: bool = False, warning: bool = False,
                   premise: bool = False) -> float:
        """The probability that the answer with these inputs is right, in [0, 1] (``premise``: an answer from the
        reading the question names, :data:`PREMISE_RATE`, at most the guess rate of a video not whole)."""
        kind = (inputs or {}).get("type")
        if (inputs or {}).get("answer", "") is None:  # unanswered: never right
            return 0.0
        if premise and not fallback:
            return round(min(PREMISE_RATE, self.guess_rate(kind)) if warning else PREMISE_RATE, 6)
        if fallback or inputs is None or "agree" not in inputs:
            return round(self.guess_rate(kind), 6)
        p = self.probability(inputs)
        if warning:
            p = min(p, self.guess_rate(kind))
        return round(min(max(p, 0.0), 1.0), 6)

    def to_json(self) -> dict[str, Any]:
        return {"model": "logistic", "features": list(self.features), "weights": [round(w, 6) for w in self.weights],
                "bias": round(self.bias, 6), "mean": [round(m, 6) for m in self.mean],
                "scale": [round(s, 6) for s in self.scale], "fallback": {k: round(v, 6) for k, v in
                                                                        self.fallback.items()}, "meta": self.meta}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ConfidenceModel:
        n = len(data["features"])
        if not (len(data["weights"]) == len(data["mean"]) == len(data["scale"]) == n):
            raise ValueError("confidence model: features, weights, mean and scale differ in length")
        return cls(tuple(data["features"]), tuple(map(float, data["weights"])), float(data["bias"]),
                   tuple(map(float, data["mean"])), tuple(map(float, data["scale"])),
                   {str(k): float(v) for k, v in data.get("fallback", {"*": 0.5}).items()}, dict(data.get("meta", {})))

    @classmethod
    def load(cls, path: str | Path = MODEL_PATH) -> ConfidenceModel:
        return cls.from_json(json.loads(Path(path).read_text(encoding="utf-8")))


@lru_cache(maxsize=1)
def default_model() -> ConfidenceModel:
    """The model shipped with the package (:data:`MODEL_PATH`)."""
    return ConfidenceModel.load(MODEL_PATH)


def fit_logistic(x: np.ndarray, y: np.ndarray, l2: float = 1.0, iterations: int = 100) -> tuple[np.ndarray, float]:
    """Weights and bias of the L2-regularised logistic regression of ``y`` (0/1) on ``x`` [n, d] (Newton's method;
    the bias is not penalised)."""
    n, d = x.shape
    a = np.hstack([x, np.ones((n, 1))])
    w = np.zeros(d + 1)
    penalty = np.full(d + 1, l2)
    penalty[-1] = 0.0
    for _ in range(iterations):
        p = 1.0 / (1.0 + np.exp(-np.clip(a @ w, -30, 30)))
        grad = a.T @ (p - y) + penalty * w
        hess = (a * (p * (1 - p))[:, None]).T @ a + np.diag(penalty) + 1e-9 * np.eye(d + 1)
        step = np.linalg.solve(hess, grad)
        w -= step
        if float(np.max(np.abs(step))) < 1e-10:
            break
    return w[:-1], float(w[-1])


def fit_model(inputs: Sequence[Mapping[str, Any]], correct: Sequence[bool], fallbacks: Sequence[bool],
              l2: float = 1.0, meta: Mapping[str, Any] | None = None, drop: Sequence[str] = ()) -> ConfidenceModel:
    """A :class:`ConfidenceModel` fitted on labelled answers: the logistic model on the answers that are not
    fallbacks, the guess rates on those that are (two pseudo-answers per type, right at :data:`CHANCE`'s rate).
    ``drop``: features left out (those whose name starts with one of them). Answers with an input that failed
    (``failed``) are left out: their features are not all measured."""
    kept = [i for i, f in enumerate(fallbacks) if not f and "agree" in inputs[i] and not inputs[i].get("failed")]
    names = tuple(f for f in feature_vector(inputs[kept[0]]) if not f.startswith(tuple(drop)))
    x = np.array([[feature_vector(inputs[i])[f] for f in names] for i in kept])
    y = np.array([float(correct[i]) for i in kept])
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    scale[scale < 1e-9] = 1.0
    w, b = fit_logistic((x - mean) / scale, y, l2)
    guesses: dict[str, list[int]] = {"*": [0, 0]}
    for i, f in enumerate(fallbacks):
        if f:
            kind = str(inputs[i].get("type"))
            for key in (kind, "*"):
                guesses.setdefault(key, [0, 0])
                guesses[key][0] += int(correct[i])
                guesses[key][1] += 1
    fallback = {k: (r + 2 * CHANCE.get(k, CHANCE["*"])) / (n + 2) for k, (r, n) in guesses.items()}
    return ConfidenceModel(names, tuple(map(float, w)), b, tuple(map(float, mean)), tuple(map(float, scale)),
                           fallback, dict(meta or {}))


def with_confidence(scene: PerceivedScene, questions: Sequence[Question], answers: Sequence[Answer],
                    model: ConfidenceModel | None = None, samples: int = 64, seed: int = 0,
                    base: SceneModel | None = None) -> list[Answer]:
    """``answers`` with their confidence and its inputs (:func:`confidence_inputs`)."""
    model = model or default_model()
    out = []
    for a, inputs in zip(answers, confidence_inputs(scene, questions, answers, samples, seed, base)):
        sure = model.confidence(inputs, a.fallback or a.answer is None, a.warning is not None, a.premise is not None)
        out.append(replace(a, confidence=sure, confidence_inputs=inputs))
    return out


def rescore(answer: Answer, model: ConfidenceModel | None = None) -> Answer:
    """``answer`` with its confidence computed again from its inputs (after its fallback or warning changed)."""
    model = model or default_model()
    return replace(answer, confidence=model.confidence(answer.confidence_inputs, answer.fallback or
                                                       answer.answer is None, answer.warning is not None,
                                                       answer.premise is not None))


__all__ = ["ALTERNATIVES", "CHANCE", "ENGINE_PACKAGES", "MODEL_PATH", "ConfidenceModel", "answer_type",
           "confidence_inputs", "default_model", "engine_missing", "feature_vector", "fit_logistic", "fit_model",
           "rescore", "with_confidence"]
