"""Per-video question generation: one simulation -> its CRAFT questions.

:func:`generate_questions` reproduces the original generator (``svqa/generate_questions.py``) for one video:
starred-word synonyms, depth-first instantiation with shuffled value lists, paraphrase choice and
value synonyms, and the output record. :func:`perturbation_filter` is the perturbation check,
improved: the *whole* scene is perturbed once per perturbation.

Randomness. Every draw comes from the ``numpy.random.Generator`` passed in, in this fixed order. Templates are
processed in file order (descriptive, counterfactual, cause, enable, prevent; never re-sorted by counts); for
each template:

1. starred words: for each paraphrase in order, for each distinct starred word in sorted order (the original
   iterated a ``set``), one ``rng.integers(len(alternatives))``;
2. the DFS: each time a side-input node is expanded, one ``rng.permutation(len(vocabulary))``;
3. for each produced question: the paraphrase (``rng.integers(len(paraphrases))``, drawn even when there is
   one paraphrase), then, for each bound parameter in binding order whose value is a synonyms key
   (``small``, ``large``, ``cube``), one ``rng.integers(len(alternatives))``.

A template that yields no question still consumes its step-1 draws and the shuffles of the nodes it expanded.

DFS order. The original pushes one child per value of the shuffled list onto a LIFO stack, so the *last* value
of the shuffled list is explored first; here the recursion iterates the shuffled list in reverse, and a
shuffle is drawn exactly when the original would draw it (when a state reaching that node is expanded), so
both the exploration order and the sequence of draws are the original's.

Pruning. As in the original, the search prunes at ``unique`` nodes only. For speed the candidate set that
feeds a chain of attribute filters is evaluated once per binding of the earlier parameters (the node-list
prefix ending at that set, run with :meth:`Program.from_nodes`, cached per (prefix, bindings)), and the
filters and ``unique`` are then applied to it with the evaluator's own module functions
(:func:`craft_dsl.semantics.filter_size` / ``filter_color`` / ``filter_shape`` and ``unique``), so the search
has no semantics of its own. ``fast=False`` in :func:`instantiate_dfs` evaluates every ``unique`` prefix as a
whole program instead (the tests check both give the same choices). Compiled prefixes are cached per process
(programs do not depend on the scene), so a worker compiles each template prefix once.

Deviations from the original, and why:

* answer rejection is not reproduced: with fresh counters in every real use it never rejects anything;
* a complete program whose answer is INVALID is skipped and the search goes on. In the original only
  ``unique`` produces ``'__INVALID__'``; ``filter_first``/``filter_last`` on an empty list and ``event_partner``
  on a foreign event raise and abort the whole video, whereas the DSL returns INVALID. No CRAFT template reaches
  those cases after a valid ``unique``, so the choices are unchanged;
* the saved ``program`` is :meth:`Program.to_nodes` (``outputs=sim``): the canonical node list, in which the
  templates' unused ``start_scene`` node 0 is dropped, so node indexes may differ from the template's by one;
* records also carry ``template_id`` (``"cause_0"``), which the original's question files do not have.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from functools import lru_cache
from typing import Any, Protocol

import numpy as np

from .. import semantics
from ..errors import CounterfactualUnavailable
from ..program import Program, to_json
from ..semantics import ObjectSet
from ..simulation import Simulation
from ..templates import Template, paraphrases, templates
from ..types import INVALID
from ..verify.records import question_record, template_id_of
from ..vocabulary import COLORS, SHAPES, SIZES
from .synonyms import SYNONYMS

__all__ = ["generate_questions", "instantiate_dfs", "perturbation_filter", "render_text", "star_paraphrases"]

_STAR = re.compile(r"\*(.+?)\*")

#: Side-input node type -> (the evaluator's module function, vocabulary enumerated by the DFS).
_SIDE_INPUT_MODULES: dict[str, tuple[Callable[[Simulation, ObjectSet, str], ObjectSet], tuple[str, ...]]] = {
    "filter_size": (semantics.filter_size, SIZES),
    "filter_color": (semantics.filter_color, COLORS),
    "filter_shape": (semantics.filter_shape, SHAPES),
}


# -- text ---------------------------------------------------------------------------------------------------


def star_paraphrases(texts: Sequence[str], rng: np.random.Generator) -> list[str]:
    """In each paraphrase, every distinct ``*word*`` (sorted) gets one synonym for all its occurrences."""
    out = []
    for text in texts:
        for word in sorted(set(_STAR.findall(text))):
            alternatives = SYNONYMS[word]
            text = text.replace(f"*{word}*", alternatives[int(rng.integers(len(alternatives)))])
        out.append(text)
    return out


def render_text(texts: Sequence[str], params: Mapping[str, str], rng: np.random.Generator) -> str:
    """Choose a (star-substituted) paraphrase, bind the placeholders with value synonyms, collapse spaces."""
    text = texts[int(rng.integers(len(texts)))]
    for placeholder, value in params.items():
        alternatives = SYNONYMS.get(value)
        if alternatives is not None:
            value = alternatives[int(rng.integers(len(alternatives)))]
        text = " ".join(text.replace(placeholder, value).split())
    return text


# -- depth-first instantiation ------------------------------------------------------------------------------


@lru_cache(maxsize=8192)
def _compiled(template_id: str, end: int, params: tuple[tuple[str, str], ...]) -> Program:
    """The program of a template's nodes 0..end with ``params`` bound (programs do not depend on the scene, so
    this cache is shared by all videos a process generates)."""
    return Program.from_nodes(templates()[template_id].nodes[: end + 1], dict(params))


def program_nodes(program: Program, sim: Simulation) -> list[dict[str, Any]]:
    """The record's ``program``: ``program.to_nodes(outputs=sim)`` (not cached: a cache keyed by the simulation
    would keep every simulation of a worker alive)."""
    return program.to_nodes(outputs=sim)


class _Search:
    """The DFS of one template over one simulation (see the module docstring)."""

    def __init__(self, template: Template, sim: Simulation, rng: np.random.Generator, fast: bool) -> None:
        self.template = template
        self.nodes = template.nodes
        self.sim = sim
        self.rng = rng
        self.fast = fast
        self._values: dict[tuple[int, tuple[tuple[str, str], ...]], Any] = {}

    def prefix_value(self, end: int, params: dict[str, str]) -> Any:
        """The value of node ``end`` (the program made of nodes 0..end), cached per (end, bindings)."""
        key = (end, tuple(params.items()))
        if key not in self._values:
            self._values[key] = _compiled(self.template.id, end, key[1]).run(self.sim)
        return self._values[key]

    def run(self) -> Iterator[tuple[dict[str, str], Program, Any]]:
        yield from self._visit(0, {}, {})

    def _visit(
        self, k: int, params: dict[str, str], sets: dict[int, tuple[int, ...]]
    ) -> Iterator[tuple[dict[str, str], Program, Any]]:
        nodes = self.nodes
        while k < len(nodes):
            node = nodes[k]
            side = node.get("side_inputs")
            if side:
                yield from self._expand(k, side[0], params, sets)
                return
            if node["type"] == "unique":
                (i,) = node["inputs"]
                if self.fast and i in sets:
                    if semantics.unique(self.sim, sets[i]) is INVALID:
                        return
                elif self.prefix_value(k, params) is INVALID:
                    return
            k += 1
        program = _compiled(self.template.id, len(nodes) - 1, tuple(params.items()))
        answer = program.run(self.sim)
        if answer is not INVALID:
            yield dict(params), program, answer

    def _expand(
        self, k: int, placeholder: str, params: dict[str, str], sets: dict[int, tuple[int, ...]]
    ) -> Iterator[tuple[dict[str, str], Program, Any]]:
        node = self.nodes[k]
        module, vocabulary = _SIDE_INPUT_MODULES[node["type"]]
        (i,) = node["inputs"]
        if self.fast:
            base = sets[i] if i in sets else self.prefix_value(i, params)
            if base is INVALID:  # cannot happen after the unique checks; kept as a guard
                return
        order = self.rng.permutation(len(vocabulary))
        for j in reversed(order.tolist()):  # the original's stack pops the last pushed child first
            value = vocabulary[j]
            child = {**params, placeholder: value}
            child_sets = sets
            if self.fast:
                child_sets = {**sets, k: module(self.sim, base, value)}
            yield from self._visit(k + 1, child, child_sets)


def instantiate_dfs(
    template: Template, sim: Simulation, rng: np.random.Generator, max_instances: int = 1, fast: bool = True
) -> list[tuple[dict[str, str], Program, Any]]:
    """The first ``max_instances`` complete valid instantiations in DFS order, as (params, program, answer).

    ``params`` is in binding order (``<Z>, <C>, <S>, <Z2>, ...``). Empty when the template has no valid
    instantiation on ``sim``.
    """
    found: list[tuple[dict[str, str], Program, Any]] = []
    if max_instances <= 0:
        return found
    for item in _Search(template, sim, rng, fast).run():
        found.append(item)
        if len(found) >= max_instances:
            break
    return found


# -- per video ----------------------------------------------------------------------------------------------


def _selected_templates(template_ids: Sequence[str] | None) -> list[Template]:
    every = templates()
    if template_ids is None:
        return list(every.values())
    wanted = set(template_ids)
    unknown = sorted(wanted - set(every))
    if unknown:
        raise ValueError(f"unknown template ids: {', '.join(unknown)} (known: descriptive_0 ... prevent_5)")
    return [t for tid, t in every.items() if tid in wanted]


def generate_questions(
    sim: Simulation,
    rng: np.random.Generator,
    *,
    video_index: int,
    video_filename: str,
    template_ids: Sequence[str] | None = None,
    instances_per_template: int = 1,
) -> list[dict[str, Any]]:
    """The CRAFT questions of one video, in the published record format (plus ``template_id``).

    One question per template that can be instantiated (at most ``instances_per_template``), templates in file
    order (``template_ids`` restricts them; default: all 67, the dropped ones included — dropping is a pipeline
    stage). Keys: ``video_filename``, ``video_index``, ``video`` (``f"{video_index:06d}"``), ``question``,
    ``program`` (:meth:`Program.to_nodes` with ``outputs=sim``), ``answer`` (bool, int or lowercase str),
    ``template_filename``, ``question_family_index``, ``question_index`` (running, 0-based), ``template_id``.
    Deterministic: the same ``sim`` and generator state give the same list (draw order: module docstring).
    """
    texts = paraphrases()
    records: list[dict[str, Any]] = []
    for template in _selected_templates(template_ids):
        starred = star_paraphrases(texts[template.id], rng)
        for params, program, answer in instantiate_dfs(template, sim, rng, instances_per_template):
            records.append(question_record(
                video_filename=video_filename, video_index=video_index, question=render_text(starred, params, rng),
                program=program_nodes(program, sim), answer=to_json(answer, original=True), family=template.family,
                family_index=template.index, question_index=len(records), template_id=template.id))
    return records


# -- perturbation check -------------------------------------------------------------------------------------


class Perturbable(Protocol):
    """A simulation that can re-run its whole scene from a perturbed start (e.g. a LiveSimulation)."""

    def perturbed(self, seed: int, amount: float = 0.02) -> Simulation: ...


def _answer_on(program: Program, sim: Simulation) -> Any:
    """The answer on a perturbed run, or None when it is INVALID or a counterfactual is unavailable."""
    try:
        answer = program.run(sim)
    except CounterfactualUnavailable:
        return None
    return None if answer is INVALID else to_json(answer, original=True)


def perturbation_filter(
    sim: Perturbable,
    questions: list[dict[str, Any]],
    rng: np.random.Generator,
    perturbations: int = 3,
    amount: float = 0.02,
) -> tuple[list[dict[str, Any]], dict[str, int]]:
    """Keep the questions whose answers survive every one of ``perturbations`` whole-scene perturbations.

    For each perturbation one seed ``int(rng.integers(2**31 - 1))`` is drawn (all seeds first, in order) and
    ``sim.perturbed(seed, amount)`` re-simulates the whole scene, factual run included; its counterfactuals are
    clean and not perturbed again. Each saved program is re-run on it; a question is kept when
    ``str(new answer) == str(saved answer)`` in all perturbations (INVALID or an unavailable
    counterfactual counts as a change). Questions already dropped are not re-checked (the result is the same).

    Returns the kept records (unchanged, ``question_index`` included) and the stats: ``{template_id: number of
    questions dropped}`` for every template present in ``questions`` (0 when none was dropped), in first-seen order.
    """
    seeds = [int(rng.integers(2**31 - 1)) for _ in range(perturbations)]
    stats: dict[str, int] = {}
    for q in questions:
        stats.setdefault(template_id_of(q), 0)
    alive = [(q, Program.from_nodes(q["program"])) for q in questions]
    for seed in seeds:
        if not alive:
            break
        psim = sim.perturbed(seed, amount)
        survivors = []
        for q, program in alive:
            if str(_answer_on(program, psim)) == str(q["answer"]):
                survivors.append((q, program))
            else:
                stats[template_id_of(q)] += 1
        alive = survivors
    return [q for q, _ in alive], stats
