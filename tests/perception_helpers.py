"""Hand-made perceived scenes for the perception tests (no physics needed to build them)."""

from __future__ import annotations

from typing import Any

from craft_dsl.perception.schema import PerceivedEvent, PerceivedObject, PerceivedScene, Pose, Track, VideoInfo

FRAMES = 30


def still_track(x: float, y: float, frames: int = FRAMES) -> Track:
    return Track(x=[x] * frames, y=[y] * frames, angle=[3.14159] * frames)


def tiny_scene(**changes: Any) -> PerceivedScene:
    """Ground (6), basket (5), a red cube (1) and a blue circle (0), a 30-frame video at 60 fps.

    Events: the cube collides with the ground at frame 3 and the circle enters the basket at frame 10."""
    objects = [
        PerceivedObject(id=6, shape={"ground": 1.0}, pose=Pose(x=128.0, y=230.4)),
        PerceivedObject(id=5, shape={"basket": 1.0}, pose=Pose(x=128.0, y=236.5)),
        PerceivedObject(id=1, color={"red": 1.0}, shape={"cube": 1.0}, size={"small": 1.0},
                        track=still_track(60.0, 200.0), moving_start=0.0, moving_end=0.0),
        PerceivedObject(id=0, color={"blue": 1.0}, shape={"circle": 1.0}, size={"large": 1.0},
                        track=still_track(128.0, 220.0), moving_start=1.0, moving_end=0.0),
    ]
    events = [PerceivedEvent(type="Collision", objects=[6, 1], frame=3),
              PerceivedEvent(type="EnterBasket", objects=[5, 0], frame=10)]
    fields: dict[str, Any] = dict(scene=None, video=VideoInfo(fps=60, frames=FRAMES), objects=objects, events=events)
    fields.update(changes)
    return PerceivedScene(**fields)


def tiny_data(**changes: Any) -> dict[str, Any]:
    """:func:`tiny_scene` as parsed JSON (a mutable dict)."""
    return tiny_scene(**changes).to_json()
