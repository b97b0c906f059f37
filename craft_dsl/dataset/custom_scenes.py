"""Custom scene layouts in a generation: each carried as its canonical JSON, so that a run never reads the user's
file again.

``craft-dsl generate --scenes 1-4,my_layouts/ramp.json`` mixes built-in scene ids with layout files (format in
docs/scenes.md). A file is read and validated once, in the main process, and becomes a :class:`CustomScene`:

* ``scene``: the layout's own ``scene`` field, the id its records and folders (``sid_<scene>``) carry;
* ``layout``: its *canonical JSON*, the validated layout written back with fixed separators and keys in the
  format's order (the order of ``variables`` is kept: it is the order of the random draws);
* ``sha256``: the hash of that text.

All three go into ``generation_config.json``, so resuming after the file changed is refused like any other
changed setting, while a file only re-indented or moved is the same scene. Workers (local processes, a Dask
cluster) get the canonical text inside each task and rebuild the layout from it.

A custom layout may not reuse the id of a built-in scene with other content: ``sid_3`` always means the CRAFT
scene 3 (a file identical to a built-in layout simply is that scene), and two entries of one run never share an
id, so two different layouts never share a folder.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..scenes import SceneLayout, layout_from_data, list_scenes, load_layout_file, load_scene

#: Characters of the hash shown in messages and the dataset card.
SHORT_HASH = 12


def canonical_json(layout: SceneLayout) -> str:
    """The layout as canonical JSON text: what is recorded and hashed (see the module docstring)."""
    return json.dumps(layout.model_dump(mode="json"), separators=(",", ":"), ensure_ascii=False, allow_nan=False)


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class CustomScene(BaseModel):
    """A scene layout given as a file (or a :class:`~craft_dsl.scenes.SceneLayout`), as a generation records it.

    Make one with :meth:`of`; a hand-written ``layout`` must be the canonical JSON of a valid layout whose ``scene``
    and hash match the other two fields.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    scene: int = Field(ge=1, description="the layout's own scene id (records, folders sid_<scene>)")
    sha256: str = Field(description="SHA-256 of the canonical JSON")
    layout: str = Field(description="the layout's canonical JSON")
    source: str = Field("", exclude=True, description="where it was read from (messages only; not recorded)")

    @model_validator(mode="after")
    def _consistent(self) -> CustomScene:
        try:
            data = json.loads(self.layout)
        except ValueError as err:
            raise ValueError(f"layout is not JSON text: {err}") from None
        layout = layout_from_data(data, self.source or "custom scene layout")
        if canonical_json(layout) != self.layout:
            raise ValueError("layout is not in canonical form; build it with CustomScene.of(layout)")
        if layout.scene != self.scene:
            raise ValueError(f"scene {self.scene} differs from the layout's own scene id {layout.scene}")
        if _sha256(self.layout) != self.sha256:
            raise ValueError("sha256 is not the hash of layout")
        return self

    @classmethod
    def of(cls, layout: SceneLayout, source: str = "") -> CustomScene:
        """The record of a validated layout (``source``: its file, for messages)."""
        text = canonical_json(layout)
        return cls(scene=layout.scene, sha256=_sha256(text), layout=text, source=source)

    def load(self) -> SceneLayout:
        """The layout, rebuilt from the canonical JSON (no file is read)."""
        return layout_from_data(json.loads(self.layout), self.source or f"custom scene {self.scene}")

    def describe(self) -> str:
        """``21 (layout ramp.json, sha256 0123456789ab)`` for messages."""
        where = f"layout {self.source}, " if self.source else "layout "
        return f"{self.scene} ({where}sha256 {self.sha256[:SHORT_HASH]})"


def scene_entry(item: object) -> object:
    """One ``scenes`` entry as the configuration holds it: a layout file (str or Path) or a SceneLayout becomes a
    :class:`CustomScene` (a built-in id when identical to that built-in layout); anything else is left to the
    field's validation (which refuses a custom layout with a built-in id, see :func:`builtin_id_clash`)."""
    if isinstance(item, (str, Path)) and not (isinstance(item, str) and item.strip().isdigit()):
        layout = load_layout_file(item)
        source = str(item)
    elif isinstance(item, SceneLayout):
        layout = item
        source = str(item.path) if item.path is not None else ""
    else:
        return item
    custom = CustomScene.of(layout, source)
    if layout.scene in list_scenes() and canonical_json(load_scene(layout.scene)) == custom.layout:
        return layout.scene
    return custom


def builtin_id_clash(custom: CustomScene) -> str | None:
    """Why ``custom`` may not be used (its id is a built-in scene's), or ``None``."""
    builtin = list_scenes()
    if custom.scene not in builtin:
        return None
    return (f"{custom.source or 'a custom scene layout'}: its \"scene\" id {custom.scene} is the built-in scene "
            f"{custom.scene}'s, and the layout differs from it; give a custom layout an id of its own (not "
            f"{', '.join(_ranges(builtin))}) so that its records and folders (sid_<id>) are not taken for the "
            "built-in scene's")


def _ranges(ids: Iterable[int]) -> list[str]:
    """``[1, 2, 3, 5]`` -> ``["1-3", "5"]``."""
    out: list[list[int]] = []
    for i in sorted(ids):
        if out and out[-1][1] == i - 1:
            out[-1][1] = i
        else:
            out.append([i, i])
    return [f"{a}-{b}" if a != b else str(a) for a, b in out]


def recorded_scenes_text(value: Any) -> str:
    """The recorded ``scenes`` setting for messages and the dataset card: ids, a custom layout as
    ``21 (layout sha256 0123456789ab)``."""
    if not isinstance(value, list):
        return repr(value)
    parts = []
    for entry in value:
        if isinstance(entry, Mapping) and "scene" in entry:
            parts.append(f"{entry['scene']} (layout sha256 {str(entry.get('sha256', '?'))[:SHORT_HASH]})")
        else:
            parts.append(str(entry))
    return "[" + ", ".join(parts) + "]"


def recorded_layout(config: Mapping[str, Any] | None, scene: int) -> SceneLayout | None:
    """The custom layout of ``scene`` that a ``generation_config.json`` records (``None`` for a built-in scene or
    an older folder); e.g. to re-simulate a video of a generated dataset."""
    for entry in (config or {}).get("scenes") or ():
        if isinstance(entry, Mapping) and entry.get("scene") == scene:
            return CustomScene.model_validate(dict(entry)).load()
    return None


__all__ = ["CustomScene", "SHORT_HASH", "builtin_id_clash", "canonical_json", "recorded_layout", "recorded_scenes_text",
           "scene_entry"]
