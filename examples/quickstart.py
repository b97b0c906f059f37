"""Quick start: parse CRAFT programs, run them over a recorded simulation, inspect a trace.

    python examples/quickstart.py
"""

from __future__ import annotations

from pathlib import Path

from craft_dsl import INVALID, load_simulation, parse
from craft_dsl.program import format_value

E1 = Path(__file__).resolve().parents[1] / "tests" / "data" / "e1.json"

QUESTIONS = {
    "How many objects fall to the ground?":
        "Count(FilterDynamic(FilterObjectsFromEvents(FilterCollideGround(Events()))))",
    "What colour is the object the large red cube first collides with?":
        'Var Red = FilterShape(FilterColor(FilterSize(SceneAtStart(), "Large"), "Red"), "Cube")\n'
        "QueryColor(EventPartner(FilterFirst(FilterCollisionWithDynamics(FilterEvents(Events(), Red))), Red))",
    "Does the large red cube cause the small blue circle to enter the basket?":
        'Var Red = FilterShape(FilterColor(FilterSize(SceneAtStart(), "Large"), "Red"), "Cube")\n'
        'Var Blue = FilterShape(FilterColor(FilterSize(SceneAtStart(), "Small"), "Blue"), “Circle”)\n'
        "Exist(FilterStationary(Intersect(Difference(FilterObjectsFromEvents(FilterEnterBasket(Events())),\n"
        "    FilterObjectsFromEvents(FilterEnterBasket(GetCounterfactEvents(Red)))), AsList(Blue)),\n"
        "    StartSceneStep()))",
    "What shape is the green cube?": 'QueryShape(FilterShape(FilterColor(SceneAtStart(), "green"), "cube"))',
}


def main() -> None:
    sim = load_simulation(E1)
    for question, text in QUESTIONS.items():
        program = parse(text)
        answer = program.run(sim)
        shown = "INVALID (no such object)" if answer is INVALID else answer
        print(f"{question}\n  {program.type}: {shown}")
    print("\nTrace of the first program:")
    for entry in parse(next(iter(QUESTIONS.values()))).trace(sim):
        print(f"  {entry.expression:75.75} -> {format_value(entry.value)}")


if __name__ == "__main__":
    main()
