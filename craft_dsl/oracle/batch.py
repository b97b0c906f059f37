"""Scoring a batch of predicted programs at once: the oracle inside a training loop.

A policy-gradient step samples several programs per question and scores each on its video's simulation.
:func:`run_batch` takes the whole batch (any form, one simulation or one per program) and returns one outcome
and answer per program, exactly those of :func:`~craft_dsl.oracle.program_outcome` run on each program alone.
The work the programs share is done once:

* programs are read into one hash-consed node table for the whole batch (:class:`~craft_dsl.checker.ProgramBuilder`):
  a call is checked once per distinct (module token, argument) combination, however many programs contain it,
  and a program written twice in the same form is read once (node lists: the same list object, and equal lists
  by :func:`node_list_key` while the batch repeats lists often enough for keys to pay);
* every node the batch's programs need is evaluated once per simulation, so shared sub-programs
  (``SceneAtStart()``, ``FilterColor(..., "red")``, ``Events()`` and its filters) cost one evaluation per
  simulation; counterfactual event sets are computed once per (simulation, removed object) by the
  simulation's own cache;
* token sequences (prefix, postfix), node lists and binding-free text are read by batch readers that keep
  a memo of checked calls; what they leave (other spellings of tokens and values, node lists of other shapes,
  text with ``Var`` bindings or with errors) is read by the single-program readers, through a
  :class:`~craft_dsl.oracle.ProgramCache`, and its nodes join the same table.

Errors are told apart without building their messages, by the checker's non-raising
:meth:`~craft_dsl.checker.ProgramBuilder.try_call`: prefix tokens are read right to left on a stack of
complete terms, which gives the syntax/type verdict of the left-to-right reader (the first error in reading
order decides); postfix tokens and node lists are read in their own order and stop at the first error.

Everything the batch builds (node table, memos, node values) lives for one call: memory is proportional to
the batch. Simulations keep their own caches (counterfactual runs, event filters) as they do for single runs.
"""

from __future__ import annotations

import gc
import marshal
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..checker import RESOLUTIONS, VALUES, ProgramBuilder, literal_type
from ..errors import (
    CounterfactualUnavailable,
    CraftError,
    EvaluationError,
    ProgramError,
)
from ..evaluator import Operation, operation, run_operations
from ..ir import RawNode, Value
from ..parser import Frame, GiveUp, scan_calls
from ..registry import NAMES, ModuleSpec
from ..simulation import Simulation
from ..tokens import INTEGER_TOKEN, ORIGINAL_TO_OURS, token_kinds
from ..types import INVALID, integer_literal
from .forms import FORMS, ProgramCache, ProgramForm
from .outcome import ANSWER_TYPES, OUTCOMES, check_outcome

#: Outcome codes of :attr:`BatchResult.codes`: the index of the outcome in :data:`~craft_dsl.oracle.OUTCOMES`.
SYNTAX_ERROR = OUTCOMES.index("syntax_error")
TYPE_ERROR = OUTCOMES.index("type_error")
INVALID_ANSWER = OUTCOMES.index("invalid")
ANSWER = OUTCOMES.index("answer")

# Stack items of the token readers: a node index (>= 0), a value token (its text), or one of these markers.
_TYPE_ERR = -1  # a complete term with a type error in it (also: a memo's node with a type error)
_OPEN_OK = -2  # prefix only: the tokens left of here start a term the sequence never completes, no type error so far
_OPEN_ERR = -3  # the same, with a type error in what was read of it
_SYNTAX_ERR = -4  # node lists: a memo's node with a syntax error (an unknown name, too many or too few inputs)
Item = int | str
# What reading one program gives: a node index (>= 0), one of these verdicts, or None (read it alone).
_SYNTAX = -10
_TYPE = -11
_UNREAD = -12  # node lists: a node the batch reader leaves to the single-program reader
#: A node-list memo's marker -> the program's verdict.
_NODE_VERDICTS: dict[int, int | None] = {_TYPE_ERR: _TYPE, _SYNTAX_ERR: _SYNTAX, _UNREAD: None}

# Entry codes of the prefix reader (:data:`_Word`): what a token of the exact-spelling table is. A module of
# three or more arguments has its number of arguments as its code.
_VALUE_WORD = -1  # a value word (or integer): pushed as it is
_NULLARY = 0  # a module of no argument: its node, made once
_UNARY = 1  # a module of one argument: its memo by argument
_BINARY = 2  # a module of two arguments: its memo by (first, second) argument

#: Per exact token: a value word (the word), or a module as (number of arguments, spec, input order of an
#: original name or None, fused side inputs).
_TokenKind = tuple[int, ModuleSpec, "tuple[int, ...] | None", tuple[str, ...]]
_TOKEN_KINDS: dict[str, _TokenKind | str] = {}


def _token_kinds() -> dict[str, _TokenKind | str]:
    """The exact token spellings :func:`craft_dsl.tokens.check_tokens` reads on its fast path."""
    if not _TOKEN_KINDS:
        for token, kind in token_kinds().items():
            if isinstance(kind, str):
                _TOKEN_KINDS[token] = kind
                continue
            spec, reorder, fused = kind
            n_args = spec.n_inputs + (0 if fused else len(spec.side_inputs))
            order = tuple(ORIGINAL_TO_OURS[spec.name]) if reorder else None
            _TOKEN_KINDS[token] = (n_args, spec, order, fused or ())
    return _TOKEN_KINDS


#: A prefix token's entry in a batch: (entry code, memo, kind). The memo is the
#: item per argument (one argument), per pair of arguments (two), the call's item itself (none), or None.
_Word = tuple[int, Any, _TokenKind]

#: Per exact token: its number of arguments (modules) or :data:`_VALUE_WORD` (values).
_ARITY: dict[str, int] = {}


def _token_arity() -> dict[str, int]:
    if not _ARITY:
        _ARITY.update({t: _VALUE_WORD if isinstance(k, str) else k[0] for t, k in _token_kinds().items()})
    return _ARITY


@dataclass(frozen=True)
class BatchResult:
    """One outcome and answer per program of a batch, as columns.

    ``codes[i]`` is program i's outcome as an index into :data:`~craft_dsl.oracle.OUTCOMES` (0 syntax error,
    1 type error, 2 INVALID, 3 answer; also :data:`SYNTAX_ERROR`, :data:`TYPE_ERROR`, :data:`INVALID_ANSWER`,
    :data:`ANSWER`); ``answers[i]`` is its answer as the dataset writes answers (bool, int, lowercase str)
    where ``codes[i] == ANSWER``, else None.
    """

    codes: np.ndarray = field(repr=False)
    answers: list[Any] = field(repr=False)

    def __len__(self) -> int:
        return len(self.answers)

    @property
    def kinds(self) -> list[str]:
        """The outcome names (``"answer"``, ``"invalid"``, ``"type_error"``, ``"syntax_error"``)."""
        return [OUTCOMES[c] for c in self.codes.tolist()]

    def counts(self) -> dict[str, int]:
        """How many programs got each outcome."""
        found = np.bincount(self.codes, minlength=len(OUTCOMES)).tolist()
        return dict(zip(OUTCOMES, found))

    def rewards(self, gold: Any, *, wrong: float = 0.0, invalid: float | None = None,
                error: float | None = None) -> np.ndarray:
        """Per program: 1.0 where the answer is ``gold``, ``wrong`` where it is another answer, ``invalid``
        where the value is INVALID and ``error`` for syntax and type errors (both default to ``wrong``).

        ``gold`` is one answer for every program, or a sequence with one answer per program; answers are
        compared after :func:`craft_dsl.verify.normalise_answer` (``"True"`` matches ``True``, ``"2"`` matches
        ``2``). Returns a float64 array.
        """
        from ..verify import normalise_answer

        n = len(self.answers)
        if isinstance(gold, np.ndarray):
            gold = gold.tolist()
        if isinstance(gold, (str, bytes)) or not isinstance(gold, Sequence):
            golds: Sequence[Any] = [gold] * n
        elif len(gold) != n:
            raise CraftError(f"rewards: {len(gold)} gold answers for {n} programs; give one answer, or one per "
                             "program")
        else:
            golds = gold
        keys: dict[tuple[type, Any], str] = {}

        def key(value: Any) -> str:
            try:
                k = (type(value), value)
                found = keys.get(k)
            except TypeError:  # unhashable (a list): its text, which matches no answer
                return normalise_answer(value)
            if found is None:
                found = keys[k] = normalise_answer(value)
            return found

        other = {SYNTAX_ERROR: wrong if error is None else error, TYPE_ERROR: wrong if error is None else error,
                 INVALID_ANSWER: wrong if invalid is None else invalid}
        out = [(1.0 if key(answer) == key(expected) else wrong) if code == ANSWER else other[code]
               for code, answer, expected in zip(self.codes.tolist(), self.answers, golds)]
        return np.array(out, dtype=np.float64)


class _Batch:
    """One batch's node table, memos of checked calls, and readers."""

    def __init__(self) -> None:
        self.builder = ProgramBuilder()
        self.nodes = self.builder.nodes
        self._add: Callable[[RawNode], int] = self.builder.add
        self.token_memo: dict[Any, Item] = {}
        #: Modules of one argument: per token, the memo by argument (cheaper than a (token, argument) key).
        self.unary: dict[str, dict[Item, Item]] = {}
        #: Prefix reader: per token of the exact-spelling table met in this batch, see :data:`_Word`.
        self.words: dict[str, _Word] = {}
        self.text_memo: dict[Any, int] = {}
        self.recipes: dict[tuple[str, ...], _TextRecipe | None] = {}
        self.literal_memo: dict[tuple[str, int, Value], int] = {}
        self.node_memo: dict[tuple[Any, ...], int] = {}
        self.cache = ProgramCache(maxsize=1 << 30)
        self.schedules: dict[int, tuple[int, ...]] = {}
        self.roots_met: set[int] = set()
        self.ops: list[Operation] = []

    # -- tokens ------------------------------------------------------------------------------------------

    def _value(self, text: str) -> Value:
        """A value token's value: the word, or the integer."""
        return text if text in _TOKEN_KINDS else integer_literal(text)

    def _call(self, kind: _TokenKind, args: Sequence[Item]) -> Item:
        """The item of a module token applied to ``args`` (in argument order)."""
        # The common well-formed calls first: one term; two terms; a term and a value word as side input.
        n = len(args)
        if n and type(a := args[0]) is int and a >= 0:
            spec = kind[1]
            if n == 1:
                return self._checked_call(spec, [a], kind[3]) if spec.n_inputs == 1 else _TYPE_ERR
            if n == 2:
                b = args[1]
                if spec.n_inputs == 2:
                    if type(b) is int and b >= 0:
                        order = kind[2]
                        return self._checked_call(spec, [a, b] if order is None else [(a, b)[j] for j in order],
                                                  kind[3])
                elif spec.n_inputs == 1 and type(b) is str and b in _TOKEN_KINDS and not kind[3]:
                    return self._checked_call(spec, [a], (b,))
        if args and type(last := args[-1]) is int and last in (_OPEN_OK, _OPEN_ERR):
            return self._open(kind, args)
        _n_args, spec, order, fused = kind
        builder = self.builder
        ids: list[int] = []
        for k in range(spec.n_inputs):
            a = args[k]
            if isinstance(a, int):
                if a < 0:
                    return _TYPE_ERR
                ids.append(a)
            else:
                value = self._value(a)
                if literal_type(spec, k, value) is None:
                    return _TYPE_ERR
                ids.append(builder.input_literal(spec, k, value, None))
        if fused:
            sides: list[Value] = list(fused)
        else:
            sides = []
            for a in args[spec.n_inputs:]:
                if isinstance(a, int):  # a term where a side input must stand (or a term with an error)
                    return _TYPE_ERR
                sides.append(self._value(a))
        if order is not None:
            ids = [ids[j] for j in order]
        return self._checked_call(spec, ids, sides)

    def _unary(self, kind: _TokenKind, a: Item) -> Item:
        """What ``_call(kind, (a,))`` gives, with the common call (a module of one term input, no side input,
        no wrapping) made here."""
        if type(a) is int:
            if a == _TYPE_ERR:  # an error in the argument is one in the call
                return _TYPE_ERR
            spec = kind[1]
            if a >= 0 and spec.n_inputs == 1 and not kind[3]:
                name = spec.name
                key = (name, self.nodes[a][3])
                res = RESOLUTIONS.get(key)
                if res is not None and not res[2]:
                    return self._add((name, (a,), (), res[1], res[0]))
        return self._call(kind, (a,))

    def _binary(self, kind: _TokenKind, a: Item, b: Item) -> Item:
        """What ``_call(kind, (a, b))`` gives, with the common calls (two term inputs in token order, or one
        term and a value word as side input, no wrapping) made here."""
        if a == _TYPE_ERR and b not in (_OPEN_OK, _OPEN_ERR):  # an error in an argument is one in the call
            return _TYPE_ERR
        spec = kind[1]
        if type(a) is int and a >= 0 and not kind[3]:
            name = spec.name
            nodes = self.nodes
            key: tuple[Any, ...]
            if type(b) is int:
                if b == _TYPE_ERR:
                    return _TYPE_ERR
                if b >= 0 and spec.n_inputs == 2 and kind[2] is None:
                    key = (name, nodes[a][3], nodes[b][3])
                    res = RESOLUTIONS.get(key)
                    if res is not None and not res[2]:
                        return self._add((name, (a, b), (), res[1], res[0]))
            elif spec.n_inputs == 1 and b in _TOKEN_KINDS:
                key = (name, nodes[a][3])
                res = RESOLUTIONS.get(key)
                if res is not None and not res[2]:
                    value = VALUES[spec.side_inputs[0]].get(b)
                    if value is not None:
                        return self._add((name, (a,), (value,), res[1], res[0]))
        return self._call(kind, (a, b))

    def _checked_call(self, spec: ModuleSpec, ids: list[int], sides: Sequence[Value]) -> int:
        """What ``builder.call(spec, ids, sides)`` gives, or :data:`_TYPE_ERR` where it raises (the caller has
        checked the numbers of arguments)."""
        found = self.builder.try_call(spec, ids, sides)
        return _TYPE_ERR if found is None else found

    def _open(self, kind: _TokenKind, args: Sequence[Item]) -> int:
        """Prefix order, right to left: a module whose arguments run past the end of the sequence (``args``: the
        complete ones in order, then possibly the open one). Records whether the left-to-right reader meets a
        type error in what it reads of this call: an argument with one, a value where an input is expected
        that is not a literal of it, a term where a side input is expected."""
        _n_args, spec, _order, _fused = kind
        for k, a in enumerate(args):
            if isinstance(a, int):
                if a in (_TYPE_ERR, _OPEN_ERR) or (a >= 0 and k >= spec.n_inputs):
                    return _OPEN_ERR
            elif k < spec.n_inputs and literal_type(spec, k, self._value(a)) is None:
                return _OPEN_ERR
        return _OPEN_OK

    def _word(self, word: str, n: int) -> _Word:
        """The batch's entry of a token of the exact-spelling table with ``n`` arguments (a value:
        :data:`_VALUE_WORD`)."""
        kind = cast(_TokenKind, _TOKEN_KINDS[word])
        entry: _Word
        if n == _VALUE_WORD:
            entry = (_VALUE_WORD, None, kind)
        elif n == _NULLARY:
            entry = (_NULLARY, self._call(kind, ()), kind)
        elif n == _UNARY:
            by_arg = self.unary.get(word)
            if by_arg is None:
                by_arg = self.unary[word] = {}
            entry = (_UNARY, by_arg, kind)
        elif n == _BINARY:
            entry = (_BINARY, {}, kind)
        else:
            entry = (n, None, kind)
        self.words[word] = entry
        return entry

    def read_prefix(self, words: Sequence[Any]) -> int | None:
        """Prefix tokens, read right to left (see :meth:`read_prefix_all`)."""
        return self.read_prefix_all((words,))[0]

    def read_prefix_all(self, sequences: Sequence[Sequence[Any]]) -> list[int | None]:
        """Each sequence of prefix tokens, read right to left: a stack of complete terms (see the module
        docstring), its top item held apart (``top``, None while the stack is empty) so that a call replaces it
        in place. One loop for the whole batch: the reader's set-up is paid once, not per sequence."""
        arity = (_ARITY or _token_arity()).get
        entry_of = self.words.get
        unary, binary = self._unary, self._binary
        stack: list[Item] = []  # the items below the top one, the deepest first
        push = stack.append
        pop = stack.pop
        results: list[int | None] = []
        result: int | None
        item: Item
        for words in sequences:
            stack.clear()
            top: Item | None = None
            for word in reversed(words):
                entry = entry_of(word)
                if entry is None:
                    n = arity(word)
                    if n is None:
                        if not _extra_token(word):
                            result = None
                            break
                        if top is not None:
                            push(top)
                        top = word
                        continue
                    entry = self._word(word, n)
                code, memo, kind = entry
                if code == _UNARY:  # the most common token
                    if top is not None:
                        item = memo.get(top)
                        if item is None:
                            item = memo[top] = unary(kind, top)
                        top = item
                    else:
                        top = _OPEN_OK
                elif code == _BINARY:
                    if stack:
                        pair = (top, pop())
                        item = memo.get(pair)
                        if item is None:
                            item = memo[pair] = binary(kind, *pair)
                        top = item
                    else:  # fewer terms than arguments: the call runs past the end
                        top = self._open(kind, [] if top is None else [top])
                elif code == _VALUE_WORD:
                    if top is not None:
                        push(top)
                    top = word
                elif code == _NULLARY:
                    if top is not None:
                        push(top)
                    top = memo  # its node, made with the entry
                elif top is not None and len(stack) >= code - 1:  # three or more arguments
                    args = [top, *stack[len(stack) - code + 1:][::-1]]
                    key = (word, *args)
                    found = self.token_memo.get(key)
                    if found is None:
                        found = self.token_memo[key] = self._call(kind, args)
                    del stack[len(stack) - code + 1:]
                    top = found
                else:
                    args = [] if top is None else [top, *stack[::-1]]
                    stack.clear()
                    top = self._open(kind, args)
            else:
                if not isinstance(top, int):  # the sequence starts with a value (words are not empty)
                    result = _SYNTAX
                elif not stack:
                    result = top if top >= 0 else _SYNTAX if top == _OPEN_OK else _TYPE
                else:  # the term starting at token 0 ends before the sequence does: too many tokens, unless
                    result = _TYPE if top == _TYPE_ERR else _SYNTAX  # it has a type error
            results.append(result)
        return results

    def read_postfix(self, words: Sequence[Any]) -> int | None:
        """Postfix tokens, left to right; the first error decides, as in the token reader."""
        arity = _ARITY or _token_arity()
        kinds = _TOKEN_KINDS
        memo = self.token_memo
        call = self._call
        stack: list[Item] = []
        for word in words:
            n = arity.get(word)
            if n is None:
                if not _extra_token(word):
                    return None
                stack.append(word)
                continue
            key: Any
            if n == _VALUE_WORD:
                stack.append(word)
                continue
            kind = cast(_TokenKind, kinds[word])
            if n == _UNARY:
                if not stack:
                    return _SYNTAX
                by_arg = self.unary.get(word)
                if by_arg is None:
                    by_arg = self.unary[word] = {}
                top = stack[-1]
                item = by_arg.get(top)
                if item is None:
                    item = by_arg[top] = call(kind, (top,))
                if item == _TYPE_ERR:
                    return _TYPE
                stack[-1] = item
                continue
            if n == _NULLARY:
                item = memo.get(word)
                if item is None:
                    item = memo[word] = call(kind, ())
                stack.append(item)
                continue
            if len(stack) < n:
                return _SYNTAX
            key = (word, *stack[-n:])
            item = memo.get(key)
            if item is None:
                item = memo[key] = call(kind, stack[-n:])
            if item == _TYPE_ERR:
                return _TYPE
            del stack[-n:]
            stack.append(item)
        root = stack[0] if len(stack) == 1 else None
        return root if isinstance(root, int) else _SYNTAX

    # -- text --------------------------------------------------------------------------------------------

    def read_text(self, text: str) -> int | None:
        """Binding-free text, as :func:`craft_dsl.parser.fast_check` reads it; None for anything that reader gives
        up on (errors included).

        Texts that differ only in their quoted values (``"red"`` for ``"blue"``) have one skeleton, read once into
        a recipe: the calls whose arguments hold no quoted value are checked when the recipe is made; a text runs
        only the calls that take its values."""
        parts = _QUOTED.split(text)
        skeleton = tuple(parts[0::2])
        if skeleton in self.recipes:
            recipe = self.recipes[skeleton]
        else:
            recipe = self.recipes[skeleton] = self._text_recipe(text)
        if recipe is None:
            return None
        steps, root = recipe
        if not steps:
            return root
        values = parts[1::2]
        results: list[int] = []
        try:
            for spec, sources in steps:
                args: list[Any] = []
                for kind, ref, k in sources:
                    if kind == _CONSTANT:
                        args.append(ref)
                    elif kind == _STEP:
                        args.append(results[ref])
                    elif kind == _INPUT_VALUE:
                        args.append(self._text_literal(spec, k, values[ref]))
                    else:
                        args.append(values[ref])
                results.append(self._text_call(spec, args))
        except (ProgramError, GiveUp):
            return None
        return results[-1]

    def _text_recipe(self, text: str) -> _TextRecipe | None:
        """The recipe of a text's skeleton: ``(steps, root)``, where ``steps`` are the calls that take quoted
        values (directly or through their arguments), in order, the last one the answer, and ``root`` is the
        answer's node when no call takes one (else :data:`_NO_ROOT`); None where :func:`~craft_dsl.parser.fast_check`
        gives up on every text of this skeleton. Read by the same scanner (:func:`~craft_dsl.parser.scan_calls`)."""
        recipe = _Recipe(self)
        found = scan_calls(text, recipe, _Recipe.close, _Recipe.input_value, _Recipe.side_value)
        if found is None:
            return None
        kind, ref, _k = found[0]
        return (recipe.steps, ref) if kind == _CONSTANT else (recipe.steps, _NO_ROOT)

    def _text_call(self, spec: ModuleSpec, args: list[Any]) -> int:
        key = (spec.name, *args)
        found = self.text_memo.get(key)
        if found is None:
            made = self.builder.try_call(spec, args[:spec.n_inputs], args[spec.n_inputs:])
            found = self.text_memo[key] = _TYPE_ERR if made is None else made
        if found < 0:
            raise GiveUp
        return found

    def _text_literal(self, spec: ModuleSpec, k: int, value: Value) -> int:
        key = (spec.name, k, value)
        found = self.literal_memo.get(key)
        if found is None:
            found = self.literal_memo[key] = self.builder.input_literal(spec, k, value, None)
        return found

    # -- node lists --------------------------------------------------------------------------------------

    def read_nodes(self, nodes: Any) -> int | None:
        """A node list of plain nodes (dicts whose ``type``, ``inputs`` and side inputs are well formed), node
        by node with a memo of checked nodes; the first type error decides; None for anything else."""
        return self.read_node_lists_all((nodes,))[0]

    def read_node_lists_all(self, programs: Sequence[Any]) -> list[int | None]:
        """Each node list: its root node, :data:`_SYNTAX` or :data:`_TYPE` where the first error decides, or None
        where the single-program reader must read it (an empty or malformed list, a node that is not a dict, inputs
        or side inputs of another type, an unhashable "type"). One loop for the whole batch: the reader's set-up is
        paid once, not per program.

        The syntax errors (an unknown name, an input that is not an earlier node, another number of inputs) come
        before the type errors of the same node, as in the single-program reader. A node's memo key is (type,
        *input node ids, *side values). The checks that depend only on the key (the module name, the numbers of
        inputs and side inputs, the side values) are made once per key, by _node_new; the ones a key does not fix
        (the dict, the input indexes, exact str side values) per node. A node with exactly the keys to_nodes()
        writes has its fields read directly, any other by _node_fields."""
        memo = self.node_memo
        lookup = memo.get
        node_new = self._node_new
        results: list[int | None] = []
        result: int | None
        key: tuple[Any, ...]
        for nodes in programs:
            if type(nodes) is not list or not nodes:
                results.append(None)
                continue
            built: list[int] = []
            append = built.append
            result = None
            try:
                for node in nodes:
                    if type(node) is not dict:
                        raise _Refused
                    if len(node) == 3:
                        try:
                            name, inputs, sides = node["type"], node["inputs"], node["value_inputs"]
                        except KeyError:
                            name, inputs, sides = _node_fields(node)
                    else:
                        name, inputs, sides = _node_fields(node)
                    if type(inputs) is not list:
                        raise _Refused
                    n = len(inputs)
                    k = len(built)
                    if n == 1:
                        i = inputs[0]
                        if type(i) is not int or not 0 <= i < k:
                            result = _SYNTAX  # an input that is not an earlier node
                            break
                        key = (name, built[i])
                    elif n == 0:
                        key = (name,)
                    else:
                        bad = False
                        for i in inputs:
                            if type(i) is not int or not 0 <= i < k:
                                bad = True
                                break
                        if bad:
                            result = _SYNTAX
                            break
                        key = (name, *[built[i] for i in inputs])
                    if sides:
                        if type(sides) is not list:
                            raise _Refused
                        for v in sides:
                            if type(v) is not str:
                                raise _Refused
                        key = (*key, *sides)
                    elif type(sides) is not list:  # None or missing: what that means depends on the module
                        key = (*key, _NOT_A_LIST)
                    found = lookup(key)
                    if found is None:
                        found = memo[key] = node_new(key, n, sides)
                    if found < 0:
                        result = _NODE_VERDICTS[found]
                        break
                    append(found)
                else:
                    result = built[-1]
            except (_Refused, TypeError):  # TypeError: an unhashable "type"
                result = None
            results.append(result)
        return results

    def _node_new(self, key: tuple[Any, ...], n: int, sides: list[str] | None) -> int:
        """The node of a memo key of :meth:`read_node_lists_all` (``n`` input ids after the name, then ``sides``), as
        :meth:`_checked_call` makes it; :data:`_SYNTAX_ERR` for an unknown name or other numbers of inputs,
        :data:`_TYPE_ERR` for a type error (other numbers of side inputs included), :data:`_UNREAD` where the
        single-program reader must decide (side inputs that are not a list, a side value written as a
        parameter)."""
        shape = _NODE_SHAPES.get(key[0])
        if shape is None or shape[1] != n:  # an unknown name, or too many or too few inputs
            return _SYNTAX_ERR
        spec, _n, reorder, n_sides = shape
        if sides:
            for v in sides:
                if v[:1] == "<":  # a placeholder or a word that looks like one
                    return _UNREAD
            if len(sides) != n_sides:
                return _TYPE_ERR
        elif n_sides:  # no side input where the module takes some: a type error if an empty list was written
            return _UNREAD if key[-1] is _NOT_A_LIST else _TYPE_ERR
        if n == 1:
            ids = [key[1]]
        else:
            ids = list(key[1:n + 1])
            if reorder is not None:
                ids = [ids[j] for j in reorder]
        return self._checked_call(spec, ids, sides or ())

    # -- programs read alone -------------------------------------------------------------------------------

    def read_alone(self, program: Any, form: ProgramForm | None) -> int:
        """A program the batch readers leave to the single-program readers; its nodes join the table."""
        outcome, checked = check_outcome(program, form, self.cache)
        if outcome is not None:
            return _SYNTAX if outcome.kind == "syntax_error" else _TYPE
        assert checked is not None
        index: list[int] = []
        add = self.builder.add
        for module, inputs, values, typ, overload in checked.nodes:
            raw: RawNode = (module, tuple([index[j] for j in inputs]), values, typ, overload)
            index.append(add(raw))
        return index[-1]

    # -- evaluation --------------------------------------------------------------------------------------------

    def schedule(self, root: int) -> tuple[int, ...]:
        """The nodes ``root`` needs, itself included, in dependency order (cached per root)."""
        found = self.schedules.get(root)
        if found is None:
            needed: set[int] = set()
            self._walk(root, needed)
            found = self.schedules[root] = tuple(sorted(needed))
        return found

    def _walk(self, root: int, needed: set[int]) -> None:
        """Add ``root`` and every node it needs to ``needed`` (the nodes already there are not walked again)."""
        nodes = self.nodes
        needed.add(root)
        stack = [root]
        while stack:
            for j in nodes[stack.pop()][1]:
                if j not in needed:
                    needed.add(j)
                    stack.append(j)

    def _operations(self) -> list[Operation]:
        """The table's nodes as the evaluator's operations (the nodes added since the last call are added)."""
        ops = self.ops
        ops.extend(map(operation, self.nodes[len(ops):]))
        return ops

    def evaluate(self, sim: Simulation, roots: Sequence[int]) -> dict[int, Any]:
        """The value of every node the ``roots`` need, on ``sim``: each node once. A node that raises
        (a counterfactual the simulation cannot give, a state index out of range) is INVALID, as are the nodes
        that take it as input; a program that needs it is INVALID, as it is when run alone."""
        # The needed nodes: a root met in an earlier group has its closure cached; the others are walked once,
        # sharing the walk with the group's other roots.
        nodes, schedules, met = self.nodes, self.schedules, self.roots_met
        distinct = set(roots)
        order: Sequence[int]
        if len(distinct) == 1:
            order = self.schedule(roots[0])
        else:
            needed: set[int] = set()
            for r in distinct:
                closure = schedules.get(r)
                if closure is None and r in met:
                    closure = self.schedule(r)
                if closure is not None:
                    needed.update(closure)
                    continue
                met.add(r)
                if r not in needed:
                    self._walk(r, needed)
            order = sorted(needed)
        ops = self.ops if len(self.ops) == len(nodes) else self._operations()
        slots: dict[int, Any] = {}
        run_operations(ops, order, sim, slots, failure_is_invalid=True)
        return slots


#: Per accepted node-list module name: (spec, number of inputs, how to reorder the inputs of an original name or
#: None, number of side inputs).
_NODE_SHAPES: dict[str, tuple[ModuleSpec, int, tuple[int, ...] | None, int]] = {
    name: (spec, spec.n_inputs, tuple(ORIGINAL_TO_OURS[spec.name]) if name != spec.name and spec.name in
           ORIGINAL_TO_OURS else None, len(spec.side_inputs))
    for name, spec in NAMES.items()
}
#: The last item of a node-list memo key whose node's side inputs are not a list (None, or no such field).
_NOT_A_LIST = object()


class _Refused(Exception):
    """A node list the batch reader leaves to the single-program reader (raised inside its loop)."""


def _node_fields(node: dict[str, Any]) -> tuple[Any, Any, Any]:
    """A node's type, inputs and side inputs, as the single-program reader takes them: the side inputs are
    ``value_inputs``, or ``side_inputs`` where ``value_inputs`` is missing (or empty beside other keys)."""
    sides = node.get("value_inputs")
    if not sides and (sides is None or len(node) > 3):
        sides = node.get("side_inputs")
    return node.get("type"), node.get("inputs"), sides


def _extra_token(word: Any) -> bool:
    """Whether a token missing from the exact-spelling table is an integer the token reader accepts."""
    if type(word) is not str or not INTEGER_TOKEN.match(word):
        return False
    try:
        integer_literal(word)
    except ValueError:
        return False
    return True


#: Where an argument of a text recipe's call comes from: (kind, reference, argument position).
_Source = tuple[int, int, int]
_CONSTANT, _STEP, _INPUT_VALUE, _SIDE_VALUE = range(4)  # a node; a step's result; a quoted value as input / side
_Step = tuple[ModuleSpec, tuple[_Source, ...]]
#: A text recipe: (steps, the answer's node or :data:`_NO_ROOT` where a step makes it).
_TextRecipe = tuple[list[_Step], int]
_NO_ROOT = -1
#: A quoted value, as the text reader's scanner finds it (craft_dsl.parser._FAST_TOKEN).
_QUOTED = re.compile('"([^"\u201c\u201d\n]*)"')


class _Recipe:
    """The hooks of :func:`~craft_dsl.parser.scan_calls` that make a text recipe: each argument a :data:`_Source`."""

    def __init__(self, batch: _Batch) -> None:
        self.batch = batch
        self.steps: list[_Step] = []
        self.quoted = 0  # quoted values so far: the index of the next one among the text's values

    def close(self, frame: Frame) -> _Source:
        """A call: checked now if it takes no quoted value, else a step."""
        spec, _n_inputs, arity, args, _index = frame
        if len(args) != arity:
            raise GiveUp
        if all(kind == _CONSTANT for kind, _ref, _k in args):
            return (_CONSTANT, self.batch._text_call(spec, [ref for _kind, ref, _k in args]), 0)
        self.steps.append((spec, tuple(args)))
        return (_STEP, len(self.steps) - 1, 0)

    def input_value(self, spec: ModuleSpec, k: int, value: Value) -> _Source:
        if isinstance(value, int):
            return (_CONSTANT, self.batch._text_literal(spec, k, value), k)
        self.quoted += 1
        return (_INPUT_VALUE, self.quoted - 1, k)

    def side_value(self, spec: ModuleSpec, k: int, value: str) -> _Source:
        self.quoted += 1
        return (_SIDE_VALUE, self.quoted - 1, k)


def _check_form(form: Any) -> ProgramForm | None:
    if form is None:
        return None
    if form not in FORMS:
        raise CraftError(f"run_batch: unknown program form {form!r}; allowed: {', '.join(FORMS)}, or None to "
                         "detect each program's form (a string is text, a list of objects a node list, a list of "
                         "strings prefix tokens)")
    return cast(ProgramForm, form)


def run_batch(programs: Sequence[Any], sims: Simulation | Sequence[Simulation],
              form: ProgramForm | None = None) -> BatchResult:
    """The outcome and answer of every program of a batch, exactly as :func:`program_outcome` gives them for
    each program alone, with the work the programs share done once (see the module docstring).

    Args:
        programs: predicted programs: DSL text (strings), node lists, or token sequences (lists of strings, or
            space-separated strings with ``form="prefix"``/``"postfix"``).
        sims: one simulation for every program, or a sequence with one simulation per program (programs on
            the same simulation object share its node values).
        form: ``"text"``, ``"nodes"``, ``"prefix"`` or ``"postfix"`` for every program, or None to detect each
            program's form as :func:`~craft_dsl.oracle.detect_form` does (a list of strings is prefix tokens).

    Raises CraftError for a batch that cannot be scored (``programs`` not a list, a ``sims`` list of another
    length, an unknown form) and, naming the program, where running that program alone raises.
    """
    form = _check_form(form)
    if isinstance(programs, (str, bytes)) or not isinstance(programs, Sequence):
        raise CraftError(f"run_batch: programs must be a list of programs, found {type(programs).__name__}")
    n = len(programs)
    sim_list: Sequence[Simulation] | None
    if isinstance(sims, Simulation):
        sim_list = None
    elif isinstance(sims, Sequence) and not isinstance(sims, (str, bytes)):
        if len(sims) != n:
            raise CraftError(f"run_batch: {n} programs but {len(sims)} simulations; pass one simulation for every "
                             "program, or a list with one simulation per program")
        for i, s in enumerate(sims):
            if not isinstance(s, Simulation):
                raise CraftError(f"run_batch: simulation {i} is a {type(s).__name__}, not a Simulation")
        sim_list = sims
    else:
        raise CraftError(f"run_batch: sims must be a Simulation or a list of them, found {type(sims).__name__}")

    if n == 1:  # nothing to share: the single-program path
        return _one(programs[0], sims if isinstance(sims, Simulation) else sims[0], form)
    was_enabled = gc.isenabled()
    gc.disable()  # a batch makes many small objects and no reference cycles: full collections would only cost
    try:
        return _run(programs, sims, sim_list, form)
    finally:
        if was_enabled:
            gc.enable()


def _run(programs: Sequence[Any], sims: Simulation | Sequence[Simulation], sim_list: Sequence[Simulation] | None,
         form: ProgramForm | None) -> BatchResult:
    batch = _Batch()
    # Read every distinct program once: `read[i]` is program i's answer node, or an error code. Programs are
    # the same when they are equal token lists (or strings) in the same form, or the same node-list object.
    read = (_read_token_lists(batch, programs, form) if form == "prefix" or form == "postfix"
            else _read_node_lists(batch, programs) if form == "nodes" else None)
    if read is None:
        read = _read_each(batch, programs, form)

    # Evaluate the needed nodes once per simulation.
    invalid = INVALID
    if isinstance(sims, Simulation):
        distinct = set(read)
        roots = [r for r in distinct if r >= 0]
        slots = batch.evaluate(sims, roots) if roots else {}
        # One outcome per distinct root, then the columns in one pass each.
        code_of: dict[int, int] = {_SYNTAX: SYNTAX_ERROR, _TYPE: TYPE_ERROR}
        answer_of: dict[int, Any] = {_SYNTAX: None, _TYPE: None}
        for r in distinct:
            if r >= 0:
                v = slots[r]
                code_of[r], answer_of[r] = (INVALID_ANSWER, None) if v is invalid else (ANSWER, v)
        return BatchResult(np.array(list(map(code_of.__getitem__, read)), dtype=np.int8),
                           list(map(answer_of.__getitem__, read)))
    assert sim_list is not None
    groups: dict[int, tuple[Simulation, list[int]]] = {}
    group_of = list(map(id, sim_list))
    for r, s, g_id in zip(read, sim_list, group_of):
        g = groups.get(g_id)
        if g is None:
            g = groups[g_id] = (s, [])
        if r >= 0:
            g[1].append(r)
    values = {g_id: batch.evaluate(s, roots) if roots else {} for g_id, (s, roots) in groups.items()}
    results = [values[g][r] if r >= 0 else invalid for g, r in zip(group_of, read)]
    codes = [(INVALID_ANSWER if v is invalid else ANSWER) if r >= 0 else SYNTAX_ERROR if r == _SYNTAX else TYPE_ERROR
             for r, v in zip(read, results)]
    answers = [None if v is invalid else v for v in results]
    return BatchResult(np.array(codes, dtype=np.int8), answers)


def _read_token_lists(batch: _Batch, programs: Sequence[Any], form: ProgramForm) -> list[int] | None:
    """The reading of a batch whose programs are all non-empty lists of hashable tokens (the form a sampler
    gives), with the per-program work in single passes: keys, distinct keys, results per program. None for
    any other batch (:func:`_read_each` reads it)."""
    if not programs or set(map(type, programs)) != {list} or not all(programs):
        return None
    index: dict[tuple[Any, ...], int] = {}  # distinct key -> its number, in the order of the first programs
    setdefault = index.setdefault
    try:
        ids = [setdefault(tuple(p), len(index)) for p in programs]  # one hash per program
    except TypeError:  # a token that is not hashable
        return None
    keys = list(index)  # in the order of the first programs: the first refused program is named
    read = batch.read_prefix_all(keys) if form == "prefix" else list(map(batch.read_postfix, keys))
    answer_types = ANSWER_TYPES
    nodes = batch.nodes
    results: list[int] = []
    for j, result in enumerate(read):
        if result is None:
            i = ids.index(j)  # the first program of this key, for the single-program reader
            result = _alone(batch, programs[i], form, i)
        elif result >= 0 and nodes[result][3] not in answer_types:
            result = _TYPE
        results.append(result)
    return list(map(results.__getitem__, ids))


#: Node lists are keyed (:func:`node_list_key`) in blocks of this many programs ...
KEY_BLOCK = 64
#: ... and the next block is keyed only where at least this share of the keys the last keyed block made found a
#: list read before: a key costs about half of reading a list again, so keys pay only where lists often repeat.
KEY_PAYS = 0.4
#: Where keys did not pay, one block in this many is keyed again, to find duplicates that begin later.
KEY_PROBE = 8


def _read_node_lists(batch: _Batch, programs: Sequence[Any]) -> list[int] | None:
    """The reading of a batch of node lists (every program a list), in one pass without the per-program
    bookkeeping of :func:`_read_each`. The same list object is read once; equal lists (see
    :func:`node_list_key`) are read once where the batch repeats them (keys are made while the duplicates found
    pay for them: :data:`KEY_BLOCK`, :data:`KEY_PAYS`, :data:`KEY_PROBE`); distinct lists share the memo of
    checked nodes. None for any other batch."""
    if not programs or set(map(type, programs)) != {list}:
        return None
    index: dict[Any, int] = {}  # key of a distinct list -> its number, in the order of the first programs
    by_id: dict[int, int] = {}  # the same for list objects (which live as long as `programs`)
    distinct: list[Any] = []
    ids: list[int] = []
    append_id = ids.append
    unpaid = 0  # blocks since the last keyed block whose duplicates did not pay for its keys (0: they did)
    for start in range(0, len(programs), KEY_BLOCK):
        block = programs[start:start + KEY_BLOCK]
        keyed = unpaid % KEY_PROBE == 0
        keys = repeats = 0
        for p in block:
            j = by_id.get(id(p))
            if j is None:
                if keyed:
                    keys += 1
                    j = index.setdefault(node_list_key(p), len(distinct))
                    if j < len(distinct):
                        repeats += 1
                else:
                    j = len(distinct)
                by_id[id(p)] = j
                if j == len(distinct):
                    distinct.append(p)
            append_id(j)
        unpaid = 0 if keyed and repeats >= KEY_PAYS * keys else unpaid + 1
    answer_types = ANSWER_TYPES
    nodes = batch.nodes
    read: list[int] = []
    append = read.append
    for j, result in enumerate(batch.read_node_lists_all(distinct)):
        if result is None:
            result = _alone(batch, distinct[j], "nodes", ids.index(j))
        elif result >= 0 and nodes[result][3] not in answer_types:
            result = _TYPE
        append(result)
    return read if len(distinct) == len(programs) else list(map(read.__getitem__, ids))


def node_list_key(nodes: list[Any]) -> Any:
    """A hashable key of a node list: equal keys, equal lists (same values of the same types, dict keys in the same
    order), so an equal list has the same outcome. The list's marshal bytes (one C call), or for a list marshal
    does not take (other objects in it) a key equal to no other."""
    try:
        return marshal.dumps(nodes)
    except ValueError:
        return object()


def _read_each(batch: _Batch, programs: Sequence[Any], form: ProgramForm | None) -> list[int]:
    """The reading of any batch, program by program (see :func:`_run`)."""
    read: list[int] = [0] * len(programs)
    seen: dict[str, dict[Any, int]] = {f: {} for f in FORMS}
    keep: list[Any] = []  # node lists are told apart by identity: keep them alive for the call
    readers: dict[str, Callable[[Any], int | None]] = {
        "prefix": batch.read_prefix, "postfix": batch.read_postfix, "text": batch.read_text,
        "nodes": batch.read_nodes}
    answer_types = ANSWER_TYPES
    nodes = batch.nodes
    for i, program in enumerate(programs):
        kind = type(program)
        p_form: str | None = form
        if kind is list or kind is tuple:
            if not program:
                p_form = None
            elif p_form is None:
                first = type(program[0])
                p_form = "nodes" if first is dict else "prefix" if first is str else None
            if p_form == "prefix" or p_form == "postfix":
                key = tuple(program) if kind is list else program
            elif p_form == "nodes" and kind is list:
                key = id(program)
            else:
                p_form = None
        elif kind is str:
            if p_form is None:
                p_form = "text"
            elif p_form == "nodes":
                p_form = None
            key = program
        else:
            p_form = None
        if p_form is None:
            read[i] = _alone(batch, program, form, i)
            continue
        table = seen[p_form]
        try:
            found = table.get(key)
        except TypeError:  # a token that is not hashable
            read[i] = _alone(batch, program, form, i)
            continue
        if found is None:
            words = program.split() if kind is str and p_form != "text" else program
            result = readers[p_form](words) if words else None
            if result is None:
                result = _alone(batch, program, form, i)
            elif result >= 0 and nodes[result][3] not in answer_types:
                result = _TYPE
            found = table[key] = result
            if p_form == "nodes":
                keep.append(program)
        read[i] = found
    return read


def _one(program: Any, sim: Simulation, form: ProgramForm | None) -> BatchResult:
    """A batch of one program: :func:`~craft_dsl.oracle.program_outcome`'s reading and run, without explaining
    an INVALID value."""
    try:
        outcome, checked = check_outcome(program, form)
    except ProgramError:  # pragma: no cover - check_outcome turns these into outcomes
        raise
    except CraftError as err:
        raise CraftError(f"run_batch: program 0: {err}") from err
    if outcome is not None:
        return BatchResult(np.array([OUTCOMES.index(outcome.kind)], dtype=np.int8), [None])
    assert checked is not None
    try:
        value = checked.run(sim)
    except (CounterfactualUnavailable, EvaluationError):
        value = INVALID
    if value is INVALID:
        return BatchResult(np.array([INVALID_ANSWER], dtype=np.int8), [None])
    return BatchResult(np.array([ANSWER], dtype=np.int8), [value])


def _alone(batch: _Batch, program: Any, form: ProgramForm | None, i: int) -> int:
    try:
        return batch.read_alone(program, form)
    except ProgramError:  # pragma: no cover - check_outcome turns these into outcomes
        raise
    except CraftError as err:
        raise CraftError(f"run_batch: program {i}: {err}") from err
