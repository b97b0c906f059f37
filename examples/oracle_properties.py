"""Property tests of your own semantic parser and executor, with craft_dsl as the oracle.

    python -m pytest examples/oracle_properties.py

Two toy components stand for yours. ``toy_parser`` maps the text of a CRAFT question ("How many blocks fall
into the bucket?") to a program; it knows eight descriptive templates. ``toy_executor`` runs a CLEVR/CRAFT node
list over a recorded simulation file's JSON, the way a plain-Python executor would; it knows twelve modules.
The strategies of craft_dsl.strategies draw the inputs, and craft_dsl answers what is right: the generator's
own program for each question, and ``Program.run`` for each node list. When a property fails, hypothesis
reports the smallest question, node list and simulation that show it.
"""

from __future__ import annotations

import re
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from craft_dsl import DslType, Program, Simulation
from craft_dsl.recorded import simulation_dict
from craft_dsl.strategies import QuestionRecord, node_lists, questions, simulations
from craft_dsl.vocabulary import SHAPES, SIZES

# -- a toy semantic parser: question text -> program ----------------------------------------------------------

#: "How many <S>s / <C> objects / <Z> objects / objects enter the basket / fall to the ground?"
TOY_TEMPLATES = [f"descriptive_{i}" for i in range(4, 12)]
QUESTION = re.compile(r"How many (?P<what>.+?) (?P<verb>enter|go into|get into|end up in|fall into|fall to|hit) "
                      r"the (?P<place>basket|container|bucket|ground|floor)\?")
VALUE_WORDS = {"block": "cube", "big": "large", "tiny": "small"}


def toy_parser(question: str) -> Program:
    match = QUESTION.fullmatch(question)
    if match is None:
        raise ValueError(f"the toy parser does not know {question!r}")
    events = "FilterCollideGround" if match["verb"] in ("fall to", "hit") else "FilterEnterBasket"
    objects = f"FilterDynamic(FilterObjectsFromEvents({events}(Events())))"
    what = match["what"]
    if what != "objects":
        word = what.removesuffix(" objects") if what.endswith(" objects") else what.removesuffix("s")
        word = VALUE_WORDS.get(word, word)
        module = "FilterSize" if word in SIZES else "FilterShape" if word in SHAPES else "FilterColor"
        objects = f'{module}({objects}, "{word}")'
    return Program.parse(f"Count({objects})")


@given(questions(TOY_TEMPLATES))
def test_parser_gives_the_generators_program(q: QuestionRecord) -> None:
    assert toy_parser(q.text) == q.program


@given(questions(TOY_TEMPLATES), simulations())
def test_parser_answers_like_the_oracle(q: QuestionRecord, sim: Simulation) -> None:
    assert toy_parser(q.text).run(sim) == q.program.run(sim)


# -- a toy executor: node list + recorded JSON -> answer ----------------------------------------------------------

TOY_MODULES = ["SceneAtStart", "SceneAtEnd", "Events", "FilterCollideGround", "FilterEnterBasket",
               "FilterObjectsFromEvents", "FilterDynamic", "FilterColor", "FilterShape", "FilterSize", "Count",
               "Exist"]


def toy_executor(nodes: list[dict[str, Any]], recorded: dict[str, Any]) -> Any:
    video = recorded["original_video_output"]
    objects = {o["uniqueID"]: o for o in video["scene_states"][0]["scene"]["objects"]}
    events = sorted(video["causal_graph"]["nodes"], key=lambda e: (e["step"], e["id"]))
    ground = next(i for i, o in objects.items() if o["shape"] == "ground")
    outputs: list[Any] = []
    for node in nodes:
        kind, args, values = node["type"], [outputs[i] for i in node["inputs"]], node["value_inputs"]
        if kind in ("start_scene", "end_scene"):
            out: Any = sorted(objects)
        elif kind == "events":
            out = events
        elif kind == "filter_collide_ground":
            out = [e for e in args[0] if e["type"] == "Collision" and ground in e["objects"]]
        elif kind == "filter_enter_container":
            out = [e for e in args[0] if e["type"] == "ContainerEndUp"]
        elif kind == "filter_objects_from_events":
            out = sorted({o for e in args[0] for o in e["objects"]})
        elif kind == "filter_dynamic_objects":
            out = [o for o in args[0] if objects[o]["bodyType"] == 2]
        elif kind in ("filter_color", "filter_shape", "filter_size"):
            out = [o for o in args[0] if objects[o][kind.removeprefix("filter_")] == values[0]]
        elif kind == "count":
            out = len(args[0])
        elif kind in ("exist", "event_exist"):
            out = len(args[0]) > 0
        else:
            raise NotImplementedError(kind)
        outputs.append(out)
    return outputs[-1]


@given(node_lists((DslType.INTEGER, DslType.BOOL), modules=TOY_MODULES), simulations())
def test_executor_agrees_with_the_oracle(nodes: list[dict[str, Any]], sim: Simulation) -> None:
    assert toy_executor(nodes, simulation_dict(sim)) == Program.from_nodes(nodes).run(sim)


# -- any program, through st.from_type ------------------------------------------------------------------------


@given(st.from_type(Program))
def test_every_program_prints_and_parses_back(program: Program) -> None:
    assert Program.parse(str(program)) == program
