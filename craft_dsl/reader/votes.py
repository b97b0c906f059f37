"""Counterfactual answers voted over perturbed replays.

A counterfactual run replays the perceived run without one object: the bodies it reaches are re-simulated from their
perceived states. Where chaotic contacts follow, the last digits of those states decide the outcome, and the
reader's reading of them is a few pixels off. So the answer of a question that reads a counterfactual is the majority
of the replay and of replays whose bodies start with their velocities scaled by up to a few percent
(:meth:`craft_dsl.perception.world.SceneModel.perturbed`): the answer that most nearby starts give. CRAFT keeps only
questions whose answers survive perturbations of the simulation, so the video's answer is the one most of its
neighbourhood gives.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

from ..errors import CraftError
from ..program import Program, parse
from ..registry import REGISTRY
from .records import Answer, format_answer

if TYPE_CHECKING:
    from ..perception.world import SceneModel

#: Perturbed replays whose answers vote with the reader's own on a counterfactual question.
VOTES = 6
#: The largest relative change of a body's velocity in a perturbed replay.
VOTE_AMOUNT = 0.05
#: The seed of the first perturbed replay (the others take the next ones).
VOTE_SEED = 1000


def uses_counterfactuals(program: Program) -> bool:
    """Whether ``program`` reads a counterfactual run (a module of the registry's ``counterfactual`` category)."""
    return any(node.module is not None and REGISTRY[node.module].category == "counterfactual"
               for node in program.nodes)


def majority(tally: Counter[str], own: str) -> str:
    """The answer with the most votes in ``tally``: ``own`` where it is among them, else the least of them as text."""
    best = max(tally.values())
    return own if tally[own] == best else min(v for v, n in tally.items() if n == best)


def decided(tally: Counter[str], own: str, left: int) -> bool:
    """Whether ``left`` more votes can no longer change the :func:`majority` of ``tally`` (a tie keeps ``own``)."""
    ranked = tally.most_common()
    if tally[own] == ranked[0][1]:  # own leads (or ties for the lead): every rival must stay at most level with it
        return tally[own] >= max((n for v, n in ranked if v != own), default=0) + left
    return ranked[0][1] > (ranked[1][1] if len(ranked) > 1 else 0) + left  # another leads: strictly, ties aside


def vote_counterfactuals(model: SceneModel, answers: Sequence[Answer], votes: int = VOTES,
                         amount: float = VOTE_AMOUNT) -> list[Answer]:
    """Each counterfactual question's answer as the majority of its replay against the perceived run and ``votes``
    replays whose bodies start from their perceived states with velocities scaled by up to ``amount``
    (:meth:`SceneModel.perturbed`, seeds :data:`VOTE_SEED` on); a tie keeps the replay's own answer. Chaotic contacts
    make the last digits of a perceived state decide some counterfactual outcomes; an answer that most nearby
    starts give is more often the video's (the dataset keeps only questions whose answers survive perturbations).
    A replay where the program has no answer (INVALID, an unavailable counterfactual) does not vote. A question stops
    being replayed once the votes left cannot change its majority (most are stable: the first three replays agree
    with its own answer), so the answers are those of all ``votes`` replays at about half their cost. Answers that are
    guesses, premises or distribution modes are left as they are; each voted answer records the ``votes`` cast."""
    if votes <= 0:
        return list(answers)
    programs: dict[int, Program] = {}
    for i, a in enumerate(answers):
        if a.program is None or a.answer is None or a.fallback or a.premise is not None or a.probability is not None:
            continue
        program = parse(a.program)
        if uses_counterfactuals(program):
            programs[i] = program
    if not programs:
        return list(answers)
    tallies: dict[int, Counter[str]] = {i: Counter({str(answers[i].answer): 1}) for i in programs}
    open_ = list(programs)
    for k in range(votes):
        sim = model.perturbed(VOTE_SEED + k, amount).simulation()
        for i in open_:
            try:
                value = format_answer(programs[i].run(sim))
            except CraftError:
                continue
            if value is not None:
                tallies[i][value] += 1
        left = votes - k - 1
        open_ = [i for i in open_ if not decided(tallies[i], str(answers[i].answer), left)]
        if not open_:
            break
    out = list(answers)
    for i, tally in tallies.items():
        out[i] = replace(answers[i], answer=majority(tally, str(answers[i].answer)), votes=dict(sorted(tally.items())))
    return out
