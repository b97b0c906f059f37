"""Free-text answers of language models, read into the dataset's answer vocabulary.

A model asked a CRAFT question in words answers in words: ``"Two."``, ``"The answer is: 2"``, ``"**Yes**, it
does"``, ``"B) red"``, ``"I cannot tell from the video."``. :func:`parse_answer` reads such a text into the answer
as ``dataset_minimal.json`` spells it (``"2"``, ``"Red"``, ``"Cube"``, ``"True"``/``"False"``), or ``None`` when
the text gives no answer of the expected kind (a refusal, a hedge between two values, nothing recognisable).

The expected kind is never guessed from the text: it is the type of the question's program
(:func:`kind_of_program`), known for every template without a simulation (:func:`kind_of_template`), since a
template's answer type does not depend on its parameters. CRAFT's 67 templates answer counts (34), booleans
(29), colours (2) and shapes (2); sizes are read too, for programs that end in ``QuerySize``.

How a text is read (every step is tested in ``tests/test_harness_answers.py``):

1. reasoning is dropped: a ``<think>...</think>`` block, or what precedes the last ``<answer>...</answer>`` tag
   (whose content is then read); markdown emphasis, code marks, headings, quotes and brackets are removed;
2. the *answer segment* is chosen: the text after the last "answer is" / "answer:" / "final answer" marker when
   there is one, else the first sentence (or line); a leading multiple-choice label (``B)``, ``(b)``, ``B.``) is
   dropped;
3. a segment that is a refusal, about the model's own inability ("I cannot tell", "not sure", "unable to
   determine", "impossible to say", "no idea"), gives ``None`` unless a value comes before the refusal; a negated
   answer is no refusal ("It cannot enter the basket" answers False);
4. the first value of the expected kind in the segment is the answer, unless the segment offers two different
   values joined by "or" (a hedge: ``None``). Without a value in the segment, the rest of the text is searched the
   same way (``"Looking at the video closely. There are two."``).

Values: counts are digits or number words up to twenty (``"none"``, ``"no objects"``, ``"zero"`` are 0;
``"once"``, ``"twice"`` 1 and 2); booleans are yes/no, true/false, correct/incorrect, or a bare "it does" / "it does
not"; colours the eight CRAFT colours (``grey`` for gray); shapes cube, triangle, circle with the words a viewer of
the 2D videos uses (square, block, box for cube; ball, sphere, disc for circle) and their plurals.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any, Literal

from ..errors import CraftError
from ..program import Program
from ..templates import templates
from ..types import DslType
from ..vocabulary import COLORS, SHAPES, SIZES

AnswerKind = Literal["count", "bool", "color", "shape", "size"]
#: The answer kinds, in the order of CRAFT's template counts.
ANSWER_KINDS: tuple[AnswerKind, ...] = ("count", "bool", "color", "shape", "size")
#: What the prompt calls each kind (docs/evaluate.md).
KIND_PHRASES: dict[str, str] = {
    "count": "a whole number (0, 1, 2, ...)",
    "bool": "True or False",
    "color": "one colour: " + ", ".join(COLORS),
    "shape": "one shape: " + ", ".join(SHAPES),
    "size": "one size: " + ", ".join(SIZES),
}
#: The ``answer_type`` column of ``dataset_minimal.json`` for each kind.
ANSWER_TYPE_OF_KIND: dict[str, str] = {"count": "Count", "bool": "Boolean", "color": "Color", "shape": "Shape",
                                       "size": "Size"}

_KIND_OF_TYPE: dict[DslType, AnswerKind] = {
    DslType.INTEGER: "count", DslType.BOOL: "bool", DslType.COLOR: "color", DslType.SHAPE: "shape",
    DslType.SIZE: "size",
}
# Any binding gives a template its type; these are vocabulary words of the placeholders' kinds.
_DUMMY_PARAMS = {"<Z>": "small", "<C>": "red", "<S>": "cube", "<Z2>": "large", "<C2>": "blue", "<S2>": "circle"}


def kind_of_program(program: Program) -> AnswerKind:
    """The answer kind of a checked program: the kind of its result type (a :class:`CraftError` for a program
    that does not answer, e.g. one returning an ObjectSet)."""
    kind = _KIND_OF_TYPE.get(program.type)
    if kind is None:
        raise CraftError(f"the program returns {program.type}, not an answer (Integer, Bool, Color, Shape, Size)")
    return kind


@cache
def kind_of_template(template_id: str) -> AnswerKind:
    """The answer kind of a CRAFT template (``"descriptive_22"`` -> ``"color"``), from its program's type."""
    template = templates().get(template_id)
    if template is None:
        raise CraftError(f"{template_id!r} is not a CRAFT template id (e.g. 'descriptive_0' ... 'prevent_5')")
    params = {p: _DUMMY_PARAMS.get(p, "red") for p in template.placeholders}
    return kind_of_program(template.program(params))


def kind_of_record(record: Mapping[str, Any]) -> AnswerKind:
    """The answer kind of a question record (a ``dataset_minimal.json`` record, a Hugging Face row, a
    ``dataset.json`` question): from its ``template_id`` (or ``template_filename`` and
    ``question_family_index``), else from its program (``program_nodes``, ``program`` as a node list or text)."""
    tid = record.get("template_id")
    if not tid and record.get("template_filename") is not None and record.get("question_family_index") is not None:
        stem = str(record["template_filename"]).rsplit("/", 1)[-1].removesuffix(".json")
        tid = f"{stem}_{record['question_family_index']}"
    if tid:
        return kind_of_template(str(tid))
    nodes = record.get("program_nodes") or record.get("program")
    if isinstance(nodes, list) and nodes:
        return kind_of_program(Program.from_nodes(nodes))
    if isinstance(nodes, str) and nodes.strip():
        return kind_of_program(Program.parse(nodes))
    raise CraftError("the record names no template (template_id, or template_filename and question_family_index) "
                     "and has no program: its answer kind is unknown")


def check_kind(kind: str) -> AnswerKind:
    """``kind`` as an :data:`AnswerKind` (a :class:`CraftError` naming the allowed kinds otherwise)."""
    for k in ANSWER_KINDS:
        if k == kind:
            return k
    raise CraftError(f"unknown answer kind {kind!r}; allowed: {', '.join(ANSWER_KINDS)}")


# -- the words of each kind -------------------------------------------------------------------------------------

_NUMBER_WORDS: dict[str, int] = {
    w: i for i, w in enumerate(
        ["zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten", "eleven", "twelve",
         "thirteen", "fourteen", "fifteen", "sixteen", "seventeen", "eighteen", "nineteen", "twenty"])
}
_NUMBER_WORDS.update({"none": 0, "no": 0, "nothing": 0, "nobody": 0, "neither": 0, "once": 1, "twice": 2,
                      "thrice": 3, "single": 1, "a single": 1, "no one": 0, "not any": 0, "a pair": 2,
                      "both": 2, "zero times": 0})

_TRUE_WORDS = ("yes", "true", "correct", "yep", "yeah", "affirmative", "indeed", "y")
_FALSE_WORDS = ("no", "false", "incorrect", "wrong", "nope", "negative", "n")

_COLOR_WORDS: dict[str, str] = {c: c for c in COLORS}
_COLOR_WORDS.update({"grey": "gray", "greyish": "gray", "grayish": "gray", "reddish": "red", "bluish": "blue",
                     "greenish": "green", "brownish": "brown", "purplish": "purple", "violet": "purple",
                     "yellowish": "yellow", "turquoise": "cyan", "aqua": "cyan"})

_SHAPE_WORDS: dict[str, str] = {}
for _canon, _words in {"cube": ("cube", "square", "block", "box", "cuboid", "rectangle"),
                       "triangle": ("triangle", "triangular", "wedge"),
                       "circle": ("circle", "circular", "ball", "sphere", "disc", "disk", "round")}.items():
    for _w in _words:
        _SHAPE_WORDS[_w] = _canon
        _SHAPE_WORDS[_w + "s"] = _canon
        _SHAPE_WORDS[_w + "es"] = _canon
_SHAPE_WORDS["boxes"] = "cube"

_SIZE_WORDS: dict[str, str] = {"small": "small", "large": "large", "big": "large", "tiny": "small",
                               "little": "small", "smaller": "small", "larger": "large", "bigger": "large"}


def _alternation(words: Sequence[str]) -> str:
    return "|".join(re.escape(w) for w in sorted(words, key=len, reverse=True))


_COUNT_RE = re.compile(r"(?<![\w.])(\d{1,18})(?:\.0+)?(?![\w.]\d)|\b(" + _alternation(list(_NUMBER_WORDS)) + r")\b")
_BOOL_RE = re.compile(r"\b(" + _alternation([*_TRUE_WORDS, *_FALSE_WORDS]) + r")\b")
_COLOR_RE = re.compile(r"\b(" + _alternation(list(_COLOR_WORDS)) + r")\b")
_SHAPE_RE = re.compile(r"\b(" + _alternation(list(_SHAPE_WORDS)) + r")\b")
_SIZE_RE = re.compile(r"\b(" + _alternation(list(_SIZE_WORDS)) + r")\b")

# "it does" / "it does not" without a yes/no word: the verb of a yes/no question, affirmed or negated
_NEGATED_VERB = re.compile(r"\b(?:does|did|do|is|was|are|were|will|would|can|could|has|had|have)\s*(?:not\b|n't\b)"
                           r"|\b(?:doesn't|didn't|don't|isn't|wasn't|aren't|weren't|won't|wouldn't|hasn't|hadn't"
                           r"|haven't|can't|couldn't|never)\b|^(?:\w+\s+)?not\b")
_AFFIRMED_VERB = re.compile(r"^(?:(?:it|they|he|she|that|this)\s+)?(?:does|did|do|is|was|are|were|will|would|has|had"
                            r"|have|can|could|causes|caused|enables|enabled|prevents|prevented)\b")

# A refusal is about the model's own inability ("I cannot tell", "impossible to determine", "not sure"), not a
# negated answer ("It cannot enter the basket", which answers False).
_INABILITY = r"(?:cannot|can\s*not|can't|could\s*not|couldn't|unable\s+to|not\s+able\s+to|impossible\s+to" \
             r"|not\s+possible\s+to|hard\s+to|difficult\s+to|no\s+way\s+to)"
_REFUSAL = re.compile(
    r"\b(?:i|we)\s*(?:'m|am|are)?\s*(?:cannot|can\s*not|can't|could\s*not|couldn't|unable|not\s+able)\b"
    r"|\b" + _INABILITY + r"\s+(?:be\s+)?(?:tell|say|determine|determined|know|see|answer|answered|judge|infer"
    r"|decide|confirm|verify|identify|watch|view|access|count|provide|give|sure)\b"
    r"|\b(?:not\s+(?:sure|certain|clear|determinable)|unclear|uncertain|unknown|don't\s+know|do\s+not\s+know"
    r"|no\s+idea|no\s+clue|insufficient|as\s+an\s+ai|i'm\s+sorry|i\s+am\s+sorry|n/a)\b|^sorry\b")
# a refusal word that nevertheless answers ("No, I cannot see it moving"): only when no value of the kind comes
# before the refusal in the segment; see _read_segment

_THINK = re.compile(r"<think>.*?(?:</think>|$)", re.S | re.I)
_ANSWER_TAG = re.compile(r"<answer>(.*?)(?:</answer>|$)", re.S | re.I)
_MARKER = re.compile(r"(?:final\s+answer|answer|prediction|response)\s*(?:is|would\s+be|will\s+be|:|=|-)\s*:?\s*",
                     re.I)
_CHOICE = re.compile(r"^\s*(?:\(\s*[a-h]\s*\)|[a-h]\s*[).:](?!\w))\s*", re.I)
_MARKUP = re.compile(r"[*_`#>|~\[\]{}\"“”‘«»]|'(?=\W|$)|(?<=\W)'|^'")
_SENTENCE_END = re.compile(r"[.!?;](?:\s|$)|\n")


def _clean(text: str) -> str:
    text = _THINK.sub(" ", text)
    tags = _ANSWER_TAG.findall(text)
    if tags:
        text = tags[-1]
    text = _MARKUP.sub(" ", text.replace("\u2019", "'"))
    return text.lower()


def _values(segment: str, kind: AnswerKind) -> list[tuple[int, int, str]]:
    """(start, end, canonical value) of every value of ``kind`` in the lower-case ``segment``."""
    out: list[tuple[int, int, str]] = []
    if kind == "count":
        for m in _COUNT_RE.finditer(segment):
            value = str(int(m.group(1))) if m.group(1) else str(_NUMBER_WORDS[m.group(2)])
            out.append((m.start(), m.end(), value))
    elif kind == "bool":
        for m in _BOOL_RE.finditer(segment):
            word = m.group(1)
            if len(word) == 1 and segment.strip() != word:
                continue  # "y" / "n" only as the whole answer
            out.append((m.start(), m.end(), "True" if word in _TRUE_WORDS else "False"))
    else:
        pattern, words = {"color": (_COLOR_RE, _COLOR_WORDS), "shape": (_SHAPE_RE, _SHAPE_WORDS),
                          "size": (_SIZE_RE, _SIZE_WORDS)}[kind]
        for m in pattern.finditer(segment):
            out.append((m.start(), m.end(), words[m.group(1)].capitalize()))
    return out


def _read_segment(segment: str, kind: AnswerKind) -> tuple[str | None, bool]:
    """(the answer of one segment or None, whether the segment settles the question: a value, a refusal or a
    hedge)."""
    segment = _CHOICE.sub("", segment).strip()
    if not segment:
        return None, False
    values = _values(segment, kind)
    refusal = _REFUSAL.search(segment)
    if kind == "count" and values and values[0][2] == "0" and segment[values[0][0]:values[0][1]] == "no":
        # "no" counts only before a noun ("no objects", "no collisions"), not as a yes/no answer
        after = segment[values[0][1]:].lstrip(" ,")
        if not after or not after[0].isalpha() or after.startswith(("i ", "it ", "the ", "there ")):
            values = values[1:]
    if refusal is not None:
        values = [v for v in values if not refusal.start() <= v[0] < refusal.end()]  # "no" of "no idea"
        if not values or values[0][0] > refusal.start():
            return None, True
    if kind == "bool" and not values:
        negated = _NEGATED_VERB.search(segment)
        if negated is not None:
            return "False", True
        if _AFFIRMED_VERB.search(segment):
            return "True", True
        return None, False
    if not values:
        return None, False
    first = values[0][2]
    for start, _end, value in values[1:]:
        if value != first and re.search(r"\bor\b", segment[values[0][1]:start]):
            return None, True  # "red or blue": a hedge
    return first, True


def _segments(text: str) -> list[str]:
    """The answer segment first, then the remaining sentences in order."""
    markers = list(_MARKER.finditer(text))
    if markers:
        after = text[markers[-1].end():]
        first = _SENTENCE_END.split(after.strip(), maxsplit=1)[0]
        rest = text[:markers[-1].start()]
        return [first, *_sentences(rest)]
    return _sentences(text)


def _sentences(text: str) -> list[str]:
    return [s for s in (p.strip(" ,:-\t") for p in _SENTENCE_END.split(text)) if s]


def parse_answer(text: Any, kind: str) -> str | None:
    """The answer a free-text model output gives, spelled as ``dataset_minimal.json`` spells answers (``"2"``,
    ``"True"``, ``"Red"``, ``"Cube"``, ``"Small"``), or None (no answer of ``kind``: a refusal, a hedge, nothing
    recognisable). ``kind`` is the question's :data:`AnswerKind` (:func:`kind_of_template`).

    ``text`` may also be a bool or an int (already an answer) or a chat completion (see :func:`completion_text`).
    """
    k = check_kind(kind)
    if isinstance(text, bool):
        return ("True" if text else "False") if k == "bool" else None
    if isinstance(text, int):
        return str(text) if k == "count" and text >= 0 else None
    cleaned = _clean(completion_text(text))
    for segment in _segments(cleaned):
        answer, settled = _read_segment(segment, k)
        if settled:
            return answer
    return None


def completion_text(completion: Any) -> str:
    """The text of a model output: a string, or a chat completion as TRL and lmms-eval pass them (a list of
    messages ``{"role", "content"}``, the last assistant message's content; a content that is a list of parts
    ``{"type": "text", "text"}`` is joined)."""
    if isinstance(completion, str):
        return completion
    if isinstance(completion, Mapping):
        return _content_text(completion.get("content", ""))
    if isinstance(completion, Sequence) and completion:
        messages = [m for m in completion if isinstance(m, Mapping)]
        if len(messages) != len(completion):
            odd = type(next(m for m in completion if not isinstance(m, Mapping))).__name__
            raise CraftError("a completion must be a string or a list of chat messages {'role', 'content'}, found "
                             f"a list holding {odd}")
        assistant = [m for m in messages if m.get("role", "assistant") == "assistant"]
        return _content_text((assistant or messages)[-1].get("content", ""))
    if isinstance(completion, Sequence):
        return ""
    raise CraftError(f"a completion must be a string or a list of chat messages, found {type(completion).__name__}")


def _content_text(content: Any) -> str:
    if isinstance(content, str):
        return content
    if isinstance(content, Sequence):
        return " ".join(str(p.get("text", "")) for p in content if isinstance(p, Mapping) and p.get("type") == "text")
    return "" if content is None else str(content)


__all__ = ["ANSWER_KINDS", "ANSWER_TYPE_OF_KIND", "KIND_PHRASES", "AnswerKind", "check_kind", "completion_text",
           "kind_of_program", "kind_of_record", "kind_of_template", "parse_answer"]
