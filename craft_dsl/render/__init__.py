"""Rendering of live simulations: CRAFT-looking frames, MP4/GIF videos and PNG stills.

``frames(sim)`` draws every frame as uint8 [T, 256, 256, 3]; ``frame(sim, step)`` one state;
``write_video(sim, "out.mp4")`` / ``write_png(sim, "f.png", step)`` write files atomically.
See ``docs/rendering.md``.
"""

from __future__ import annotations

from .raster import (
    RenderError,
    frame,
    frame_count,
    frame_steps,
    frames,
    iter_frames,
    render_states,
    static_layer,
    world_to_pixel,
)
from .video import encode_png, write_frames, write_png, write_video

__all__ = [
    "RenderError",
    "encode_png",
    "frame",
    "frame_count",
    "frame_steps",
    "frames",
    "iter_frames",
    "render_states",
    "static_layer",
    "world_to_pixel",
    "write_frames",
    "write_png",
    "write_video",
]
