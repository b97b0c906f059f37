"""A slot the original leaves empty on a duplicate triple (scene 7's last object): the reader reads the scene the
video shows, with that slot absent, and reads the full scene where the object is there."""

from __future__ import annotations

import pytest

from craft_dsl.physics import simulate
from craft_dsl.reader.layout_model import LayoutModel, layout_model
from craft_dsl.reader.perceive import perceive_frames
from craft_dsl.render import frames as render_frames
from craft_dsl.scenes import sample_world

#: A seed of scene 7 whose 4th object revision 2 drops, and one that keeps it.
DROPPED, KEPT = 16, 0


def _dynamic(world: object) -> list[tuple[str, str, str]]:
    return sorted((b.shape, b.color, b.size) for b in world.bodies if b.dynamic)  # type: ignore[attr-defined]


def test_the_seeds_are_what_they_say() -> None:
    assert len(_dynamic(sample_world(7, DROPPED))) == 3
    assert len(_dynamic(sample_world(7, KEPT))) == 4


def test_a_layout_model_without_a_drop_slot_renumbers_the_draws() -> None:
    full, less = layout_model(7), layout_model(7, (3,))
    assert len(full.layout.dynamic) == 4 and len(less.layout.dynamic) == 3 and less.absent == (3,)
    values = {"variables.x": 20.0, "dynamic[3].velocity[0]": 4.0, "dynamic[0].position[0]": -12.0}
    assert less.renumbered(values) == {"variables.x": 20.0, "dynamic[0].position[0]": -12.0}
    assert full.fixed_start(3, {}) == (-12.0, 11.0)
    with pytest.raises(ValueError, match="only a slot that drops its object"):
        LayoutModel(7, (0,))


@pytest.mark.parametrize("seed", [DROPPED, KEPT])
def test_the_reader_reads_the_objects_the_video_shows(seed: int) -> None:
    sim = simulate(sample_world(7, seed), steps=240)
    perception = perceive_frames(render_frames(sim))
    read = sorted((o.shape, o.color, o.size) for o in perception.reconstruction.simulation.world_spec.bodies
                  if o.dynamic)
    assert read == _dynamic(sim.world_spec)
