"""Questions to programs: read a CRAFT question's text back into its template, parameters and program.

A CRAFT question is one paraphrase of one of the 67 templates (``template_texts.txt``) in which the generator
replaced every ``*starred*`` word by one of its synonyms and every placeholder (``<Z> <C> <S> <Z2> <C2> <S2>``) by a
size, colour or shape word. :func:`match_question` inverts that: it finds the template, the paraphrase and the
canonical parameter values, and returns ``templates()[template_id].program(params)``, the program the generator
saved for that question.

Accepted text (see docs/questions.md):

* every paraphrase of every template, the 19 basket-collision templates included, with any synonym of every
  starred word (each occurrence on its own, so "falls into ... go into" is read too);
* placeholder words: the canonical values, the generator's value synonyms (tiny, big, block), the DSL's aliases
  (grey, box, ball, sphere) and "square" for the cube (the CRAFT paper's figures), in the plural where the template
  says ``<S>s`` ("blocks", "boxes");
* the texts the dataset pipeline's post-process fixes were written for: "Is the ... is prevented by ..."
  (prevent_0-2) and "Will the ... collide with the basket the ... is removed?" (counterfactual_2, without "if");
* any letter case, any whitespace, commas anywhere or nowhere, and any run of final ``?``, ``.`` or ``!`` (or none).

How. Each paraphrase compiles, once, at first use, into a deterministic word automaton (starred-word synonyms
become a trie of their words; a placeholder becomes one edge per accepted word, labelled with the canonical
value). The union of all of them becomes one deterministic automaton by subset construction (about 1,000 states).
Reading a question costs one dictionary lookup per word, then one walk of the accepted paraphrase's own automaton
to collect the parameters; programs are cached per (template, parameters).

Ambiguity. The subset construction proves that no text is read by two paraphrases: no accepting state of the union
holds two of them, so every accepted text has exactly one (template, paraphrase, parameters). Building the
automaton fails if an edit of the templates ever makes two of them share a text (:func:`shared_texts` lists such
groups for any table of paraphrases).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from .errors import QuestionParseError
from .program import Program
from .templates import paraphrases, templates
from .vocabulary import COLORS, SHAPES, SIZES, VALUE_ALIASES

__all__ = [
    "END",
    "QUESTION_ALIASES",
    "QuestionMatch",
    "match_question",
    "question_to_program",
    "shared_texts",
    "value_words",
]

#: Placeholder words accepted in questions only (not in programs): the CRAFT paper's figures say "square".
QUESTION_ALIASES: dict[str, str] = {"square": "cube"}

#: Stands for the end of the question in :attr:`QuestionParseError.expected`.
END = "<end>"

_KINDS: dict[str, tuple[str, ...]] = {"Z": SIZES, "C": COLORS, "S": SHAPES}
_WORD = re.compile(r"\w+|[^\w\s]")
_FINAL_PUNCTUATION = frozenset("?.!")
_TEMPLATE_TOKEN = re.compile(r"\*([^*]+)\*|<([ZCS])(2?)>(s?)|(\w+)|([^\w\s])")
_STAR = re.compile(r"\*(.+?)\*")
#: Only this many leading words are compared to find the closest template (the longest paraphrase has 19 words).
_DIAGNOSED_WORDS = 64

#: Texts the post-process fixes were written for: (template ids, paraphrase text before, the unfixed text).
_UNFIXED_FORMS: tuple[tuple[frozenset[str], str, str], ...] = (
    (frozenset({"prevent_0", "prevent_1", "prevent_2"}), "Is the <Z2> <C2> <S2> *prevented* by",
     "Is the <Z2> <C2> <S2> is *prevented* by"),
    (frozenset({"counterfactual_2"}), "*basket* if the", "*basket* the"),
)


def _plural(word: str) -> str:
    return word + "es" if word.endswith(("s", "x", "sh", "ch")) else word + "s"


def value_words(kind: str, plural: bool = False) -> dict[str, str]:
    """Every word accepted for a placeholder of ``kind`` (``"Z"`` size, ``"C"`` colour, ``"S"`` shape) -> its
    canonical value: the value, the generator's synonyms, VALUE_ALIASES and QUESTION_ALIASES (plural forms with
    ``plural``)."""
    from .synonyms import SYNONYMS

    aliases = {**VALUE_ALIASES, **QUESTION_ALIASES}
    out: dict[str, str] = {}
    for value in _KINDS[kind]:
        for word in (value, *SYNONYMS.get(value, ()), *(a for a, v in aliases.items() if v == value)):
            out[_plural(word) if plural else word] = value
    return out


# -- one paraphrase ---------------------------------------------------------------------------------------------

Edge = tuple[int, str | None, str | None]  # (next state, placeholder bound by the word, its canonical value)


@dataclass(frozen=True)
class _Choice:
    """One position of a paraphrase: alternative word sequences, or the words of a placeholder."""

    phrases: tuple[tuple[str, ...], ...]
    placeholder: str | None = None
    values: Mapping[str, str] | None = None


def _choices(text: str) -> list[_Choice]:
    from .synonyms import SYNONYMS

    out: list[_Choice] = []
    for star, kind, two, plural, word, mark in _TEMPLATE_TOKEN.findall(text):
        if star:
            out.append(_Choice(tuple(tuple(p.split()) for p in SYNONYMS[star])))
        elif kind:
            values = value_words(kind, bool(plural))
            out.append(_Choice(tuple((w,) for w in values), f"<{kind}{two}>", values))
        elif word:
            out.append(_Choice(((word.lower(),),)))
        elif mark not in ",?":
            raise ValueError(f"paraphrase {text!r}: unexpected character {mark!r}")
    return out


def _compile(choices: Sequence[_Choice]) -> tuple[list[dict[str, Edge]], int]:
    """A deterministic automaton whose states are numbered in topological order; returns (edges, final state)."""
    edges: list[dict[str, Edge]] = [{}]
    state = 0
    for choice in choices:
        ids: dict[tuple[str, ...], int] = {(): state}
        for phrase in choice.phrases:
            for k in range(1, len(phrase)):
                if phrase[:k] not in ids:
                    ids[phrase[:k]] = len(edges)
                    edges.append({})
        end = len(edges)
        edges.append({})
        for phrase in choice.phrases:
            for k, word in enumerate(phrase):
                last = k == len(phrase) - 1
                target = end if last else ids[phrase[: k + 1]]
                value = choice.values[word] if choice.values is not None else None
                old = edges[ids[phrase[:k]]].get(word)
                if old is not None and old[0] != target:
                    raise ValueError(f"alternative {' '.join(phrase)!r} is a prefix of another one")
                edges[ids[phrase[:k]]][word] = (target, choice.placeholder, value)
        state = end
    return edges, state


@dataclass(frozen=True, eq=False)
class _Paraphrase:
    """One paraphrase of one template, compiled."""

    template_id: str
    index: int
    text: str  # as shown in messages: starred words without stars
    edges: list[dict[str, Edge]]
    final: int
    placeholders: tuple[str, ...]  # in the template's binding order

    def bind(self, words: Sequence[str]) -> dict[str, str]:
        """The parameters of an accepted word sequence, in binding order."""
        edges = self.edges
        state = 0
        found: dict[str, str] = {}
        for word in words:
            state, placeholder, value = edges[state][word]
            if placeholder is not None and value is not None:
                found[placeholder] = value
        return {p: found[p] for p in self.placeholders}

    def prefix(self, words: Sequence[str]) -> tuple[int, int]:
        """(number of leading words this paraphrase accepts, the state reached)."""
        state = 0
        for k, word in enumerate(words):
            edge = self.edges[state].get(word)
            if edge is None:
                return k, state
            state = edge[0]
        return len(words), state

    def distance(self, words: Sequence[str]) -> int:
        """Word-level edit distance between ``words`` and the closest text this paraphrase accepts."""
        targets = [{t for t, _, _ in out.values()} for out in self.edges]

        def skip(row: list[int]) -> list[int]:  # leave out paraphrase words (states are in topological order)
            for s, ts in enumerate(targets):
                for t in ts:
                    row[t] = min(row[t], row[s] + 1)
            return row

        row = skip([0] + [len(words) + len(self.edges)] * (len(self.edges) - 1))
        for word in words:
            new = [c + 1 for c in row]  # an extra question word
            for s, out in enumerate(self.edges):
                for t in targets[s]:
                    new[t] = min(new[t], row[s] + 1)  # a different word
                hit = out.get(word)
                if hit is not None:
                    new[hit[0]] = min(new[hit[0]], row[s])
            row = skip(new)
        return row[self.final]


def _paraphrases(table: Mapping[str, Sequence[str]]) -> list[_Paraphrase]:
    """Every paraphrase of ``table`` (template id -> texts), then the unfixed forms, compiled."""
    known = templates()
    items: list[tuple[str, int, str]] = [(tid, i, text) for tid, texts in table.items() for i, text in enumerate(texts)]
    for ids, before, unfixed in _UNFIXED_FORMS:
        items += [(tid, i, text.replace(before, unfixed)) for tid, i, text in list(items)
                  if tid in ids and before in text]
    out = []
    for tid, i, text in items:
        edges, final = _compile(_choices(text))
        in_text = [f"<{k}{two}>" for _, k, two, _, _, _ in _TEMPLATE_TOKEN.findall(text) if k]
        if len(set(in_text)) != len(in_text):
            raise ValueError(f"{tid} paraphrase {i}: a placeholder appears twice")
        order = tuple(in_text)
        if tid in known:
            order = known[tid].placeholders
            if set(order) != set(in_text):
                raise ValueError(f"{tid} paraphrase {i}: placeholders {in_text} but the program binds {list(order)}")
        out.append(_Paraphrase(tid, i, _STAR.sub(r"\1", text), edges, final, order))
    return out


# -- all paraphrases --------------------------------------------------------------------------------------------


class _Automaton:
    """The union of all paraphrases as one deterministic word automaton (subset construction)."""

    def __init__(self, items: Sequence[_Paraphrase]) -> None:
        self.paraphrases = list(items)
        self.transitions: list[dict[str, int]] = []
        self.accepting: list[int | None] = []
        self.shared: list[tuple[int, ...]] = []
        start = frozenset((p, 0) for p in range(len(items)))
        index = {start: 0}
        pending = [start]
        while len(self.transitions) < len(pending):
            states = pending[len(self.transitions)]
            moves: dict[str, set[tuple[int, int]]] = {}
            for p, s in states:
                for word, (t, _, _) in items[p].edges[s].items():
                    moves.setdefault(word, set()).add((p, t))
            row: dict[str, int] = {}
            for word, targets in moves.items():
                key = frozenset(targets)
                if key not in index:
                    index[key] = len(pending)
                    pending.append(key)
                row[word] = index[key]
            self.transitions.append(row)
            done = tuple(sorted(p for p, s in states if s == items[p].final))
            self.accepting.append(done[0] if done else None)
            if len({(items[p].template_id, items[p].index) for p in done}) > 1:
                self.shared.append(done)

    def diagnose(self, text: str) -> QuestionParseError:
        """The error for a text that no paraphrase accepts: the closest paraphrase and where the text leaves it."""
        shown = _strip([w for w in _WORD.findall(text) if w != ","])
        words = [w.lower() for w in shown]
        quoted = " ".join(text.split())
        if len(quoted) > 200:
            quoted = quoted[:197] + "..."
        if not words:
            return QuestionParseError(f'no CRAFT template matches "{quoted}": the question is empty', question=text)
        every = self.paraphrases
        head = words[:_DIAGNOSED_WORDS]
        best = every[min(range(len(every)), key=lambda n: (every[n].distance(head), -every[n].prefix(head)[0], n))]
        matched, state = best.prefix(words)
        expected = tuple(best.edges[state]) + ((END,) if state == best.final else ())
        allowed = _alternatives(expected)
        if matched < len(words):
            where = f"diverges at word {matched + 1} {shown[matched]!r} (expected {allowed})"
            found: str | None = shown[matched]
        else:
            where = f"diverges at word {matched + 1}, where the question ends (expected {allowed})"
            found = None
        return QuestionParseError(
            f'no CRAFT template matches "{quoted}": closest is {best.template_id} "{best.text}", which {where}',
            question=text, template_id=best.template_id, paraphrase=best.index, word_index=matched + 1,
            found=found, expected=expected,
        )


def _alternatives(words: Sequence[str]) -> str:
    shown = ["the end of the question" if w == END else repr(w) for w in words]
    return shown[0] if len(shown) == 1 else ", ".join(shown[:-1]) + " or " + shown[-1]


def _strip(words: list[str]) -> list[str]:
    while words and words[-1] in _FINAL_PUNCTUATION:
        words.pop()
    return words


def _words(text: str) -> list[str]:
    """The question's words: lower case, commas dropped, final punctuation dropped."""
    words = _WORD.findall(text.lower())
    if "," in words:
        words = [w for w in words if w != ","]
    return _strip(words)


@lru_cache(maxsize=1)
def _automaton() -> _Automaton:
    automaton = _Automaton(_paraphrases(paraphrases()))
    if automaton.shared:
        groups = "; ".join(", ".join(f"{automaton.paraphrases[p].template_id} paraphrase "
                                     f"{automaton.paraphrases[p].index}" for p in g) for g in automaton.shared)
        raise RuntimeError(f"template texts overlap, decide which program such a question means: {groups}")
    return automaton


def question_words() -> list[str]:
    """Every word a question can contain (lower case; the words of every paraphrase, synonym and value word),
    sorted: the closed question vocabulary of CRAFT."""
    return sorted({word for row in _automaton().transitions for word in row})


def question_tokens(text: str) -> list[str]:
    """A question's tokens for a vocabulary: lower-cased words, with each punctuation mark a token of its own."""
    return _WORD.findall(text.lower())


def shared_texts(table: Mapping[str, Sequence[str]] | None = None) -> list[tuple[tuple[str, int], ...]]:
    """Groups of (template id, paraphrase index) that can produce one and the same question text.

    ``table`` maps template ids to paraphrases in the ``template_texts.txt`` notation (default: the 67 CRAFT
    templates, for which the answer is ``[]``). Exact: it reads the accepting states of the union automaton.
    """
    automaton = _Automaton(_paraphrases(paraphrases() if table is None else table))
    out: list[tuple[tuple[str, int], ...]] = []
    for group in automaton.shared:
        ids = tuple(dict.fromkeys((automaton.paraphrases[p].template_id, automaton.paraphrases[p].index)
                                  for p in group))
        if ids not in out:
            out.append(ids)
    return out


# -- public API -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class QuestionMatch:
    """What a question text is: its template, paraphrase index, parameters (canonical values, in binding order
    ``<Z> <C> <S> <Z2> <C2> <S2>``) and the template's program with those parameters bound."""

    template_id: str
    paraphrase: int
    params: dict[str, str] = field(hash=False)
    program: Program

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict; ``program`` is the canonical text form."""
        return {"template_id": self.template_id, "paraphrase": self.paraphrase, "params": dict(self.params),
                "program": str(self.program)}


@lru_cache(maxsize=16384)
def _program(template_id: str, params: tuple[tuple[str, str], ...]) -> Program:
    return templates()[template_id].program(dict(params))


def match_question(text: str) -> QuestionMatch:
    """Read a CRAFT question: template, paraphrase, parameters and program.

    Raises :class:`~craft_dsl.errors.QuestionParseError` (naming the closest template and the word where the text
    diverges from it) when no template accepts the text.
    """
    automaton = _automaton()
    words = _words(text)
    transitions = automaton.transitions
    state = 0
    for word in words:
        following = transitions[state].get(word)
        if following is None:
            raise automaton.diagnose(text)
        state = following
    accepted = automaton.accepting[state]
    if accepted is None:
        raise automaton.diagnose(text)
    paraphrase = automaton.paraphrases[accepted]
    params = paraphrase.bind(words)
    return QuestionMatch(paraphrase.template_id, paraphrase.index, params,
                         _program(paraphrase.template_id, tuple(params.items())))


def question_to_program(text: str) -> Program:
    """The program of a CRAFT question text (see :func:`match_question`)."""
    return match_question(text).program
