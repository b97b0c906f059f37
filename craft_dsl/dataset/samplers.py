"""Who draws a video's start state: a revision of craft_dsl's layout files, or the original simulator's own sampler.

* ``layouts-2`` (the default): :func:`craft_dsl.scenes.sample_world` on revision 2 of the built-in layouts, which
  follows the original wherever the comparison of the two samplers (docs/sampler.md) found a difference;
* ``layouts-1``: revision 1 of the built-in layouts, what every dataset made before revision 2 used (a
  ``generation_config.json`` that names no sampler);
* ``original``: the original CRAFT simulator's own scene generation, seeded through the build's edit
  (:func:`craft_dsl.physics.original_sampler.sample_original`); built-in scenes only, and the original simulator
  must be built.

The video's simulation seed (a 32-bit integer) seeds whichever sampler it is.
"""

from __future__ import annotations

from typing import Any, Final, Literal

from ..errors import CraftError
from ..scenes import SceneLayout, sample_world
from ..world import WorldSpec

Sampler = Literal["layouts-2", "layouts-1", "original"]
#: Every sampler a dataset can name, the default first.
SAMPLERS: Final[tuple[str, ...]] = ("layouts-2", "layouts-1", "original")
#: What new datasets use.
DEFAULT_SAMPLER: Final = "layouts-2"
#: What a ``generation_config.json`` that names no sampler was made with.
LEGACY_SAMPLER: Final = "layouts-1"
#: The command line's short name for the current layouts.
SAMPLER_ALIASES: Final = {"layouts": DEFAULT_SAMPLER}
ORIGINAL_SAMPLER: Final = "original"


def layout_revision(sampler: str) -> int:
    """The revision of the built-in layouts a ``layouts-N`` sampler draws from."""
    if not sampler.startswith("layouts-") or sampler not in SAMPLERS:
        raise CraftError(f"{sampler!r} does not sample from the layout files; layout samplers: "
                         f"{', '.join(s for s in SAMPLERS if s.startswith('layouts-'))}")
    return int(sampler.removeprefix("layouts-"))


def start_state(scene: int, seed: int, sampler: str, layout: SceneLayout | None = None) -> WorldSpec:
    """The start state of a video of ``scene`` with simulation seed ``seed`` (``layout``: a custom scene's layout,
    which only the layout samplers take)."""
    if sampler == ORIGINAL_SAMPLER:
        if layout is not None:
            raise CraftError(f"scene {scene} is a custom layout; the original's sampler makes the 20 built-in "
                             "scenes only")
        from ..physics.original_sampler import sample_original

        return sample_original(scene, seed)
    revision = layout_revision(sampler)
    return sample_world(layout if layout is not None else scene, seed, revision)


def check_sampler_scenes(sampler: str, scenes: tuple[Any, ...]) -> str | None:
    """Why ``sampler`` cannot make these scene entries (ints are built-in ids), or None."""
    custom = [s for s in scenes if not isinstance(s, int)]
    if sampler == ORIGINAL_SAMPLER and custom:
        return ("sampler original draws the 20 built-in scenes only; give custom layouts to a dataset of the "
                "layout sampler (layouts-2)")
    return None


__all__ = ["DEFAULT_SAMPLER", "LEGACY_SAMPLER", "ORIGINAL_SAMPLER", "SAMPLERS", "SAMPLER_ALIASES", "Sampler",
           "check_sampler_scenes", "layout_revision", "start_state"]
