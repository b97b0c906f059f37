"""A seeded noise model that degrades a perceived scene the way a perception model errs.

Each kind of error draws from its own stream, ``SeedSequence(seed).spawn(6)`` in the order attributes, positions,
swaps, gaps, events, timing, so turning one knob never changes the draws of another, and the same seed and model
give the same bytes.

* ``attribute_confusion`` r: each colour, shape and size of a dynamic object is replaced, with probability r, by
  a uniformly drawn other value; the reported distribution is the calibrated one (1 - r on the reported value,
  r spread evenly over the others), so r = 0 keeps every attribute certain;
* ``position_sigma_px``: Gaussian noise (pixels of the video) on every track position, independently per frame;
  a static object's pose, seen in every frame, gets sigma / sqrt(frames); ``angle_sigma_rad`` likewise on angles;
* ``identity_swap_rate``: a Poisson number of swaps per video; each exchanges the tracks of two dynamic objects
  from a uniformly drawn frame on, and the ids in the events seen from that frame on;
* ``gap_rate``: a Poisson number of gaps per track, each starting at a uniform frame and lasting a geometric
  number of frames (mean ``gap_frames``), during which the object is not seen;
* ``event_miss_rate``: each event is dropped with this probability; ``event_false_alarm_rate`` f: a Poisson
  number (mean f times the number of true events) of spurious events (uniform type among Collision, TouchStart,
  TouchEnd, EnterBasket; a random dynamic object with a random partner, the basket for EnterBasket; uniform
  frame). Every reported event gets the calibrated confidence (1 - m) / (1 - m + f);
* ``timing_jitter_frames`` J: every reported event's frame moves by a uniform integer in [-J, J];
* velocities are dropped unless ``keep_velocities`` (a tracker reports positions); ``track_fps`` subsamples the
  tracks (the frames nearest the lower rate's times).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ..vocabulary import COLLISION, COLORS, ENTER_BASKET, SHAPES, SIZES, TOUCH_END, TOUCH_START
from .coords import frame_rows
from .reading import DECISION_THRESHOLD, dynamic_probability
from .schema import PerceivedEvent, PerceivedObject, PerceivedScene, Pose, Track
from .validation import most_likely

_VALUES = {"color": COLORS, "shape": SHAPES, "size": SIZES}
_FALSE_ALARM_TYPES = (COLLISION, TOUCH_START, TOUCH_END, ENTER_BASKET)
_TRACK_FIELDS = ("x", "y", "angle", "vx", "vy", "angular_velocity", "visible")


class NoiseModel(BaseModel):
    """How much to degrade a perceived scene (see the module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    position_sigma_px: float = Field(default=0.0, ge=0)
    angle_sigma_rad: float = Field(default=0.0, ge=0)
    attribute_confusion: float = Field(default=0.0, ge=0, le=1)
    event_miss_rate: float = Field(default=0.0, ge=0, le=1)
    event_false_alarm_rate: float = Field(default=0.0, ge=0)
    timing_jitter_frames: int = Field(default=0, ge=0)
    identity_swap_rate: float = Field(default=0.0, ge=0)
    gap_rate: float = Field(default=0.0, ge=0)
    gap_frames: float = Field(default=10.0, ge=1)
    keep_velocities: bool = False
    track_fps: float | None = Field(default=None, gt=0, le=60)


def _confuse(obj: PerceivedObject, rate: float, rng: np.random.Generator) -> dict[str, Any]:
    update: dict[str, Any] = {}
    for name, values in _VALUES.items():
        true = most_likely(getattr(obj, name))
        if true not in values:
            continue
        u = float(rng.random())
        other = int(rng.integers(len(values) - 1))
        reported = true
        if u < rate:
            others = [v for v in values if v != true]
            reported = others[other]
        if rate <= 0:
            update[name] = {reported: 1.0}
        else:
            update[name] = {v: (1.0 - rate if v == reported else rate / (len(values) - 1)) for v in values}
    return update


def _noisy(values: list[float | None] | None, sigma: float, rng: np.random.Generator) -> list[float | None] | None:
    if values is None:
        return None
    noise = rng.normal(0.0, sigma, size=len(values)) if sigma > 0 else np.zeros(len(values))
    return [None if v is None else float(v + d) for v, d in zip(values, noise)]


def _subsample(track: Track, scene: PerceivedScene, fps: float) -> Track:
    src_rows = frame_rows(scene.steps, track.fps or scene.video.fps)
    dst_rows = frame_rows(scene.steps, fps)
    pick = np.clip(np.searchsorted(src_rows, dst_rows), 0, len(src_rows) - 1)
    update: dict[str, Any] = {"fps": fps}
    for name in _TRACK_FIELDS:
        values = getattr(track, name)
        if values is not None:
            update[name] = [values[i] for i in pick]
    return track.model_copy(update=update)


def _swap_from(a: Track, b: Track, frame: int) -> tuple[Track, Track]:
    ua: dict[str, Any] = {}
    ub: dict[str, Any] = {}
    for name in _TRACK_FIELDS:
        va, vb = getattr(a, name), getattr(b, name)
        if va is None or vb is None:
            continue
        ua[name] = va[:frame] + vb[frame:]
        ub[name] = vb[:frame] + va[frame:]
    return a.model_copy(update=ua), b.model_copy(update=ub)


def _with_gaps(track: Track, rate: float, mean_length: float, rng: np.random.Generator) -> Track:
    n = track.length
    count = int(rng.poisson(rate)) if rate > 0 else 0
    hidden = np.zeros(n, dtype=bool)
    for _ in range(count):
        start = int(rng.integers(n))
        length = int(rng.geometric(1.0 / mean_length))
        hidden[start:start + length] = True
    if not hidden.any():
        return track
    update: dict[str, Any] = {}
    for name in _TRACK_FIELDS[:-1]:
        values = getattr(track, name)
        if values is not None:
            update[name] = [None if h else v for v, h in zip(values, hidden.tolist())]
    visible = track.visible if track.visible is not None else [True] * n
    update["visible"] = [bool(v and not h) for v, h in zip(visible, hidden.tolist())]
    return track.model_copy(update=update)


def degrade(scene: PerceivedScene, noise: NoiseModel, seed: int) -> PerceivedScene:
    """``scene`` as an imperfect perception model would report it (deterministic in ``seed`` and ``noise``)."""
    attr_rng, pos_rng, swap_rng, gap_rng, event_rng, time_rng = (
        np.random.Generator(np.random.PCG64(s)) for s in np.random.SeedSequence(seed).spawn(6))
    frames = scene.video.frames
    objects = sorted(scene.objects, key=lambda o: o.id)
    dynamic_ids = [o.id for o in objects if dynamic_probability(o) >= DECISION_THRESHOLD]
    out: list[PerceivedObject] = []
    for obj in objects:
        update: dict[str, Any] = {}
        if obj.id in dynamic_ids:
            update.update(_confuse(obj, noise.attribute_confusion, attr_rng))
        if obj.pose is not None and noise.position_sigma_px > 0:
            s = noise.position_sigma_px / np.sqrt(frames)
            dx, dy = (float(v) for v in pos_rng.normal(0, s, size=2))
            update["pose"] = Pose(x=obj.pose.x + dx, y=obj.pose.y + dy, angle=obj.pose.angle)
        if obj.track is not None:
            t = obj.track
            changes: dict[str, Any] = {"x": _noisy(t.x, noise.position_sigma_px, pos_rng),
                                       "y": _noisy(t.y, noise.position_sigma_px, pos_rng),
                                       "angle": _noisy(t.angle, noise.angle_sigma_rad, pos_rng)}
            if not noise.keep_velocities:
                changes.update(vx=None, vy=None, angular_velocity=None)
            update["track"] = t.model_copy(update=changes)
        out.append(obj.model_copy(update=update) if update else obj)
    events = [e.model_copy() for e in scene.events] if scene.events is not None else None
    # identity swaps
    tracked = [i for i, o in enumerate(out) if o.track is not None and o.id in dynamic_ids]
    swaps = int(swap_rng.poisson(noise.identity_swap_rate)) if noise.identity_swap_rate > 0 else 0
    for _ in range(swaps):
        if len(tracked) < 2:
            break
        i, j = (int(k) for k in swap_rng.choice(tracked, size=2, replace=False))
        frame = int(swap_rng.integers(1, max(frames, 2)))
        ti, tj = out[i].track, out[j].track
        assert ti is not None and tj is not None
        frame = min(frame, ti.length)
        ti, tj = _swap_from(ti, tj, frame)
        out[i] = out[i].model_copy(update={"track": ti})
        out[j] = out[j].model_copy(update={"track": tj})
        a, b = out[i].id, out[j].id
        if events is not None:
            events = [e.model_copy(update={"objects": [b if o == a else a if o == b else o for o in e.objects]})
                      if e.frame >= frame else e for e in events]
    # gaps and subsampling
    for k, obj in enumerate(out):
        if obj.track is None:
            continue
        track = _with_gaps(obj.track, noise.gap_rate, noise.gap_frames, gap_rng)
        if noise.track_fps is not None:
            track = _subsample(track, scene, noise.track_fps)
        out[k] = obj.model_copy(update={"track": track})
    # events: misses, false alarms, confidence, timing
    if events is not None:
        kept = [e for e in events if not (float(event_rng.random()) < noise.event_miss_rate)]
        basket = [o.id for o in out if most_likely(o.shape) == "basket"]
        others = [o.id for o in out]
        rate = noise.event_false_alarm_rate * len(events)
        n_false = int(event_rng.poisson(rate)) if rate > 0 else 0
        for _ in range(n_false):
            if not dynamic_ids:
                break
            kind = _FALSE_ALARM_TYPES[int(event_rng.integers(len(_FALSE_ALARM_TYPES)))]
            body = dynamic_ids[int(event_rng.integers(len(dynamic_ids)))]
            if kind == ENTER_BASKET and basket:
                pair = [basket[0], body]
            else:
                partners = [o for o in others if o != body]
                if not partners:
                    continue
                pair = [partners[int(event_rng.integers(len(partners)))], body]
                kind = COLLISION if kind == ENTER_BASKET else kind
            kept.append(PerceivedEvent(type=kind, objects=pair, frame=int(event_rng.integers(frames))))
        confidence = 1.0
        if noise.event_false_alarm_rate > 0:
            confidence = (1.0 - noise.event_miss_rate) / (1.0 - noise.event_miss_rate + noise.event_false_alarm_rate)
        jitter = noise.timing_jitter_frames
        events = []
        for e in kept:
            frame = e.frame
            if jitter:
                frame = int(np.clip(frame + int(time_rng.integers(-jitter, jitter + 1)), 0, frames - 1))
            events.append(e.model_copy(update={"frame": frame, "confidence": confidence}))
    meta = dict(scene.meta, noise=noise.model_dump(mode="json"), noise_seed=seed)
    return scene.model_copy(update={"objects": out, "events": events, "meta": meta})
