"""Answer distributions: a program's answer over every reading of a perceived scene, weighted by its probability.

The uncertain factors are independent: each object's colour, shape and size (categorical), whether it is dynamic
and whether it moves at the start and at the end (Bernoulli), and whether each perceived event happened (its
confidence). A factor whose probability is concentrated on one value is not uncertain. While the number of
readings (the product of the factors' sizes) stays at or below ``bound``, every reading is enumerated and the
distribution is exact; otherwise ``samples`` readings are drawn by seeded Monte Carlo (one
``numpy.random.Generator(PCG64(seed))``, factors drawn in a fixed order) and each probability comes with its
standard error ``sqrt(p (1 - p) / samples)``.

Physics is shared by all readings: the counterfactual runs are simulated once per removed object with the most
likely geometry, and a reading that leaves out a perceived event drops it from its factual and counterfactual
event lists (where the counterfactual replays it) without re-simulating. Answers are compared as the dataset
stores them, by :func:`craft_dsl.verify.answers.normalise_answer` (``True`` and ``"true"`` are one answer).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import PerceptionError
from ..program import Program, to_json
from ..types import INVALID_JSON
from ..verify.answers import normalise_answer
from .reading import DECISION_THRESHOLD, Reading, attribute_distribution, dynamic_probability
from .schema import PerceivedScene
from .world import ExecutionOptions, SceneModel

#: Readings are enumerated exactly while there are at most this many.
DEFAULT_BOUND = 4096
#: Monte Carlo readings drawn beyond the bound.
DEFAULT_SAMPLES = 256
#: log_likelihood's floor for an answer the distribution gives probability 0.
LOG_FLOOR = 1e-6


@dataclass(frozen=True)
class Factor:
    """One independent uncertain quantity of a scene: ``kind`` of object ``key`` (or event index ``key``)."""

    kind: str  # color, shape, size, dynamic, moving_start, moving_end, event
    key: int
    values: tuple[Any, ...]
    probabilities: tuple[float, ...]


def _bernoulli(kind: str, key: int, p: float) -> Factor | None:
    if p <= 0.0 or p >= 1.0:
        return None
    return Factor(kind, key, (True, False), (p, 1.0 - p))


def scene_factors(model: SceneModel) -> list[Factor]:
    """The uncertain factors of a scene, in a fixed order (objects by id, then events)."""
    out: list[Factor] = []
    for obj in sorted(model.scene.objects, key=lambda o: o.id):
        for name in ("color", "shape", "size"):
            dist = attribute_distribution(obj, name)
            if len(dist) > 1:
                out.append(Factor(name, obj.id, tuple(dist), tuple(dist.values())))
        for kind, p in (("dynamic", dynamic_probability(obj)), ("moving_start", model.moving_start[obj.id]),
                        ("moving_end", model.moving_end[obj.id])):
            factor = _bernoulli(kind, obj.id, p)
            if factor is not None:
                out.append(factor)
    for e in model.step_events:
        factor = _bernoulli("event", e.index, model.scene.events[e.index].confidence if model.scene.events else 1.0)
        if factor is not None:
            out.append(factor)
    return out


def reading_count(factors: Sequence[Factor]) -> int:
    return math.prod(len(f.values) for f in factors)


def _apply(base: Reading, factors: Sequence[Factor], choice: Sequence[int]) -> Reading:
    """``base`` with factor i set to its value ``choice[i]``."""
    objects = {o.id: o for o in base.objects}
    changes: dict[int, dict[str, Any]] = {}
    moving_start, moving_end, events = set(base.moving_start), set(base.moving_end), set(base.events)
    flags = {"moving_start": moving_start, "moving_end": moving_end, "event": events}
    for f, i in zip(factors, choice):
        value = f.values[i]
        if f.kind in flags:
            (flags[f.kind].add if value else flags[f.kind].discard)(f.key)
        else:
            changes.setdefault(f.key, {})[f.kind] = value
    new_objects = tuple(replace(o, **changes[o.id]) if o.id in changes else o for o in objects.values())
    dynamic = {o.id for o in new_objects if o.dynamic}
    return Reading(new_objects, frozenset(moving_start & dynamic), frozenset(moving_end & dynamic), frozenset(events))


def _base_reading(model: SceneModel) -> Reading:
    """The reading every factor is applied to: the most likely one, with the moving flags of all objects kept
    (they are masked by the reading's dynamic objects)."""
    ml = model.most_likely_reading()
    start = {i for i, p in model.moving_start.items() if p >= DECISION_THRESHOLD}
    end = {i for i, p in model.moving_end.items() if p >= DECISION_THRESHOLD}
    return Reading(ml.objects, frozenset(start), frozenset(end), ml.events)


# -- the distribution ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AnswerDistribution:
    """A distribution over the answers of one program.

    ``probabilities`` maps each answer's comparison key (:func:`normalise_answer`) to its probability, most likely
    first; ``answers`` maps the key to the answer as the dataset stores it (bool, int, lowercase string,
    ``"__INVALID__"``). ``method`` is ``"exact"`` (``samples`` readings enumerated) or ``"monte_carlo"``
    (``samples`` readings drawn; ``standard_errors`` per answer).

    A question presupposes the objects it names ("the red cube"): readings in which the program is INVALID (no
    unique such object) are left out and the rest renormalised; ``invalid`` is the probability they had. Only when
    every reading is INVALID is the distribution INVALID with probability 1.
    """

    probabilities: dict[str, float]
    answers: dict[str, Any]
    method: str
    samples: int
    standard_errors: dict[str, float] = field(default_factory=dict)
    invalid: float = 0.0

    @property
    def mode(self) -> Any:
        """The most probable answer (ties: the smaller comparison key)."""
        if not self.probabilities:
            raise PerceptionError("an empty answer distribution has no mode")
        key = min(self.probabilities, key=lambda k: (-self.probabilities[k], k))
        return self.answers[key]

    def p(self, answer: Any) -> float:
        """The probability of ``answer`` (any form :func:`normalise_answer` accepts)."""
        return self.probabilities.get(normalise_answer(answer), 0.0)

    def standard_error(self, answer: Any) -> float:
        return self.standard_errors.get(normalise_answer(answer), 0.0)

    def log_likelihood(self, answer: Any, floor: float = LOG_FLOOR) -> float:
        """``log(max(p(answer), floor))`` (natural log): the score of the true answer."""
        return math.log(max(self.p(answer), floor))

    def brier(self, answer: Any) -> float:
        """Multi-class Brier score of the true ``answer``: sum over answers of (p - [answer is the true one])^2."""
        truth = normalise_answer(answer)
        keys = set(self.probabilities) | {truth}
        return sum((self.probabilities.get(k, 0.0) - (1.0 if k == truth else 0.0)) ** 2 for k in keys)

    def to_json(self) -> dict[str, Any]:
        return {
            "mode": self.mode if self.probabilities else None,
            "method": self.method,
            "samples": self.samples,
            "invalid": self.invalid,
            "answers": [
                {"answer": self.answers[k], "p": p,
                 **({"standard_error": self.standard_errors[k]} if k in self.standard_errors else {})}
                for k, p in self.probabilities.items()
            ],
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> AnswerDistribution:
        try:
            entries = list(data["answers"])
            method, samples = str(data["method"]), int(data["samples"])
            invalid = float(data.get("invalid", 0.0))
            probabilities = {normalise_answer(e["answer"]): float(e["p"]) for e in entries}
            answers = {normalise_answer(e["answer"]): e["answer"] for e in entries}
            errors = {normalise_answer(e["answer"]): float(e["standard_error"]) for e in entries
                      if "standard_error" in e}
        except (KeyError, TypeError, ValueError) as err:
            raise PerceptionError(f"not an answer distribution ({err!r}); expected {{'method', 'samples', "
                                  "'answers': [{'answer', 'p'[, 'standard_error']}]}}") from None
        return cls(probabilities, answers, method, samples, errors, invalid)

    @classmethod
    def single(cls, answer: Any) -> AnswerDistribution:
        """Probability 1 on one answer."""
        value = to_json(answer, original=True)
        return cls({normalise_answer(value): 1.0}, {normalise_answer(value): value}, "exact", 1)


_INVALID_KEY = normalise_answer(INVALID_JSON)


def _distribution(weights: Mapping[str, float], answers: Mapping[str, Any], method: str, samples: int
                  ) -> AnswerDistribution:
    total = sum(weights.values())
    invalid = weights.get(_INVALID_KEY, 0.0) / total
    valid = {k: w for k, w in weights.items() if k != _INVALID_KEY} or dict(weights)
    valid_total = sum(valid.values())
    probs = {k: w / valid_total for k, w in valid.items()}
    ordered = dict(sorted(probs.items(), key=lambda kv: (-kv[1], kv[0])))
    errors = {}
    if method == "monte_carlo":
        n = max(1, round(samples * valid_total / total))
        errors = {k: math.sqrt(p * (1.0 - p) / n) for k, p in ordered.items()}
    return AnswerDistribution(ordered, {k: answers[k] for k in ordered}, method, samples, errors, invalid)


Weighted = Iterator[tuple[tuple[int, ...], float]]


def _readings(factors: Sequence[Factor], bound: int, samples: int, seed: int) -> tuple[str, int, Weighted]:
    """(method, count, iterator of (choice, weight))."""
    total = reading_count(factors)
    if total <= bound:
        def exact() -> Iterator[tuple[tuple[int, ...], float]]:
            for choice in itertools.product(*(range(len(f.values)) for f in factors)):
                yield choice, math.prod(f.probabilities[i] for f, i in zip(factors, choice))

        return "exact", total, exact()
    rng = np.random.Generator(np.random.PCG64(seed))
    draws = np.stack([rng.choice(len(f.values), size=samples, p=np.asarray(f.probabilities) / sum(f.probabilities))
                      for f in factors], axis=1)

    def monte_carlo() -> Iterator[tuple[tuple[int, ...], float]]:
        for row in draws:
            yield tuple(int(i) for i in row), 1.0

    return "monte_carlo", samples, monte_carlo()


def answer_distributions(scene: PerceivedScene | SceneModel, programs: Sequence[Program], *,
                         bound: int = DEFAULT_BOUND, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                         options: ExecutionOptions | None = None) -> list[AnswerDistribution]:
    """The answer distribution of each program over the readings of ``scene`` (exact or Monte Carlo, see the
    module docstring); every program sees the same readings."""
    if samples < 1 or bound < 1:
        raise PerceptionError(f"samples and bound must be at least 1 (got samples={samples}, bound={bound})")
    model = scene if isinstance(scene, SceneModel) else SceneModel(scene, options)
    factors = scene_factors(model)
    base = _base_reading(model)
    method, count, readings = _readings(factors, bound, samples, seed)
    weights: list[dict[str, float]] = [{} for _ in programs]
    answers: list[dict[str, Any]] = [{} for _ in programs]
    cache: dict[tuple[int, ...], list[tuple[str, Any]]] = {}
    for choice, weight in readings:
        results = cache.get(choice)
        if results is None:
            sim = model.simulation(_apply(base, factors, choice))
            results = []
            for program in programs:
                value = to_json(program.run(sim), original=True)
                results.append((normalise_answer(value), value))
            cache[choice] = results
        for i, (key, value) in enumerate(results):
            weights[i][key] = weights[i].get(key, 0.0) + weight
            answers[i][key] = value
    return [_distribution(w, a, method, count) for w, a in zip(weights, answers)]


def answer_distribution(scene: PerceivedScene | SceneModel, program: Program, **kwargs: Any) -> AnswerDistribution:
    """The answer distribution of one program (see :func:`answer_distributions`)."""
    return answer_distributions(scene, [program], **kwargs)[0]
