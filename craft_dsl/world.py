"""A concrete scene: the bodies a simulator starts from, with their geometry resolved.

Scene layouts (``scenes/*.json``) are sampled into a :class:`WorldSpec` with an explicit seed; physics
engines read a WorldSpec and nothing else, and the renderer draws its bodies. No engine is named here.

Geometry is given in the body's local frame (metres); a body at ``position`` rotated by ``angle`` places
it in the world. Catalogue facts (sizes, shapes, density, friction, restitution) follow the original CRAFT simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from .vocabulary import STATIC_COLOR, STATIC_SIZE

Point = tuple[float, float]
Polygon = tuple[Point, ...]
Segment = tuple[Point, Point]

GRAVITY: Point = (0.0, -15.0)
STEPS_PER_SECOND = 60
DEFAULT_STEPS = 600
DENSITY = 50.0
FRICTION = 0.1
RESTITUTION = 0.2
#: Box2D drops restitution for approach speeds below this (m/s).
RESTITUTION_THRESHOLD = 1.0
#: Dynamic bodies start at this angle (the original's RandomFloat(pi, pi)).
INITIAL_ANGLE = math.pi
#: "small" and "large" size parameter L (metres).
SIZE_LENGTH = {"small": 1.0, "large": 2.0}


@dataclass(frozen=True)
class Geometry:
    """Local-frame collision geometry of one body.

    polygons: convex polygons (counter-clockwise); circle_radius: a circle centred on the origin;
    segments: zero-thickness edges (the basket's open chain), drawn/collided with ``segment_radius``;
    sensor: a polygon that detects entries without colliding (the basket's inner region).
    """

    polygons: tuple[Polygon, ...] = ()
    circle_radius: float | None = None
    segments: tuple[Segment, ...] = ()
    segment_radius: float = 0.01
    sensor: Polygon | None = None


@dataclass(frozen=True)
class BodySpec:
    """One body of a concrete scene, in creation order. ``uid`` is the original's uniqueID."""

    uid: int
    shape: str
    color: str
    size: str
    dynamic: bool
    position: Point
    angle: float
    velocity: Point = (0.0, 0.0)
    angular_velocity: float = 0.0
    geometry: Geometry = field(default_factory=Geometry)


@dataclass(frozen=True)
class WorldSpec:
    """A concrete scene: bodies in creation order plus the world constants."""

    bodies: tuple[BodySpec, ...]
    scene_id: int | None = None
    seed: int | None = None
    gravity: Point = GRAVITY
    steps_per_second: int = STEPS_PER_SECOND

    def body(self, uid: int) -> BodySpec:
        for b in self.bodies:
            if b.uid == uid:
                return b
        raise KeyError(f"no body with uid {uid} (uids: {[b.uid for b in self.bodies]})")

    def without(self, uid: int) -> WorldSpec:
        """The same scene with one body removed (the others keep their uids and order)."""
        self.body(uid)
        return replace(self, bodies=tuple(b for b in self.bodies if b.uid != uid))

    @property
    def dynamic_uids(self) -> tuple[int, ...]:
        return tuple(b.uid for b in self.bodies if b.dynamic)


# -- the object catalogue -------------------------------------------------------------------------


def regular_polygon(radius: float, sides: int) -> Polygon:
    """Regular polygon of circumradius ``radius``, first vertex at (0, -radius), counter-clockwise."""
    pts = []
    for k in range(sides):
        a = -math.pi / 2 + 2 * math.pi * k / sides
        pts.append((radius * math.cos(a), radius * math.sin(a)))
    return tuple(pts)


def box(half_w: float, half_h: float, cx: float = 0.0, cy: float = 0.0) -> Polygon:
    return ((cx - half_w, cy - half_h), (cx + half_w, cy - half_h), (cx + half_w, cy + half_h),
            (cx - half_w, cy + half_h))


BASKET_CHAIN: tuple[Point, ...] = ((-3.5, 3.5), (-2.5, -3.5), (2.5, -3.5), (3.5, 3.5))
BASKET_SENSOR: Polygon = ((-2.465, -3.465), (2.465, -3.465), (3.3, 2.5), (-3.3, 2.5))


def dynamic_geometry(shape: str, size: str) -> Geometry:
    """Geometry of a dynamic object: cube (half-extent L), triangle (circumradius L+1, truncated as in
    the original), circle (radius L)."""
    length = SIZE_LENGTH[size]
    if shape == "cube":
        return Geometry(polygons=(box(length, length),))
    if shape == "triangle":
        return Geometry(polygons=(regular_polygon(length + 1.0, 3),))
    if shape == "circle":
        return Geometry(circle_radius=length)
    raise ValueError(f"unknown dynamic shape {shape!r}; allowed: cube, triangle, circle")


def static_geometry(shape: str) -> Geometry:
    """Geometry of a static element (walls and ground are offset inside a body at the origin)."""
    if shape == "wall_l":
        return Geometry(polygons=(box(0.2, 25.0, -25.0, 20.0),))
    if shape == "wall_r":
        return Geometry(polygons=(box(0.2, 25.0, 25.0, 20.0),))
    if shape == "ground":
        return Geometry(polygons=(box(25.0, 0.2, 0.0, -5.0),))
    if shape == "platform":
        return Geometry(polygons=(box(8.0, 0.5),))
    if shape == "ramp":
        return Geometry(polygons=(((0.0, 0.0), (3.0, 0.0), (0.0, 3.0)),))
    if shape == "static_ball":
        return Geometry(circle_radius=3.0)
    if shape == "basket":
        chain = BASKET_CHAIN
        return Geometry(segments=tuple((chain[i], chain[i + 1]) for i in range(3)), sensor=BASKET_SENSOR)
    raise ValueError(
        f"unknown static shape {shape!r}; allowed: wall_l, wall_r, ground, platform, ramp, static_ball, basket"
    )


def make_static(uid: int, shape: str, position: Point = (0.0, 0.0), angle: float = 0.0) -> BodySpec:
    return BodySpec(uid=uid, shape=shape, color=STATIC_COLOR, size=STATIC_SIZE, dynamic=False,
                    position=position, angle=angle, geometry=static_geometry(shape))


def make_dynamic(uid: int, shape: str, color: str, size: str, position: Point,
                 velocity: Point = (0.0, 0.0), angle: float = INITIAL_ANGLE) -> BodySpec:
    return BodySpec(uid=uid, shape=shape, color=color, size=size, dynamic=True, position=position,
                    angle=angle, velocity=velocity, geometry=dynamic_geometry(shape, size))


def bounding_radius(geo: Geometry) -> float:
    """The radius (metres) of the smallest circle about a body's origin that holds its polygons and circle."""
    r = geo.circle_radius or 0.0
    for poly in geo.polygons:
        r = max(r, max(math.hypot(x, y) for x, y in poly))
    return r


def assign_uids(bodies: list[BodySpec]) -> tuple[BodySpec, ...]:
    """Give bodies in creation order the original's uniqueIDs: N-1 for the first, 0 for the last."""
    n = len(bodies)
    return tuple(replace(b, uid=n - 1 - i) for i, b in enumerate(bodies))
