"""Programs as token sequences (craft_dsl.tokens): formats, round trips, errors, the fast readers."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from craft_dsl import (
    INVALID,
    NodeListError,
    Program,
    ProgramError,
    SideInputError,
    Simulation,
    TokenError,
    TypeCheckError,
    parse,
)
from craft_dsl.parser import check_text, fast_check
from craft_dsl.strategies import programs
from craft_dsl.templates import DROPPED, templates
from craft_dsl.tokens import _fast_read, check_tokens, program_vocabulary
from tests.conftest import E1_PATH

STYLES = list(itertools.product(("prefix", "postfix"), ("canonical", "original"), (False, True)))
PARAMS = {"<Z>": "small", "<C>": "red", "<S>": "cube", "<Z2>": "large", "<C2>": "blue", "<S2>": "circle"}


def _template_programs() -> list[Program]:
    return [t.program({k: v for k, v in PARAMS.items() if k in t.placeholders}) for t in templates().values()]


TEMPLATE_PROGRAMS = _template_programs()


# -- the format ---------------------------------------------------------------------------------------------------


def test_prefix_and_postfix_of_a_small_program() -> None:
    p = parse('Count(FilterColor(SceneAtStart(), "red"))')
    assert p.to_tokens() == ["Count", "FilterColor", "SceneAtStart", "red"]
    assert p.to_tokens("postfix") == ["SceneAtStart", "red", "FilterColor", "Count"]
    assert p.to_tokens(fused=True) == ["Count", "FilterColor[red]", "SceneAtStart"]
    assert p.to_tokens("postfix", names="original") == ["start_scene", "red", "filter_color", "count"]


def test_tokens_write_the_checker_unique_and_inline_bindings() -> None:
    p = parse('Var O = FilterColor(SceneAtStart(), "red")\nQueryShape(O)')
    assert p.to_tokens() == ["QueryShape", "Unique", "FilterColor", "SceneAtStart", "red"]
    # a token sequence without the Unique reads to the same program: the checker inserts it
    assert Program.from_tokens(["QueryShape", "FilterColor", "SceneAtStart", "red"]).key == p.key


def test_original_names_take_the_original_argument_order() -> None:
    p = parse("EventPartner(FilterFirst(Events()), Unique(FilterDynamic(SceneAtStart())))")
    canonical = p.to_tokens()
    original = p.to_tokens(names="original")
    assert canonical[:2] == ["EventPartner", "FilterFirst"]
    assert original[:2] == ["event_partner", "unique"]  # the original writes (Object, Event)
    assert Program.from_tokens(original).key == p.key == Program.from_tokens(canonical).key


def test_overloads_get_their_original_names() -> None:
    assert parse("Exist(Events())").to_tokens(names="original") == ["event_exist", "events"]
    assert parse("Exist(SceneAtStart())").to_tokens(names="original") == ["exist", "start_scene"]


def test_integer_and_value_literals_in_input_positions() -> None:
    p = parse('EqualColor(QueryColor(FilterColor(SceneAtStart(), "red")), "Red")')
    for order in ("prefix", "postfix"):
        assert Program.from_tokens(p.to_tokens(order), order) == p
    q = parse("FilterMoving(SceneAtStart(), -1)")
    assert q.to_tokens() == ["FilterMoving", "SceneAtStart", "-1"]
    assert Program.from_tokens(["FilterMoving", "SceneAtStart", "-1"]).key == q.key


def test_a_space_separated_string_is_a_token_sequence() -> None:
    assert Program.from_tokens("Count FilterDynamic SceneAtStart") == parse("Count(FilterDynamic(SceneAtStart()))")
    assert Program.from_tokens("SceneAtStart FilterDynamic Count", "postfix").to_tokens() == [
        "Count", "FilterDynamic", "SceneAtStart"]


def test_values_are_read_in_any_case_and_with_aliases() -> None:
    p = Program.from_tokens(["Count", "FilterShape", "SceneAtStart", "Block"])
    assert p.to_tokens()[-1] == "cube"


@pytest.mark.parametrize(("order", "names", "fused"), STYLES)
def test_every_template_round_trips_through_every_token_style(order: str, names: str, fused: bool) -> None:
    for p in TEMPLATE_PROGRAMS:
        tokens = p.to_tokens(order, names=names, fused=fused)  # type: ignore[arg-type]
        back = Program.from_tokens(tokens, order)  # type: ignore[arg-type]
        assert back.key == p.key, (str(p), tokens)
        assert str(back) == str(p)
        assert back.to_tokens(order, names=names, fused=fused) == tokens  # type: ignore[arg-type]


def test_every_template_answers_the_same_through_tokens(e1: Simulation) -> None:
    for p in TEMPLATE_PROGRAMS:
        expected = p.run(e1)
        for order in ("prefix", "postfix"):
            got = Program.from_tokens(p.to_tokens(order), order).run(e1)  # type: ignore[arg-type]
            assert got == expected or (got is INVALID and expected is INVALID)


def test_token_vocabulary_covers_every_template_token() -> None:
    for names, fused in itertools.product(("canonical", "original"), (False, True)):
        vocab = set(program_vocabulary(names, fused))  # type: ignore[arg-type]
        for p in TEMPLATE_PROGRAMS:
            assert set(p.to_tokens(names=names, fused=fused)) <= vocab  # type: ignore[arg-type]
    assert len(program_vocabulary()) == len(set(program_vocabulary()))


# -- errors -----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("tokens", "order", "index", "needle"),
    [
        (["Count", "Cnt", "SceneAtStart"], "prefix", 1, "unknown token 'Cnt'; did you mean Count"),
        (["Count", "FilterColor", "SceneAtStart"], "prefix", 3, "end too early: FilterColor (token 1) still needs 1"),
        (["Count", "SceneAtStart", "SceneAtEnd"], "prefix", 2, "after the complete program"),
        (["red", "Count"], "prefix", 0, "starts with a module"),
        (["Count", "SceneAtStart"], "postfix", 0, "takes 1 argument(s) but only 0"),
        (["SceneAtStart", "SceneAtEnd"], "postfix", 1, "2 separate expressions"),
        (["SceneAtStart", "Count", "red"], "postfix", 2, "ends with a module"),
        ([], "prefix", None, "empty"),
    ],
)
def test_token_errors_name_the_token(tokens: list[str], order: str, index: int | None, needle: str) -> None:
    with pytest.raises(TokenError) as info:
        Program.from_tokens(tokens, order)  # type: ignore[arg-type]
    assert needle in str(info.value)
    assert info.value.index == index
    if index is not None:
        assert str(info.value).startswith(f"token {index}: ")


def test_type_errors_in_tokens_name_the_token_and_the_types() -> None:
    with pytest.raises(TypeCheckError) as info:
        Program.from_tokens(["Count", "QueryColor", "Unique", "SceneAtStart"])
    err = info.value
    assert (err.module, err.argument, err.found) == ("Count", 1, "Color")
    assert err.expected == ("EventSet", "ObjectSet")
    assert err.location == "token 1" and err.index == 1  # the offending argument, as in text
    with pytest.raises(TypeCheckError, match="argument 2 must be a Color value"):
        Program.from_tokens(["FilterColor", "SceneAtStart", "SceneAtEnd"])
    with pytest.raises(TokenError, match="order must be"):
        Program.from_tokens(["Count", "SceneAtStart"], "infix")  # type: ignore[arg-type]


def test_unknown_fused_module_is_an_unknown_token() -> None:
    with pytest.raises(TokenError, match="unknown token 'FilterColour\\[red\\]'"):
        Program.from_tokens(["Count", "FilterColour[red]", "SceneAtStart"])
    with pytest.raises(SideInputError, match="not a Color"):
        Program.from_tokens(["Count", "FilterColor[pink]", "SceneAtStart"])


def test_node_list_errors_name_the_node() -> None:
    with pytest.raises(NodeListError, match="did you mean Count") as info:
        Program.from_nodes([{"type": "start_scene", "inputs": []}, {"type": "cnt", "inputs": [0]}])
    assert info.value.location == "node 1" and info.value.index == 1
    with pytest.raises(TypeCheckError) as type_info:
        Program.from_nodes([{"type": "events", "inputs": []}, {"type": "query_color", "inputs": [0]}])
    assert type_info.value.location == "node 1" and type_info.value.found == "EventSet"


# -- the fast readers agree with the full ones --------------------------------------------------------------------


def test_fast_token_reader_handles_every_template_style() -> None:
    for p, (order, names, fused) in itertools.product(TEMPLATE_PROGRAMS, STYLES):
        tokens = p.to_tokens(order, names=names, fused=fused)  # type: ignore[arg-type]
        fast = _fast_read(tokens, order == "prefix")
        assert fast is not None and fast.nodes == p.key


def test_fast_text_reader_handles_every_template() -> None:
    for p in TEMPLATE_PROGRAMS:
        fast = fast_check(str(p))
        assert fast is not None and fast.nodes == p.key


_WORDS = ["Count", "FilterColor", "SceneAtStart", "Events", "FilterFirst", "Unique", "EqualColor", "QueryColor",
          "red", "Red", "pink", "0", "-1", "Cnt", "count", "filter_color", "FilterMoving", "EventPartner"]
_TEXT_PIECES = ["Count", "FilterColor", "SceneAtStart", "QueryColor", "FilterMoving", "(", ")", ",", '"red"',
                '"Red"', '"pink"', "-3", "0", " ", "\n", "Var", "X", "=", "#", "\u201cred\u201d", "\u00a0", "é"]


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(_WORDS), min_size=1, max_size=8), st.sampled_from(["prefix", "postfix"]))
def test_fast_token_reader_never_disagrees_with_the_full_reader(words: list[str], order: str) -> None:
    fast = _fast_read(words, order == "prefix")
    try:
        full = check_tokens(words, order)  # type: ignore[arg-type]
    except ProgramError:  # a wrong sequence; any other exception is a bug and fails the test
        assert fast is None  # the full reader words every error
        return
    assert fast is None or fast.nodes == full.nodes


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(_TEXT_PIECES), min_size=1, max_size=14))
def test_fast_text_reader_never_disagrees_with_the_grammar(pieces: list[str]) -> None:
    text = "".join(pieces)
    fast = fast_check(text)
    try:
        full = check_text(text) if fast is None else None
        from craft_dsl.checker import check_tree
        from craft_dsl.parser import parse_tree

        reference = check_tree(parse_tree(text))
    except ProgramError:  # a wrong text; any other exception is a bug and fails the test
        assert fast is None
        return
    assert full is None or full.nodes == reference.nodes
    if fast is not None:
        assert fast.nodes == reference.nodes


def test_text_and_tokens_and_nodes_meet_in_one_key() -> None:
    text = 'Var A = FilterColor(SceneAtStart(), "red")\nCount(Intersect(A, A))'
    p = parse(text)
    assert p.key == Program.from_nodes(p.to_nodes()).key == Program.from_tokens(p.to_tokens()).key
    assert p != Program.from_nodes(p.to_nodes())  # the printed bindings differ ...
    assert str(Program.from_nodes(p.to_nodes())) == 'Count(Intersect(FilterColor(SceneAtStart(), "red"), ' \
                                                    'FilterColor(SceneAtStart(), "red")))'


def test_source_nodes_map_each_form_to_the_checked_nodes() -> None:
    p = Program.from_tokens(["Count", "FilterColor", "SceneAtStart", "red"])
    assert [p.nodes[i].module for i in p.source_nodes if i is not None] == ["Count", "FilterColor", "SceneAtStart"]
    q = parse('Count(FilterColor(SceneAtStart(), "red"))')
    assert q.source_nodes == p.source_nodes
    nodes = [{"type": "start_scene", "inputs": []}, {"type": "events", "inputs": []},
             {"type": "count", "inputs": [1]}]
    r = Program.from_nodes(nodes)
    assert r.source_nodes == (None, 0, 1)  # node 0 is unused


def test_deep_programs_check_print_and_run(e1: Simulation) -> None:
    depth = 3000
    text = "Count(" + "FilterDynamic(" * depth + "SceneAtStart()" + ")" * depth + ")"
    p = parse(text)
    dynamic = parse("Count(FilterDynamic(SceneAtStart()))").run(e1)
    assert p.run(e1) == dynamic
    assert str(p) == text
    tokens = ["Count"] + ["FilterDynamic"] * depth + ["SceneAtStart"]
    assert Program.from_tokens(tokens).key == p.key
    nodes = [{"type": "start_scene", "inputs": []}] + [
        {"type": "filter_dynamic_objects", "inputs": [k]} for k in range(depth)] + [
        {"type": "count", "inputs": [depth]}]
    assert Program.from_nodes(nodes).run(e1) == dynamic
    assert len(Program.from_nodes(nodes).to_nodes()) == depth + 2


def test_e1_path_exists() -> None:
    assert E1_PATH.exists() and DROPPED


# -- laws over every well-typed program (the public strategies) ---------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(programs(), st.sampled_from(STYLES))
def test_every_well_typed_program_round_trips_through_every_token_form(
        p: Program, style: tuple[str, str, bool]) -> None:
    order, names, fused = style
    try:
        tokens = p.to_tokens(order, names=names, fused=fused)  # type: ignore[arg-type]
    except TokenError:  # a module without an original name cannot be written with original names
        assert names == "original"
        return
    back = Program.from_tokens(tokens, order)  # type: ignore[arg-type]
    assert back.key == p.key
    assert back.to_tokens(order, names=names, fused=fused) == tokens  # type: ignore[arg-type]
    assert Program.from_tokens(" ".join(tokens), order).key == p.key  # type: ignore[arg-type]
    assert fast_check(str(back)) is None or fast_check(str(back)).nodes == p.key  # type: ignore[union-attr]


def test_a_lone_value_is_a_program_in_no_form() -> None:
    for text in ("0", "Var X = 3\nX", "-1"):
        with pytest.raises(ProgramError, match="lone value"):
            parse(text)
    with pytest.raises(TokenError):
        Program.from_tokens(["0"])
