"""A hand-made live simulation (scripted motion, no physics engine) for tests, benchmarks and demos."""

from __future__ import annotations

import numpy as np

from craft_dsl.simulation import Event, ObjectState, SimObject, Simulation, Trajectory
from craft_dsl.world import WorldSpec, assign_uids, make_dynamic, make_static


def synthetic_world() -> WorldSpec:
    """Walls, ground, a basket, a tilted platform, a ramp, a static ball and three dynamic bodies."""
    bodies = [
        make_static(0, "wall_l"),
        make_static(0, "wall_r"),
        make_static(0, "ground"),
        make_static(0, "basket", (12.0, -1.2)),
        make_static(0, "platform", (-10.0, 20.0), angle=-0.3),
        make_static(0, "ramp", (15.0, 15.0), angle=0.0),
        make_static(0, "static_ball", (0.0, 10.0)),
        make_dynamic(0, "cube", "red", "large", (-12.0, 30.0)),
        make_dynamic(0, "triangle", "blue", "large", (5.0, 35.0)),
        make_dynamic(0, "circle", "yellow", "small", (10.0, 20.0)),
        make_dynamic(0, "cube", "green", "small", (-18.0, 8.0)),
    ]
    return WorldSpec(bodies=assign_uids(bodies), scene_id=None, seed=0)


def synthetic_simulation(steps: int = 600, world: WorldSpec | None = None) -> Simulation:
    """A Simulation with ``world`` and a scripted ``trajectory`` (bodies drift and spin)."""
    world = world or synthetic_world()
    ids = tuple(b.uid for b in world.bodies)
    n = len(ids)
    t = np.arange(steps + 1, dtype=np.float64) / 60.0
    pos = np.zeros((steps + 1, n, 2))
    ang = np.zeros((steps + 1, n))
    for k, b in enumerate(world.bodies):
        pos[:, k] = b.position
        ang[:, k] = b.angle
        if b.dynamic:
            phase = 0.7 * k
            pos[:, k, 0] += 6.0 * np.sin(0.5 * t + phase)
            pos[:, k, 1] -= 2.0 * t
            ang[:, k] += (0.6 + 0.1 * k) * t
    vel = np.asarray(np.gradient(pos, axis=0)) * 60.0 if steps > 0 else np.zeros_like(pos)
    angvel = np.asarray(np.gradient(ang, axis=0)) * 60.0 if steps > 0 else np.zeros_like(ang)
    traj = Trajectory(ids=ids, positions=pos, angles=ang, velocities=vel, angular_velocities=angvel)
    objects = []
    for k, b in enumerate(world.bodies):
        start = ObjectState(tuple(pos[0, k]), float(ang[0, k]), tuple(vel[0, k]), float(angvel[0, k]))
        end = ObjectState(tuple(pos[-1, k]), float(ang[-1, k]), tuple(vel[-1, k]), float(angvel[-1, k]))
        objects.append(SimObject(b.uid, b.shape, b.color, b.size, b.dynamic, start, end))
    events = [Event(0, "Start", -1), Event(1, "End", steps)]
    return Simulation(objects, events, steps=steps, trajectory=traj, world=world,
                      meta={"source": "synthetic"})


def simulation_from_rows(world: WorldSpec, positions: np.ndarray, angles: np.ndarray) -> Simulation:
    """A Simulation that shows ``world`` along the given rows (positions [T+1, N, 2], angles [T+1, N], world order),
    with zero velocities and only Start and End events: for rendering tests."""
    steps = positions.shape[0] - 1
    n = len(world.bodies)
    traj = Trajectory(tuple(b.uid for b in world.bodies), positions, angles, np.zeros((steps + 1, n, 2)),
                      np.zeros((steps + 1, n)))
    objects = [SimObject(b.uid, b.shape, b.color, b.size, b.dynamic, ObjectState(b.position, b.angle),
                         ObjectState(b.position, b.angle)) for b in world.bodies]
    return Simulation(objects, [Event(0, "Start", -1), Event(1, "End", steps)], steps=steps, trajectory=traj,
                      world=world)
