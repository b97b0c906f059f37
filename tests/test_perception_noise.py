"""The noise model: deterministic in its seed, and every knob does what it says (rates measured on large draws)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from perception_helpers import tiny_scene

from craft_dsl.perception import PerceivedEvent, PerceivedObject, PerceivedScene, VideoInfo, check_scene
from craft_dsl.perception.noise import NoiseModel, degrade
from craft_dsl.perception.schema import Track
from craft_dsl.vocabulary import COLORS

N_OBJECTS = 400
FRAMES = 60


def _crowd() -> PerceivedScene:
    """400 dynamic objects with straight tracks and 400 events: large draws in one call."""
    objects = [PerceivedObject(id=i, color={COLORS[i % 8]: 1.0}, shape={"cube": 1.0}, size={"small": 1.0},
                               track=Track(x=[float(i % 200)] * FRAMES, y=[50.0 + k for k in range(FRAMES)],
                                           angle=[0.0] * FRAMES, vx=[0.0] * FRAMES, vy=[60.0] * FRAMES,
                                           angular_velocity=[0.0] * FRAMES))
               for i in range(N_OBJECTS)]
    objects.append(PerceivedObject(id=N_OBJECTS, shape={"basket": 1.0}))
    events = [PerceivedEvent(type="Collision", objects=[i, (i + 1) % N_OBJECTS], frame=30) for i in range(N_OBJECTS)]
    return PerceivedScene(video=VideoInfo(fps=60, frames=FRAMES), objects=objects, events=events)


def _binomial_ok(count: int, n: int, p: float) -> bool:
    return abs(count - n * p) <= 5 * math.sqrt(n * p * (1 - p)) + 1


def test_same_seed_same_bytes_other_seed_other_bytes() -> None:
    noise = NoiseModel(position_sigma_px=2, attribute_confusion=0.1, event_miss_rate=0.1, event_false_alarm_rate=0.1,
                       timing_jitter_frames=2, identity_swap_rate=1, gap_rate=0.5)
    scene = _crowd()
    a, b, c = degrade(scene, noise, 5), degrade(scene, noise, 5), degrade(scene, noise, 6)
    assert a.dumps() == b.dumps() != c.dumps()
    check_scene(a)  # a degraded scene is a valid scene


def test_zero_noise_keeps_everything_but_velocities() -> None:
    scene = _crowd()
    out = degrade(scene, NoiseModel(), 0)
    assert out.events == scene.events
    assert all(o.track is not None and o.track.vx is None for o in out.objects[:-1])
    assert [o.track.x for o in out.objects[:-1] if o.track] == [o.track.x for o in scene.objects[:-1] if o.track]
    kept = degrade(scene, NoiseModel(keep_velocities=True), 0)
    assert kept.objects == scene.objects


def test_attribute_confusion_rate_and_calibrated_distribution() -> None:
    scene = _crowd()
    out = degrade(scene, NoiseModel(attribute_confusion=0.2), 1)
    changed = sum(max(o.color, key=o.color.__getitem__) != COLORS[o.id % 8]  # type: ignore[union-attr, arg-type]
                  for o in out.objects[:-1])
    assert _binomial_ok(changed, N_OBJECTS, 0.2)
    dist = out.objects[0].color
    assert dist is not None and len(dist) == 8 and sum(dist.values()) == pytest.approx(1.0)
    assert sorted(dist.values())[-1] == pytest.approx(0.8) and sorted(dist.values())[0] == pytest.approx(0.2 / 7)
    assert out.objects[-1].shape == {"basket": 1.0}  # statics are never confused


def test_position_noise_standard_deviation() -> None:
    scene = _crowd()
    out = degrade(scene, NoiseModel(position_sigma_px=2.0), 2)
    dx = np.array([[a - b for a, b in zip(o.track.x, s.track.x)]  # type: ignore[union-attr, operator]
                   for o, s in zip(out.objects[:-1], scene.objects[:-1])])
    assert dx.std() == pytest.approx(2.0, rel=0.02)
    assert abs(dx.mean()) < 0.02


def test_event_misses_false_alarms_and_confidence() -> None:
    scene = _crowd()
    missed = degrade(scene, NoiseModel(event_miss_rate=0.1), 3)
    assert missed.events is not None and _binomial_ok(N_OBJECTS - len(missed.events), N_OBJECTS, 0.1)
    assert {e.confidence for e in missed.events} == {1.0}
    false = degrade(scene, NoiseModel(event_false_alarm_rate=0.25), 3)
    assert false.events is not None
    extra = len(false.events) - N_OBJECTS
    assert abs(extra - 100) <= 5 * 10  # Poisson(100)
    assert all(e.confidence == pytest.approx(1 / 1.25) for e in false.events)
    check_scene(false)


def test_timing_jitter_stays_within_its_bound_and_uses_it() -> None:
    out = degrade(_crowd(), NoiseModel(timing_jitter_frames=3), 4)
    assert out.events is not None
    shifts = [e.frame - 30 for e in out.events]
    assert set(shifts) == {-3, -2, -1, 0, 1, 2, 3}
    assert abs(np.mean(shifts)) < 0.5


def test_identity_swaps_exchange_tracks_and_event_ids() -> None:
    scene = tiny_scene()
    out = degrade(scene, NoiseModel(identity_swap_rate=50, keep_velocities=True), 7)
    cube, circle = out.object(1).track, out.object(0).track
    assert cube is not None and circle is not None
    assert set(cube.x) == {60.0, 128.0} and set(circle.x) == {60.0, 128.0}  # exchanged from some frame on


def test_gaps_hide_frames() -> None:
    out = degrade(_crowd(), NoiseModel(gap_rate=1.0, gap_frames=5), 8)
    hidden = [sum(not v for v in o.track.visible) for o in out.objects[:-1] if o.track and o.track.visible]
    assert hidden and sum(hidden) > 0
    o = next(o for o in out.objects[:-1] if o.track and o.track.visible and not all(o.track.visible))
    assert o.track is not None and o.track.visible is not None
    assert all(x is None for x, v in zip(o.track.x, o.track.visible) if not v)


def test_noise_knobs_are_validated() -> None:
    with pytest.raises(ValueError):
        NoiseModel(attribute_confusion=1.5)
    with pytest.raises(ValueError):
        NoiseModel(position_sigma_px=-1)


@settings(max_examples=25, deadline=None)
@given(st.floats(0, 8), st.floats(0, 1), st.floats(0, 1), st.floats(0, 2), st.integers(0, 5), st.floats(0, 3),
       st.floats(0, 3), st.integers(0, 2**32 - 1))
def test_any_degradation_is_a_valid_scene(sigma: float, confusion: float, miss: float, false_alarm: float,
                                          jitter: int, swaps: float, gaps: float, seed: int) -> None:
    noise = NoiseModel(position_sigma_px=sigma, attribute_confusion=confusion, event_miss_rate=miss,
                       event_false_alarm_rate=false_alarm, timing_jitter_frames=jitter, identity_swap_rate=swaps,
                       gap_rate=gaps)
    out = degrade(tiny_scene(), noise, seed)
    assert check_scene(out)[1] == []
    assert {o.id for o in out.objects} == {o.id for o in tiny_scene().objects}
