"""A scene layout as a function of its random draws: the values a perception model estimates.

A layout (``scenes/scene_NN.json``) names uniform and choice draws; everything else (constants, expressions of the
variables) follows from them. :class:`LayoutModel` lists the draws in the sampler's order with their paths
(``"variables.h"``, ``"static[2].angle"``, ``"dynamic[0].velocity[1]"``: the keys of
:func:`craft_dsl.scenes.sample_values`) and builds the :class:`~craft_dsl.world.WorldSpec` of given draw values and
dynamic attributes, in the sampler's creation order, so uniqueIDs are the simulator's own.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache

from ..scenes import Choice, Const, Expr, Quantity, SceneLayout, Uniform, load_scene
from ..world import BodySpec, WorldSpec, assign_uids, make_dynamic, make_static

_DYNAMIC_PATH = re.compile(r"^dynamic\[(\d+)\](.*)$")
_POSITION_PATH = re.compile(r"^(basket|static\[\d+\]|dynamic\[\d+\])\.position\[([01])\]$")

#: Offset (metres) = (0, 0): the world as the layout file places it.
NO_OFFSET: tuple[float, float] = (0.0, 0.0)

#: (shape, colour, size) of one dynamic object.
Attributes = tuple[str, str, str]


@dataclass(frozen=True)
class Draw:
    """One random draw of a layout: its path, and its range (uniform) or options (choice)."""

    path: str
    quantity: Quantity

    @property
    def is_choice(self) -> bool:
        return isinstance(self.quantity, Choice)


def _scalar(q: Const | Expr, variables: Mapping[str, float]) -> float:
    return q.value if isinstance(q, Const) else q.evaluate(variables)


class LayoutModel:
    """The layout of scene ``scene_id`` as a function of its draws."""

    def __init__(self, scene_id: int, absent: tuple[int, ...] = (), offset: tuple[float, float] = NO_OFFSET) -> None:
        self.scene_id = scene_id
        #: Where a picture drawn by another renderer puts the world, against craft_dsl's drawing (metres, x and y):
        #: the draws fitted to its pixels carry the offset, so every place no draw moves (walls, ground, constant
        #: coordinates) is moved by it too, and the world keeps its shape (:meth:`evaluate`).
        self.offset = (float(offset[0]), float(offset[1]))
        layout = load_scene(scene_id)
        bad = [i for i in absent if not 0 <= i < len(layout.dynamic) or layout.dynamic[i].on_duplicate != "drop"]
        if bad:
            raise ValueError(f"scene {scene_id}: slots {bad} cannot be absent (only a slot that drops its object on "
                             "a duplicate triple can)")
        #: Dynamic slots of the layout file left out: slots that drop their object (``on_duplicate: "drop"``) and
        #: whose object the video does not show. The remaining slots are renumbered in file order.
        self.absent = absent
        if absent:
            layout = layout.model_copy(update={"dynamic": tuple(d for i, d in enumerate(layout.dynamic)
                                                                if i not in absent)})
        self.layout: SceneLayout = layout
        self._statics_cache: dict[tuple[tuple[str, float], ...], tuple[BodySpec, ...]] = {}

    @cached_property
    def draws(self) -> tuple[Draw, ...]:
        return tuple(Draw(path, q) for path, q in self.layout.fields() if isinstance(q, Uniform | Choice))

    def draws_of(self, prefix: str) -> tuple[Draw, ...]:
        return tuple(d for d in self.draws if d.path.startswith(prefix))

    @cached_property
    def static_paths(self) -> tuple[str, ...]:
        """Draws that move a static element (the basket included): the variables they read and their own."""
        used: set[str] = set()
        for path, q in self.layout.fields():
            if path.startswith(("basket", "static")):
                used.add(path)
                used |= {f"variables.{n}" for n in _names(q)}
        # variables read by used variables
        changed = True
        while changed:
            changed = False
            for name, q in self.layout.variables.items():
                if f"variables.{name}" in used:
                    for n in _names(q):
                        if f"variables.{n}" not in used:
                            used.add(f"variables.{n}")
                            changed = True
        return tuple(d.path for d in self.draws if d.path in used)

    def evaluate(self, values: Mapping[str, float]) -> dict[str, float]:
        """Every field's number given the draws in ``values`` (missing draws: the middle of their range, the first
        option); a position no draw moves is moved by :attr:`offset`."""
        out = self._evaluate(values)
        if self.offset != NO_OFFSET:
            for path, axis in self.fixed_positions:
                out[path] += self.offset[axis]
        return out

    def _evaluate(self, values: Mapping[str, float]) -> dict[str, float]:
        variables: dict[str, float] = {}
        out: dict[str, float] = {}
        for path, q in self.layout.fields():
            if isinstance(q, Uniform):
                if path in values:
                    v = float(values[path])
                else:
                    v = 0.5 * (_scalar(q.low, variables) + _scalar(q.high, variables))
            elif isinstance(q, Choice):
                v = float(values.get(path, q.options[0]))
            else:
                v = _scalar(q, variables)
            out[path] = v
            if path.startswith("variables."):
                variables[path.split(".", 1)[1]] = v
        return out

    @cached_property
    def fixed_positions(self) -> tuple[tuple[str, int], ...]:
        """The position fields (path, axis) that no draw moves: each draw set to the ends of its range (another
        option of a choice), one at a time, leaves them where they are."""
        middle = self._evaluate({})
        moved: set[str] = set()
        for d in self.draws:
            q = d.quantity
            if isinstance(q, Uniform):
                lo, hi = self.bounds({}).get(d.path, (0.0, 0.0))
                trials = [lo, hi]
            else:
                assert isinstance(q, Choice)
                trials = list(q.options)
            for value in trials:
                changed = self._evaluate({d.path: value})
                moved |= {p for p, v in changed.items() if v != middle[p]}
        out = []
        for path, _q in self.layout.fields():
            m = _POSITION_PATH.match(path)
            if m is not None and path not in moved:
                out.append((path, int(m.group(2))))
        return tuple(out)

    def from_unit(self, units: Mapping[str, float]) -> dict[str, float]:
        """Draw values from positions in their ranges (0: low end, 1: high end; clipped), evaluated in draw order
        since a range may read earlier draws; draws not given take the middle of their range."""
        variables: dict[str, float] = {}
        out: dict[str, float] = {}
        for path, q in self.layout.fields():
            if isinstance(q, Uniform):
                lo, hi = _scalar(q.low, variables), _scalar(q.high, variables)
                v = lo + min(max(float(units.get(path, 0.5)), 0.0), 1.0) * (hi - lo)
                out[path] = v
            elif isinstance(q, Choice):
                v = q.options[0]
            else:
                v = _scalar(q, variables)
            if path.startswith("variables."):
                variables[path.split(".", 1)[1]] = v
        return out

    def bounds(self, values: Mapping[str, float]) -> dict[str, tuple[float, float]]:
        """The range of each uniform draw given the others (bounds may read variables)."""
        fields = self._evaluate(values)
        variables = {p.split(".", 1)[1]: v for p, v in fields.items() if p.startswith("variables.")}
        out = {}
        for d in self.draws:
            q = d.quantity
            if isinstance(q, Uniform):
                out[d.path] = (_scalar(q.low, variables), _scalar(q.high, variables))
            else:
                assert isinstance(q, Choice)
                out[d.path] = (min(q.options), max(q.options))
        return out

    def statics(self, values: Mapping[str, float]) -> list[BodySpec]:
        """Walls, ground, basket and the static elements, in creation order (uids not yet assigned)."""
        key = tuple(sorted(values.items()))
        if key in self._statics_cache:
            return list(self._statics_cache[key])
        bodies = self._make_statics(values)
        if len(self._statics_cache) > 256:
            self._statics_cache.clear()
        self._statics_cache[key] = tuple(bodies)
        return bodies

    def _make_statics(self, values: Mapping[str, float]) -> list[BodySpec]:
        f = self.evaluate(values)
        bodies = [make_static(0, "wall_l", self.offset), make_static(0, "wall_r", self.offset),
                  make_static(0, "ground", self.offset),
                  make_static(0, "basket", (f["basket.position[0]"], f["basket.position[1]"]), 0.0)]
        for i, s in enumerate(self.layout.static):
            bodies.append(make_static(0, s.shape, (f[f"static[{i}].position[0]"], f[f"static[{i}].position[1]"]),
                                      f[f"static[{i}].angle"]))
        return bodies

    def world(self, values: Mapping[str, float], attributes: Sequence[Attributes]) -> WorldSpec:
        """The concrete scene: statics at the draws' places, slot i holding ``attributes[i]`` at its drawn start."""
        if len(attributes) != len(self.layout.dynamic):
            raise ValueError(f"scene {self.scene_id} has {len(self.layout.dynamic)} dynamic slots, "
                             f"got {len(attributes)} objects")
        f = self.evaluate(values)
        bodies = self.statics(values)
        for i, (shape, color, size) in enumerate(attributes):
            bodies.append(make_dynamic(0, shape, color, size,
                                       (f[f"dynamic[{i}].position[0]"], f[f"dynamic[{i}].position[1]"]),
                                       (f[f"dynamic[{i}].velocity[0]"], f[f"dynamic[{i}].velocity[1]"])))
        return WorldSpec(bodies=assign_uids(bodies), scene_id=self.scene_id)

    def renumbered(self, values: Mapping[str, float]) -> dict[str, float]:
        """Draw values keyed by the full layout's paths, keyed by this model's (the absent slots' left out, the
        other dynamic slots renumbered)."""
        if not self.absent:
            return dict(values)
        new_index: dict[int, int] = {}
        for old in range(len(self.layout.dynamic) + len(self.absent)):
            if old not in self.absent:
                new_index[old] = len(new_index)
        out: dict[str, float] = {}
        for path, v in values.items():
            m = _DYNAMIC_PATH.match(path)
            if m is None:
                out[path] = v
            elif int(m.group(1)) in new_index:
                out[f"dynamic[{new_index[int(m.group(1))]}]{m.group(2)}"] = v
        return out

    def fixed_start(self, slot: int, values: Mapping[str, float]) -> tuple[float, float] | None:
        """Where dynamic slot ``slot`` starts, where the draws in ``values`` decide it (a constant, or an expression
        of those draws' variables); None where it depends on a draw of its own or one not in ``values``."""
        known = {path.removeprefix("variables."): v for path, v in values.items() if path.startswith("variables.")}
        out = []
        for axis, q in enumerate(self.layout.dynamic[slot].position):
            if isinstance(q, Const) or (isinstance(q, Expr) and not q.names):
                out.append(_scalar(q, known) + self.offset[axis])  # a place no draw moves
            elif isinstance(q, Expr) and set(q.names) <= set(known):
                out.append(q.evaluate(known))
            else:
                return None
        return out[0], out[1]

    def slot_allows(self, slot: int, attributes: Attributes) -> bool:
        """Whether dynamic slot ``slot`` can hold an object with these (shape, colour, size)."""
        s = self.layout.dynamic[slot]
        shape, color, size = attributes
        return all(fixed in ("random", value) for fixed, value in ((s.shape, shape), (s.color, color),
                                                                   (s.size, size)))


def _names(q: Quantity) -> tuple[str, ...]:
    if isinstance(q, Expr):
        return q.names
    if isinstance(q, Uniform):
        return _names(q.low) + _names(q.high)
    return ()


@lru_cache(maxsize=64)
def layout_model(scene_id: int, absent: tuple[int, ...] = (), offset: tuple[float, float] = NO_OFFSET
                 ) -> LayoutModel:
    """The :class:`LayoutModel` of a built-in scene, less the ``absent`` dynamic slots, its fixed places moved by
    ``offset`` (cached)."""
    return LayoutModel(scene_id, absent, offset)
