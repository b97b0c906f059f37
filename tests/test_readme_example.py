"""The README's first example prints what it says."""

from __future__ import annotations

from craft_dsl import parse, simulate


def test_readme_first_example_answers_3() -> None:
    q = parse('Var QueryObject = FilterShape(FilterColor(FilterSize(SceneAtStart(), "Small"), "Yellow"), "Cube")\n'
              "Count(FilterObjectsFromEvents(FilterCollideGround(GetCounterfactEvents(QueryObject))))")
    assert q.run(simulate(scene=2, seed=0)) == 3
