"""Ground truth as a perception model would write it: a :class:`PerceivedScene` from any simulation.

Every attribute has probability 1 and every event confidence 1. A live simulation (one with a trajectory) gives
exact tracks of its dynamic bodies in the pixel coordinates of the video craft_dsl renders, sampled at the chosen
frame rate like the renderer's frames, with velocities unless ``velocities=False``; static bodies get a pose. A
recorded simulation (start and end states only) gives no tracks; its objects then carry ``moving_start`` and
``moving_end`` (0 or 1) instead.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from ..render.raster import DEFAULT_SIZE, SIM_FPS
from ..simulation import Simulation
from ..vocabulary import END, START
from .coords import event_frame, frame_rows, to_pixels
from .schema import SCHEMA_VERSION, PerceivedEvent, PerceivedObject, PerceivedScene, Pose, Track, VideoInfo


def _scene_id(sim: Simulation) -> int | None:
    candidates: list[Any] = [getattr(sim.world, "scene_id", None), sim.meta.get("scene")]
    for c in candidates:
        if isinstance(c, int) and not isinstance(c, bool) and 1 <= c <= 20:
            return c
    return None


def _floats(values: np.ndarray) -> list[float | None]:
    return [float(v) for v in values]


def export_perceived(sim: Simulation, fps: float = SIM_FPS, size: int = DEFAULT_SIZE,
                     velocities: bool = True) -> PerceivedScene:
    """The ground-truth perceived scene of ``sim`` at ``fps`` frames per second in a ``size``-pixel video."""
    rows = frame_rows(sim.steps, fps)
    traj = sim.trajectory
    objects = []
    scale = size / 50.0
    for o in sim.objects:
        fields: dict[str, Any] = dict(id=o.id, color={o.color: 1.0}, shape={o.shape: 1.0}, size={o.size: 1.0},
                                      dynamic=1.0 if o.dynamic else 0.0)
        if traj is not None and o.id in traj.ids:
            col = traj.column(o.id)
            if o.dynamic:
                px, py = to_pixels(traj.positions[rows, col, 0], traj.positions[rows, col, 1], size)
                track: dict[str, Any] = dict(x=_floats(px), y=_floats(py), angle=_floats(traj.angles[rows, col]))
                if velocities:
                    track.update(vx=_floats(traj.velocities[rows, col, 0] * scale),
                                 vy=_floats(-traj.velocities[rows, col, 1] * scale),
                                 angular_velocity=_floats(traj.angular_velocities[rows, col]))
                fields["track"] = Track(**track)
            else:
                px, py = to_pixels(traj.positions[0, col, 0], traj.positions[0, col, 1], size)
                fields["pose"] = Pose(x=float(px), y=float(py), angle=float(traj.angles[0, col]))
        else:
            fields["moving_start"] = 1.0 if o.is_moving(0) else 0.0
            fields["moving_end"] = 1.0 if o.is_moving(-1) else 0.0
        objects.append(PerceivedObject(**fields))
    events = [PerceivedEvent(type=e.type, objects=list(e.objects), frame=event_frame(e.step, rows))
              for e in sim.events if e.type not in (START, END)]
    meta = {"source": "ground truth", **{k: v for k, v in sim.meta.items() if isinstance(v, str | int | float)}}
    return PerceivedScene(schema_version=SCHEMA_VERSION, scene=_scene_id(sim),
                          video=VideoInfo(fps=fps, frames=int(rows.size), steps=sim.steps, width=size, height=size),
                          objects=objects, events=events, physics=_physics(sim), meta=meta)


def _physics(sim: Simulation) -> Literal["pymunk", "box2d"] | None:
    """The engine of a live run (its counterfactuals re-simulate with it); None for a recorded simulation."""
    name = getattr(getattr(sim, "engine", None), "name", None)
    if name == "pymunk":
        return "pymunk"
    if name == "box2d":
        return "box2d"
    return None
