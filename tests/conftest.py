"""Shared fixtures: the worked example scene E1 and a compact builder for hand-made simulations.

Compact descriptions used by :func:`make_sim`:

* an object is ``(id, description)`` or ``(id, description, start_velocity)`` or
  ``(id, description, start_velocity, end_velocity)``; the description is either one static shape
  (``"ground"``, ``"basket"``, ``"platform"`` ...; black, large, static) or ``"<size> <colour> <shape>"``
  for a dynamic object (``"small red cube"``);
* an event is ``(step, type, *object_ids)``, e.g. ``(40, "Collision", 3, 2)`` or
  ``(80, "EnterBasket", 5, 2)``; events are numbered in list order, so among events of the same step
  the list order is the time order (as the loader's stable sort does for files). Start (step -1) and End
  (step = ``steps``) are added unless ``start_end=False``;
* counterfactuals are a dict ``{removed_object_id: [event, ...]}``; the counterfactual simulation holds
  the same objects without the removed one. Asking for an object that is not a key raises
  :class:`craft_dsl.CounterfactualUnavailable` naming it.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

from craft_dsl import (
    CounterfactualUnavailable,
    Event,
    ObjectState,
    SimObject,
    Simulation,
    load_simulation,
)
from craft_dsl.vocabulary import STATIC_SHAPES

DATA = Path(__file__).parent / "data"
E1_PATH = DATA / "e1.json"
E1_EXPECTED_PATH = DATA / "e1_expected.json"

Velocity = tuple[float, float]
ObjectSpec = tuple[Any, ...]
EventSpec = tuple[Any, ...]

#: A small standard scene (ids as the simulator would assign them: dynamic objects get the smallest).
BASIC_OBJECTS: list[ObjectSpec] = [
    (6, "ground"),
    (5, "basket"),
    (4, "platform"),
    (3, "large red cube", (-10.0, -4.0), (0.0, 0.0)),
    (2, "small blue circle", (0.0, 0.0), (0.0005, 0.0)),
    (1, "small green triangle", (0.0, 0.0), (0.5, 0.0)),
    (0, "large yellow circle", (3.0, -8.0), (0.0, -0.002)),
]


def make_object(oid: int, description: str, v0: Velocity = (0.0, 0.0), v1: Velocity = (0.0, 0.0)) -> SimObject:
    """A SimObject from ``"ground"`` (static) or ``"small red cube"`` (dynamic)."""
    words = description.split()
    if len(words) == 1:
        assert words[0] in STATIC_SHAPES, f"unknown static shape {words[0]!r}"
        return SimObject(oid, words[0], "black", "large", False,
                         ObjectState(velocity=v0), ObjectState(velocity=v1))
    size, color, shape = words
    return SimObject(oid, shape, color, size, True, ObjectState(velocity=v0), ObjectState(velocity=v1))


def make_events(specs: Sequence[EventSpec], steps: int, start_end: bool = True) -> list[Event]:
    """Events numbered in list order (Start first, End last when added)."""
    events: list[Event] = []
    if start_end:
        events.append(Event(0, "Start", -1, ()))
    for step, etype, *objs in specs:
        events.append(Event(len(events), etype, int(step), tuple(int(o) for o in objs)))
    if start_end:
        events.append(Event(len(events), "End", steps, ()))
    return events


def make_sim(
    objects: Sequence[ObjectSpec],
    events: Sequence[EventSpec] = (),
    counterfactuals: Mapping[int, Sequence[EventSpec]] | None = None,
    steps: int = 600,
    start_end: bool = True,
) -> Simulation:
    """A hand-made Simulation from compact descriptions (see the module docstring)."""
    objs = [make_object(*spec) for spec in objects]
    removals: dict[int, Sequence[EventSpec]] = dict(counterfactuals or {})

    def source(removed: int) -> Simulation:
        if removed not in removals:
            raise CounterfactualUnavailable(f"no counterfactual for object {removed} in this hand-made scene")
        rest = [o for o in objs if o.id != removed]
        return Simulation(rest, make_events(removals[removed], steps, start_end), steps=steps, removed=(removed,))

    return Simulation(objs, make_events(events, steps, start_end), steps=steps,
                      counterfactuals=source if counterfactuals is not None else None)


def e1_data() -> dict[str, Any]:
    """A fresh copy of the parsed E1 file (tests may mutate it)."""
    return copy.deepcopy(_E1_DATA)


_E1_DATA: dict[str, Any] = json.loads(E1_PATH.read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def e1() -> Simulation:
    """The worked example scene E1, loaded from tests/data/e1.json."""
    return load_simulation(E1_PATH)


@pytest.fixture
def e1_dict() -> dict[str, Any]:
    """A mutable copy of E1's JSON content."""
    return e1_data()


@pytest.fixture(scope="session")
def e1_expected() -> list[dict[str, Any]]:
    """The 65 expected answers of the worked example (the original engine's)."""
    data: list[dict[str, Any]] = json.loads(E1_EXPECTED_PATH.read_text(encoding="utf-8"))
    return data


@pytest.fixture
def sim_builder() -> Callable[..., Simulation]:
    """The :func:`make_sim` builder, as a fixture."""
    return make_sim


@pytest.fixture(scope="session")
def basic_sim() -> Simulation:
    """BASIC_OBJECTS with a few events and counterfactuals for every dynamic object."""
    return make_sim(
        BASIC_OBJECTS,
        [(40, "Collision", 3, 2), (40, "Collision", 0, 4), (80, "EnterBasket", 5, 2),
         (140, "Collision", 1, 6), (145, "TouchStart", 6, 1)],
        {3: [(40, "Collision", 0, 4)], 2: [(85, "EnterBasket", 5, 3)], 1: [], 0: [(40, "Collision", 3, 2)]},
    )


# -- a small generated dataset with videos, shared by the tests of the dataset's user-facing parts -------------

#: 6 videos over scenes 1 (hard split: train), 8 (validation) and 11 (test), 200 steps, MPEG-1 videos.
USERS_DATASET = {"size": 6, "seed": 0, "scenes": (1, 8, 11), "steps": 200, "perturbations": 0, "balance": False,
                 "videos": True}


@pytest.fixture(scope="session")
def users_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset folder written by ``generate_dataset`` with ``videos=True`` (read-only for tests: copy to change)."""
    from craft_dsl.dataset.pipeline import GenerationConfig, generate_dataset

    out = tmp_path_factory.mktemp("users") / "craft6"
    generate_dataset(GenerationConfig.make(**USERS_DATASET), out)
    return out


@pytest.fixture(scope="session")
def video(users_dataset: Path) -> Path:
    """The first video of ``users_dataset`` (an MPEG-1 file as ``generate`` writes it; read-only)."""
    return sorted((users_dataset / "videos").rglob("*.mpg"))[0]


# -- hypothesis profiles ----------------------------------------------------------------------------------------
# "ci" (the default): hypothesis's 100 examples per test, no deadline (the machines are shared). "long": the fuzz
# tests for about 30 minutes on 2 cores: python -m pytest tests/ -k fuzz --hypothesis-profile=long
settings.register_profile("ci", deadline=None)
settings.register_profile("long", deadline=None, max_examples=10_000,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.load_profile("ci")
