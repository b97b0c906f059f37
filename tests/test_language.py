"""Parsing and checking: the paper's programs, the text form's freedoms, the canonical form, the errors."""

from __future__ import annotations

import pytest

from craft_dsl import (
    INVALID,
    DslType,
    ParseError,
    Program,
    ProgramError,
    SideInputError,
    Simulation,
    TypeCheckError,
    UnknownModuleError,
    parse,
)
from tests.conftest import make_sim

# -- the programs of the paper's appendix, exactly as printed  ----------------------

FALL_TO_GROUND = """\
Count (
    FilterDynamic (
        FilterObjectsFromEvents (
            FilterCollideGround (
                Events ()
            )
        )
    )
)
"""

AFTER_ENTERING_AS_PRINTED = """\
Var QueryObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Yellow"), "Cube" )
Var SmallYellowCubeEvents = FilterEvents ( Events(), QueryObject )
Exist (
    FilterAfter (
        FilterCollisionWithDynamics ( SmallYellowCubeEvents ),
            FilterFirst (
                FilterEnterBasket ( SmallYellowCubeEvents )
            )
        )
    )
)
"""

CF_COUNT = """\
Var QueryObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Yellow"), "Cube" )
Count (
    FilterObjectsFromEvents (
        FilterCollideGround (
            GetCounterfactEvents ( QueryObject )
        )
    )
)
"""

CF_ANY_OTHER = """\
Var QueryObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Gray"), "Cube" )
Var OtherDynamicObjects = Difference ( FilterDynamic ( SceneAtStart() ), AsList ( QueryObject ) )
AnyTrue (
    ExistList (
        IntersectList (
            FilterObjectsFromEventsList (
                FilterEnterBasketList (
                    GetCounterfactEventsList ( OtherDynamicObjects )
                )
            ),
            AsList (
                QueryObject
            )
        )
    )
)
"""

CAUSE = """\
Var AffectorObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Brown"), “Circle” )
Var PatientObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Yellow"), "Cube" )
Exist (
    FilterStationary (
        Intersect (
            Difference (
                FilterObjectsFromEvents (
                    FilterEnterBasket (
                        Events()
                    )
                ),
                FilterObjectsFromEvents (
                    FilterEnterBasket (
                        GetCounterfactEvents (
                            AffectorObject
                        )
                    )
                )
            ),
            AsList ( PatientObject )
        ),
        StartSceneStep()
    )
)
"""

ENABLE = """\
Var AffectorObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Gray"), "Cube" )
Count (
    FilterMoving (
        Difference (
            Difference (
                FilterObjectsFromEvents (
                    FilterEnterBasket (
                        Events()
                    )
                ),
                FilterObjectsFromEvents (
                    FilterEnterBasket (
                        GetCounterfactEvents (
                            AffectorObject
                        )
                    )
                )
            ),
            AsList ( AffectorObject )
        ),
        StartSceneStep()
    )
)
"""

PREVENT = """\
Var AffectorObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Yellow"), "Cube" )
Var PatientObject = FilterShape ( FilterColor ( FilterSize ( SceneAtStart(),  "Small" ) , "Brown"), "Circle" )
Exist (
    FilterMoving (
        Intersect (
            Difference (
                FilterObjectsFromEvents (
                    FilterEnterBasket (
                        GetCounterfactEvents (
                            AffectorObject
                        )
                    )
                ),
                FilterObjectsFromEvents (
                    FilterEnterBasket (
                        Events()
                    )
                )
            ),
            AsList ( PatientObject )
        ),
        StartSceneStep()
    )
)
"""


def _without_last_line(text: str) -> str:
    return "\n".join(text.rstrip("\n").split("\n")[:-1]) + "\n"


AFTER_ENTERING = _without_last_line(AFTER_ENTERING_AS_PRINTED)

PAPER = {
    "fall_to_ground": (FALL_TO_GROUND, DslType.INTEGER),
    "after_entering": (AFTER_ENTERING, DslType.BOOL),
    "cf_count": (CF_COUNT, DslType.INTEGER),
    "cf_any_other": (CF_ANY_OTHER, DslType.BOOL),
    "cause": (CAUSE, DslType.BOOL),
    "enable": (ENABLE, DslType.INTEGER),
    "prevent": (PREVENT, DslType.BOOL),
}


@pytest.mark.parametrize("name", list(PAPER))
def test_paper_programs_parse_and_type_check(name: str) -> None:
    text, typ = PAPER[name]
    p = parse(text)
    assert p.type is typ
    assert parse(str(p)) == p
    assert str(parse(str(p))) == str(p)


def test_paper_program_with_an_extra_parenthesis_points_at_it() -> None:
    with pytest.raises(ParseError) as info:
        parse(AFTER_ENTERING_AS_PRINTED)
    err = info.value
    assert (err.line, err.column) == (11, 1)
    assert "line 11, column 1" in str(err)
    assert "')'" in str(err)


def test_canonical_form_shows_the_inserted_unique() -> None:
    assert str(parse(AFTER_ENTERING)) == (
        'Var QueryObject = FilterShape(FilterColor(FilterSize(SceneAtStart(), "small"), "yellow"), "cube")\n'
        "Var SmallYellowCubeEvents = FilterEvents(Events(), Unique(QueryObject))\n"
        "Exist(FilterAfter(FilterCollisionWithDynamics(SmallYellowCubeEvents), "
        "FilterFirst(FilterEnterBasket(SmallYellowCubeEvents))))"
    )
    assert str(parse(CF_COUNT)).endswith(
        "Count(FilterObjectsFromEvents(FilterCollideGround(GetCounterfactEvents(Unique(QueryObject)))))")
    text = str(parse(CF_ANY_OTHER))
    assert "AsList(Unique(QueryObject))" in text
    assert text.count("Unique(") == 2
    assert str(parse(FALL_TO_GROUND)) == "Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))"
    # the binding keeps its ObjectSet type: Unique is inserted at the use, not in the binding
    assert parse(CAUSE).binding_types["AffectorObject"] is DslType.OBJECT_SET


def test_paper_programs_on_e1(e1: Simulation) -> None:
    assert parse(FALL_TO_GROUND).run(e1) == 2
    # E1 has no small yellow cube, small gray cube or small brown circle: Unique fails, the answer is INVALID
    for name in ("after_entering", "cf_count", "cf_any_other", "cause", "enable", "prevent"):
        assert parse(PAPER[name][0]).run(e1) is INVALID, name


def test_paper_programs_on_a_scene_with_their_objects() -> None:
    sim = make_sim(
        [(6, "ground"), (5, "basket"), (3, "small yellow cube", (0.0, 0.0)), (2, "small brown circle", (2.0, 0.0)),
         (1, "small gray cube", (1.0, 0.0)), (0, "large red triangle")],
        [(30, "Collision", 2, 3), (60, "EnterBasket", 5, 3), (90, "Collision", 3, 0), (100, "Collision", 0, 6)],
        {
            3: [(100, "Collision", 0, 6)],
            2: [(100, "Collision", 0, 6)],
            1: [(30, "Collision", 2, 3), (60, "EnterBasket", 5, 3), (90, "Collision", 3, 0), (100, "Collision", 0, 6)],
            0: [(30, "Collision", 2, 3), (60, "EnterBasket", 5, 3)],
        },
    )
    assert parse(AFTER_ENTERING).run(sim) is True  # yellow cube hits the red triangle after entering
    assert parse(CF_COUNT).run(sim) == 2  # without the cube: red triangle and ground
    assert parse(CF_ANY_OTHER).run(sim) is False  # the gray cube never enters
    assert parse(CAUSE).run(sim) is True  # brown circle makes the resting yellow cube enter
    assert parse(ENABLE).run(sim) == 0
    assert parse(PREVENT).run(sim) is False


# -- text form freedoms --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        'Count(FilterShape(SceneAtStart(), "circle"))',
        'Count(FilterShape(SceneAtStart(), "Circle"))',
        'Count(FilterShape(SceneAtStart(), "CIRCLE"))',
        "Count(FilterShape(SceneAtStart(), \u201cCircle\u201d))",
        "Count(FilterShape(SceneAtStart(), \u201ccircle\"))",
        'Count(FilterShape(SceneAtStart(), "sphere"))',
        'Count(FilterShape(SceneAtStart(), "Ball"))',
        'Count ( FilterShape ( SceneAtStart ( ) , "circle" ) )',
        'Count(\n\tFilterShape(\n\t\tSceneAtStart(),\n\t\t"circle"\n\t)\n)\n',
        '# a comment line\nCount(FilterShape(SceneAtStart(), "circle"))  # trailing comment\n# end',
        'Count(FilterShape(SceneAtStart(), # comment inside\n "circle"))',
        '\n\n   Count(FilterShape(SceneAtStart(),"circle"))   \n\n',
        "Count(FilterShape(SceneAtStart(),\u00a0\"circle\"))",
        'count(filter_shape(start_scene(), "circle"))',
    ],
)
def test_free_layout_quotes_case_comments_aliases(text: str) -> None:
    assert parse(text) == parse('Count(FilterShape(SceneAtStart(), "circle"))')
    assert str(parse(text)) == 'Count(FilterShape(SceneAtStart(), "circle"))'


@pytest.mark.parametrize(
    ("written", "canonical"),
    [("Small", "small"), ("tiny", "small"), ("Big", "large"), ("LARGE", "large")],
)
def test_size_values(written: str, canonical: str) -> None:
    assert str(parse(f'FilterSize(SceneAtStart(), "{written}")')) == f'FilterSize(SceneAtStart(), "{canonical}")'


@pytest.mark.parametrize(
    ("written", "canonical"),
    [("Grey", "gray"), ("gray", "gray"), ("Yellow", "yellow"), ("CYAN", "cyan")],
)
def test_colour_values(written: str, canonical: str) -> None:
    assert str(parse(f'FilterColor(SceneAtStart(), "{written}")')) == f'FilterColor(SceneAtStart(), "{canonical}")'


@pytest.mark.parametrize(("written", "canonical"), [("Cube", "cube"), ("block", "cube"), ("box", "cube"),
                                                    ("Triangle", "triangle")])
def test_shape_values(written: str, canonical: str) -> None:
    assert str(parse(f'FilterShape(SceneAtStart(), "{written}")')) == f'FilterShape(SceneAtStart(), "{canonical}")'


def test_bindings_and_references() -> None:
    p = parse("Var A = SceneAtStart()\nVar B = FilterDynamic(A)\nCount(Difference(A, B))")
    assert p.binding_types == {"A": DslType.OBJECT_SET, "B": DslType.OBJECT_SET}
    assert str(p) == "Var A = SceneAtStart()\nVar B = FilterDynamic(A)\nCount(Difference(A, B))"
    # layout of bindings is free too
    q = parse("Var A=SceneAtStart() Var B=FilterDynamic( A )   Count( Difference( A , B ) )")
    assert p == q
    # a binding is not the same program as its inlined form
    assert p != parse("Count(Difference(SceneAtStart(), FilterDynamic(SceneAtStart())))")


def test_var_names_may_start_with_var_or_be_module_names(e1: Simulation) -> None:
    p = parse("Var Variable = SceneAtStart()\nVar Count = FilterDynamic(Variable)\nCount(Count)")
    assert p.run(e1) == 4
    assert parse(str(p)) == p


def test_integer_literals() -> None:
    p = parse("LessThan(Count(SceneAtStart()), -3)")
    assert str(p) == "LessThan(Count(SceneAtStart()), -3)"
    assert parse(str(p)) == p
    assert parse("FilterMoving(SceneAtStart(), 0)").type is DslType.OBJECT_SET


def test_equality_ignores_positions_and_hash_agrees() -> None:
    a = parse('Count(FilterColor(SceneAtStart(), "red"))')
    b = parse('\n\n   Count(\n FilterColor( SceneAtStart() , "Red" ) )')
    assert a == b and hash(a) == hash(b)
    assert a != parse('Count(FilterColor(SceneAtStart(), "blue"))')
    assert len({a, b}) == 1


def test_program_type_for_each_answer_type() -> None:
    red = 'FilterColor(SceneAtStart(), "red")'
    assert parse(f"QueryColor({red})").type is DslType.COLOR
    assert parse(f"QueryShape({red})").type is DslType.SHAPE
    assert parse(f"QuerySize({red})").type is DslType.SIZE
    assert parse(f"Exist({red})").type is DslType.BOOL
    assert parse(f"Count({red})").type is DslType.INTEGER
    assert parse(f"Unique({red})").type is DslType.OBJECT
    assert parse("FilterFirst(Events())").type is DslType.EVENT


def test_unique_is_not_inserted_where_an_object_set_is_expected() -> None:
    p = parse('Count(FilterColor(SceneAtStart(), "red"))')
    assert "Unique" not in str(p)
    # explicit Unique stays, and no second Unique is added
    q = parse('QueryColor(Unique(FilterColor(SceneAtStart(), "red")))')
    assert str(q) == 'QueryColor(Unique(FilterColor(SceneAtStart(), "red")))'
    assert q == parse('QueryColor(FilterColor(SceneAtStart(), "red"))')


def test_program_construction_routes_agree() -> None:
    text = 'Count(FilterColor(SceneAtStart(), "red"))'
    assert Program.parse(text) == parse(text)
    assert repr(parse(text)).startswith("Program(")


# -- errors ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("Count(SceneAtStart()", 1, 21),  # unclosed
        ("Count(SceneAtStart()))", 1, 22),  # one ')' too many
        ("Count(\n  SceneAtStart()\n  SceneAtEnd())", 3, 3),  # missing comma
        ("Count(SceneAtStart() & x)", 1, 22),  # stray character
        ('Count(FilterColor(SceneAtStart(), "red))', 1, 35),  # unterminated string
        ("Var 1X = SceneAtStart()\nCount(1X)", 1, 5),
        ("", 1, 1),
        ("# only a comment\n", 1, 1),
    ],
)
def test_parse_errors_point_at_line_and_column(text: str, line: int, column: int) -> None:
    with pytest.raises(ParseError) as info:
        parse(text)
    assert (info.value.line, info.value.column) == (line, column)
    assert f"line {line}, column {column}" in str(info.value)


def test_parse_error_messages_say_what_is_wrong() -> None:
    with pytest.raises(ParseError, match="too early|unclosed"):
        parse("Count(SceneAtStart()")
    with pytest.raises(ParseError, match="comma"):
        parse("Count(SceneAtStart() SceneAtEnd())")
    with pytest.raises(ParseError, match="empty"):
        parse("   ")


def test_trailing_comma_message_is_not_misleading() -> None:
    with pytest.raises(ParseError) as info:
        parse("Count(SceneAtStart(),)")
    assert (info.value.line, info.value.column) == (1, 22)
    assert "closes no open parenthesis" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "needles", "where"),
    [
        ("FilterEvents(Events(), Events())", ["FilterEvents", "argument 2", "Object", "EventSet"], (1, 24)),
        ("Count(Unique(SceneAtStart()))", ["Count", "argument 1", "ObjectSet", "EventSet", "Object"], (1, 7)),
        ("IsBefore(Events(), FilterFirst(Events()))", ["IsBefore", "argument 1", "Event", "EventSet"], (1, 10)),
        ("AnyTrue(FilterDynamic(SceneAtStart()))", ["AnyTrue", "argument 1", "BoolList", "ObjectSet"], (1, 9)),
        ("QueryColor(3)", ["QueryColor", "argument 1", "Object", "Integer"], (1, 12)),
        ("Exist(GetCounterfactEventsList(SceneAtStart()))", ["Exist", "argument 1", "EventSetList"], (1, 7)),
        ("FilterMoving(SceneAtStart(), SceneAtEnd())", ["FilterMoving", "argument 2", "Integer", "ObjectSet"], None),
        ("IntersectList(SceneAtStart(), SceneAtStart())",
         ["IntersectList", "argument 1", "ObjectSetList", "ObjectSet"], None),
    ],
)
def test_type_errors_name_module_argument_expected_and_found(
    text: str, needles: list[str], where: tuple[int, int] | None
) -> None:
    with pytest.raises(TypeCheckError) as info:
        parse(text)
    message = str(info.value)
    for needle in needles:
        assert needle in message, (needle, message)
    if where is not None:
        assert (info.value.line, info.value.column) == where


def test_type_error_on_a_later_line() -> None:
    with pytest.raises(TypeCheckError) as info:
        parse("Var E = Events()\nCount(\n    FilterEvents(E, E)\n)")
    assert (info.value.line, info.value.column) == (3, 21)
    assert "FilterEvents" in str(info.value)


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        ('Count("red")', ["Count", "argument 1", "ObjectSet"]),
        ('EqualInteger(Count(SceneAtStart()), "red")', ["EqualInteger", "argument 2", "Integer", "'red'"]),
    ],
)
def test_quoted_value_in_an_input_position_names_module_and_argument(text: str, needles: list[str]) -> None:
    with pytest.raises(TypeCheckError) as info:
        parse(text)
    for needle in needles:
        assert needle in str(info.value)


def test_side_input_must_be_a_quoted_value() -> None:
    with pytest.raises(TypeCheckError, match=r"FilterColor.*argument 2.*Color"):
        parse("FilterColor(SceneAtStart(), SceneAtStart())")
    with pytest.raises(TypeCheckError, match=r"FilterSize.*argument 2.*integer"):
        parse("FilterSize(SceneAtStart(), 3)")


@pytest.mark.parametrize(
    ("text", "suggestion"),
    [
        ("Cnt(SceneAtStart())", "Count"),
        ("COUNT(SceneAtStart())", "Count"),
        ('FilterColour(SceneAtStart(), "red")', "FilterColor"),
        ("FilterEnterContainer(Events())", "FilterEnterBasket"),
        ("filter_enter_basket(Events())", "FilterEnterBasket"),
        ("SceneAtBeginning()", "SceneAtStart"),
        ("GetCounterfactualEvents(SceneAtStart())", "GetCounterfactEvents"),
    ],
)
def test_unknown_module_suggests_nearest_names(text: str, suggestion: str) -> None:
    with pytest.raises(UnknownModuleError) as info:
        parse(text)
    assert suggestion in str(info.value)
    assert (info.value.line, info.value.column) == (1, 1)


def test_unknown_module_without_near_name_still_explains() -> None:
    with pytest.raises(UnknownModuleError, match="unknown module 'Xyzzy'"):
        parse("Xyzzy()")


def test_unknown_module_inside_a_program_points_at_it() -> None:
    with pytest.raises(UnknownModuleError) as info:
        parse("Count(\n  FilterDynamc(SceneAtStart()))")
    assert (info.value.line, info.value.column) == (2, 3)
    assert "FilterDynamic" in str(info.value)


def test_unsupported_original_module_is_explained() -> None:
    with pytest.raises(UnknownModuleError, match="relate.*not supported"):
        parse("relate(SceneAtStart())")


@pytest.mark.parametrize(
    ("text", "allowed"),
    [
        ('FilterColor(SceneAtStart(), "pink")', ["gray", "red", "blue", "green", "brown", "purple", "cyan", "yellow"]),
        ('FilterColor(SceneAtStart(), "small")', ["gray", "yellow"]),
        ('FilterShape(SceneAtStart(), "ground")', ["cube", "triangle", "circle"]),
        ('FilterShape(SceneAtStart(), "square")', ["cube", "triangle", "circle"]),
        ('FilterSize(SceneAtStart(), "medium")', ["small", "large"]),
        ('FilterColor(SceneAtStart(), "")', ["gray", "red"]),
    ],
)
def test_unknown_side_input_lists_allowed_values(text: str, allowed: list[str]) -> None:
    with pytest.raises(SideInputError) as info:
        parse(text)
    for value in allowed:
        assert value in str(info.value)
    assert (info.value.line, info.value.column) == (1, text.index('"') + 1)


def test_unknown_var() -> None:
    with pytest.raises(ProgramError, match="unknown variable 'Objs'") as info:
        parse("Var Obj = SceneAtStart()\nCount(Objs)")
    assert (info.value.line, info.value.column) == (2, 7)
    assert "Obj" in str(info.value)  # lists what is defined


def test_var_used_before_its_binding() -> None:
    with pytest.raises(ProgramError, match="unknown variable 'B'"):
        parse("Var A = FilterDynamic(B)\nVar B = SceneAtStart()\nCount(A)")
    with pytest.raises(ProgramError, match="unknown variable 'A'"):
        parse("Var A = FilterDynamic(A)\nCount(A)")


def test_module_name_used_as_a_var_hints_at_a_call() -> None:
    with pytest.raises(ProgramError, match=r"SceneAtStart\(\.\.\.\)"):
        parse("Count(SceneAtStart)")


def test_var_bound_twice() -> None:
    with pytest.raises(ProgramError, match="bound twice") as info:
        parse("Var X = SceneAtStart()\nVar X = SceneAtEnd()\nCount(X)")
    assert (info.value.line, info.value.column) == (2, 5)


@pytest.mark.parametrize(
    ("text", "module", "expected", "found"),
    [
        ("Count()", "Count", "1 argument", "found 0"),
        ("Count(SceneAtStart(), SceneAtStart())", "Count", "1 argument", "found 2"),
        ("SceneAtStart(Events())", "SceneAtStart", "0 arguments", "found 1"),
        ("FilterColor(SceneAtStart())", "FilterColor", "2 arguments", "found 1"),
        ('FilterColor(SceneAtStart(), "red", "blue")', "FilterColor", "2 arguments", "found 3"),
        ("FilterMoving(SceneAtStart())", "FilterMoving", "2 arguments", "found 1"),
    ],
)
def test_wrong_arity(text: str, module: str, expected: str, found: str) -> None:
    with pytest.raises(TypeCheckError) as info:
        parse(text)
    message = str(info.value)
    assert module in message and expected in message and found in message


def test_errors_are_program_errors() -> None:
    for bad in ("Count(", "Cnt()", "Count(Events(), 1)", 'FilterColor(SceneAtStart(), "x")', "Count(X)"):
        with pytest.raises(ProgramError):
            parse(bad)


def test_quoted_value_where_a_colour_is_expected_is_a_literal(e1: Simulation) -> None:
    p = parse('EqualColor(QueryColor(FilterColor(SceneAtStart(), "red")), "Red")')
    assert str(p) == 'EqualColor(QueryColor(Unique(FilterColor(SceneAtStart(), "red"))), "red")'
    assert p.run(e1) is True
    with pytest.raises(SideInputError, match="allowed: gray"):
        parse('EqualColor(QueryColor(FilterColor(SceneAtStart(), "red")), "pink")')
