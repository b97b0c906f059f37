"""The CRAFT vocabulary: shapes, colours, sizes, event types, and their accepted aliases.

This module is the single source of truth for every closed set of names in craft_dsl.
"""

from __future__ import annotations

from typing import Final

SHAPES: tuple[str, ...] = ("cube", "triangle", "circle")
COLORS: tuple[str, ...] = ("gray", "red", "blue", "green", "brown", "purple", "cyan", "yellow")
SIZES: tuple[str, ...] = ("small", "large")

#: Shapes of static scene elements. No shape filter of the vocabulary keeps them.
STATIC_SHAPES: tuple[str, ...] = (
    "ground", "wall_l", "wall_r", "basket", "platform", "ramp", "static_ball", "table",
)
STATIC_COLOR = "black"
STATIC_SIZE = "large"

#: RGB of every colour, as the original simulator draws them.
COLOR_RGB: dict[str, tuple[int, int, int]] = {
    "gray": (87, 87, 87),
    "red": (173, 35, 35),
    "blue": (42, 75, 215),
    "green": (29, 105, 20),
    "brown": (129, 74, 25),
    "purple": (129, 38, 192),
    "cyan": (41, 208, 208),
    "yellow": (255, 238, 51),
    "black": (0, 0, 0),
}

#: Words accepted in side inputs besides the canonical values (the generator's synonyms).
VALUE_ALIASES: dict[str, str] = {
    "block": "cube",
    "box": "cube",
    "sphere": "circle",
    "ball": "circle",
    "big": "large",
    "tiny": "small",
    "grey": "gray",
}

#: Physics engines behind the simulator protocol.
ENGINES: tuple[str, ...] = ("pymunk", "box2d", "box2d128")
#: Box2D with the original's 128-gon circles: it needs Box2D built with 128-vertex polygons
#: (``tools/box2d128/build.sh``).
BOX2D128_ENGINE: Final = "box2d128"
#: The engine every command and function that simulates uses unless told otherwise: Box2D (pybox2d) with the
#: original's rolling loss and contact flicker, the engine whose answers agree with the original CRAFT simulator's
#: more often than the original agrees with its own 2% perturbation (docs/original.md).
DEFAULT_ENGINE: Final = "box2d"
#: The default before Box2D: what a ``generation_config.json`` that names no engine was made with.
LEGACY_DEFAULT_ENGINE: Final = "pymunk"
#: What ``--help`` says of each engine: where it stands against the original simulator.
ENGINE_NOTES: dict[str, str] = {
    "box2d": "box2d, the default: its answers agree with the original CRAFT simulator's more often than the "
             "original's own 2%% perturbation does",
    "pymunk": "pymunk: less often than that floor, kept for the datasets made with it",
    "box2d128": "box2d128: Box2D with the original's 128-gon circles, nearly as often as the original agrees with "
                "itself (needs Box2D built by tools/box2d128/build.sh)",
    "original": "original: the original CRAFT simulator, built by tools/original/build.sh",
}


def engine_help(names: tuple[str, ...], extra: str = "") -> str:
    """The ``--engine`` help of a command offering ``names`` (argparse text: ``%%`` is a percent sign)."""
    notes = "; ".join(ENGINE_NOTES[n] for n in (DEFAULT_ENGINE, *(n for n in names if n != DEFAULT_ENGINE))
                      if n in ENGINE_NOTES)
    return f"physics engine ({notes}){extra}"

#: The original CRAFT simulator, driven as a separate built program (``tools/original/build.sh``): it records runs
#: (start and end states, events) rather than stepping a world, so it serves the commands that simulate scenes and
#: compare engines, not those that need per-frame trajectories (rendering, the reader, perceived scenes).
ORIGINAL_ENGINE = "original"
SIMULATORS: tuple[str, ...] = (*ENGINES, ORIGINAL_ENGINE)

# Event types -----------------------------------------------------------------------------------

START = "Start"
END = "End"
COLLISION = "Collision"
TOUCH_START = "TouchStart"
TOUCH_END = "TouchEnd"
ENTER_BASKET = "EnterBasket"

EVENT_TYPES: tuple[str, ...] = (START, END, COLLISION, TOUCH_START, TOUCH_END, ENTER_BASKET)

#: The original simulator's type strings, accepted when reading files.
EVENT_TYPE_ALIASES: dict[str, str] = {
    "StartTouching": TOUCH_START,
    "EndTouching": TOUCH_END,
    "ContainerEndUp": ENTER_BASKET,
}
#: Canonical type -> the original's string, used when writing files for the original tools.
ORIGINAL_EVENT_TYPE: dict[str, str] = {
    START: "Start",
    END: "End",
    COLLISION: "Collision",
    TOUCH_START: "StartTouching",
    TOUCH_END: "EndTouching",
    ENTER_BASKET: "ContainerEndUp",
}

#: A contact that ends within this many steps of its start is one Collision.
COLLISION_MAX_STEPS = 20
#: |vx| or |vy| above this (m/s) means "moving".
MOVING_THRESHOLD = 0.001


def canonical_event_type(name: str) -> str:
    """Map an event type string (canonical or original alias) to its canonical name."""
    if name in EVENT_TYPES:
        return name
    if name in EVENT_TYPE_ALIASES:
        return EVENT_TYPE_ALIASES[name]
    allowed = ", ".join(EVENT_TYPES + tuple(EVENT_TYPE_ALIASES))
    raise ValueError(f"unknown event type {name!r}; allowed: {allowed}")
