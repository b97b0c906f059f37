"""Hypothesis's entry point: ``st.from_type`` draws craft_dsl's Program, Simulation and WorldSpec.

Hypothesis calls :func:`_hypothesis_setup_hook` when it is imported (the ``hypothesis`` entry-point group
in pyproject.toml), so ``st.from_type(craft_dsl.Program)`` works in any test without importing
:mod:`craft_dsl.strategies` first. The hook imports the core package (no physics engine) and registers
functions that build the strategies only when a test first asks for them. ``HYPOTHESIS_NO_PLUGINS=1``
turns every such hook off.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hypothesis.strategies import SearchStrategy

    from .program import Program
    from .simulation import Simulation
    from .world import WorldSpec


def _programs(_: type) -> SearchStrategy[Program]:
    from .strategies import programs

    return programs()


def _simulations(_: type) -> SearchStrategy[Simulation]:
    from .strategies import simulations

    return simulations()


def _world_specs(_: type) -> SearchStrategy[WorldSpec]:
    from .strategies import world_specs

    return world_specs()


def _hypothesis_setup_hook() -> None:
    """Register :func:`~craft_dsl.strategies.programs`, :func:`~craft_dsl.strategies.simulations` and
    :func:`~craft_dsl.strategies.world_specs` as the strategies of their types."""
    from hypothesis import strategies as st

    from .program import Program
    from .simulation import Simulation
    from .world import WorldSpec

    st.register_type_strategy(Program, _programs)
    st.register_type_strategy(Simulation, _simulations)
    st.register_type_strategy(WorldSpec, _world_specs)
