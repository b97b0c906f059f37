"""A measurement that fails can only lower an answer's confidence, and says why (craft_dsl/reader/confidence.py);
a probe of a video that fails says what it could not check (craft_dsl/reader/video.py)."""

from __future__ import annotations

import ast
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import craft_dsl.reader
from craft_dsl.perception import export_perceived
from craft_dsl.perception.schema import PerceivedScene
from craft_dsl.perception.world import SceneModel
from craft_dsl.physics import simulate
from craft_dsl.reader import confidence
from craft_dsl.reader.answer import Answer, Question, answer_questions
from craft_dsl.reader.confidence import ALTERNATIVES, default_model, rescore
from craft_dsl.reader.video import VideoCheckWarning, collect_unchecked, incomplete, not_checked, stated_rate

SIM = simulate(1, seed=0, steps=200)
_ONE = next(o for o in SIM.objects if o.dynamic)
QUESTIONS = [Question(0, 0, "How many objects fall to the ground?"),
             Question(0, 1, f"How many objects does the {_ONE.size} {_ONE.color} {_ONE.shape} cause to fall to the "
                            "ground?")]


@pytest.fixture(scope="module")
def scene() -> PerceivedScene:
    return export_perceived(SIM)


@pytest.fixture(scope="module")
def measured(scene: PerceivedScene) -> list[Answer]:
    return answer_questions(scene, QUESTIONS, votes=0)


def _answered(scene: PerceivedScene) -> list[Answer]:
    return answer_questions(scene, QUESTIONS, votes=0)


def _failing(monkeypatch: pytest.MonkeyPatch, when: Callable[[SceneModel], bool]) -> None:
    """Make ``SceneModel.simulation`` raise for the models ``when`` picks."""
    original = SceneModel.simulation

    def simulation(self: SceneModel, *args: Any, **kwargs: Any) -> Any:
        if when(self):
            raise RuntimeError("this execution broke")
        return original(self, *args, **kwargs)

    monkeypatch.setattr(SceneModel, "simulation", simulation)


PICKS: dict[str, Callable[[SceneModel], bool]] = {
    "engine": lambda m: m.options.engine is not None,
    "resimulate": lambda m: m.options.counterfactual == "resimulate",
    "derived": lambda m: m.options.events == "derived",
}


@pytest.mark.parametrize("name", sorted(ALTERNATIVES))
def test_an_alternative_that_raises_lowers_the_confidence_and_says_why(
        name: str, scene: PerceivedScene, measured: list[Answer], monkeypatch: pytest.MonkeyPatch) -> None:
    _failing(monkeypatch, PICKS[name])
    for before, after in zip(measured, _answered(scene)):
        assert after.answer == before.answer
        assert after.confidence is not None and before.confidence is not None
        assert after.confidence <= before.confidence
        inputs = after.to_json()["confidence_inputs"]
        assert name not in inputs["agree"] and "this execution broke" in inputs["failed"][name]
        assert set(inputs["agree"]) == set(ALTERNATIVES) - {name}


def test_a_program_that_raises_under_the_alternatives_lowers_the_confidence(
        scene: PerceivedScene, measured: list[Answer], monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(value: object) -> str:
        raise RuntimeError("no answer under this execution")

    monkeypatch.setattr(confidence, "format_answer", broken)
    for before, after in zip(measured, _answered(scene)):
        assert after.confidence is not None and before.confidence is not None
        assert after.confidence <= before.confidence
        assert after.confidence_inputs is not None and after.confidence_inputs["agree"] == {}
        assert set(after.confidence_inputs["failed"]) == set(ALTERNATIVES)


def test_a_scene_probability_that_fails_lowers_the_confidence_and_says_why(
        scene: PerceivedScene, measured: list[Answer], monkeypatch: pytest.MonkeyPatch) -> None:
    import craft_dsl.perception.distribution as distribution

    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("no distribution today")

    monkeypatch.setattr(distribution, "answer_distributions", broken)
    for before, after in zip(measured, _answered(scene)):
        assert after.confidence is not None and before.confidence is not None
        assert after.confidence <= before.confidence
        inputs = after.to_json()["confidence_inputs"]
        assert inputs["scene_p"] is None and "no distribution today" in inputs["failed"]["scene_p"]
        assert inputs["scene_p_floor"] == 1.0  # a scene without doubt: its one reading holds every answer
        assert before.confidence_inputs is not None and before.confidence_inputs["scene_p"] == 1.0


def test_an_engine_this_install_lacks_is_weighed_at_the_fitted_rate_and_said(
        scene: PerceivedScene, monkeypatch: pytest.MonkeyPatch) -> None:
    """An install without Box2D (the reader's physics pymunk): the engine alternative cannot run at all."""
    pymunk = scene.model_copy(update={"physics": "pymunk"})
    measured = _answered(pymunk)
    monkeypatch.setattr(confidence, "engine_missing",
                        lambda engine: "box2d is not installed here (test)" if engine == "box2d" else None)
    model = default_model()
    for before, after in zip(measured, _answered(pymunk)):
        inputs = after.confidence_inputs
        assert inputs is not None and before.confidence_inputs is not None
        assert after.confidence is not None and before.confidence is not None
        assert after.confidence <= before.confidence
        assert inputs["unavailable"] == {"engine": "box2d is not installed here (test)"}
        assert "engine" not in inputs["agree"] and "failed" not in inputs
        measured_inputs = {k: v for k, v in inputs.items() if k != "unavailable"}
        agrees = model.confidence({**measured_inputs, "agree": {**inputs["agree"], "engine": True}})
        differs = model.confidence({**measured_inputs, "agree": {**inputs["agree"], "engine": False}})
        assert differs < after.confidence < agrees  # never more than counting it as agreeing
        rate = model.agree_rate("engine")
        p = rate * agrees + (1 - rate) * differs
        assert after.confidence == pytest.approx(p, abs=2e-6)


INPUTS = {"category": "CF/O", "type": "count", "answer": "1", "mean_stray_px": 1.0, "max_stray_px": 3.0,
          "anchors": 2, "refits": 1, "layout_rms": 8.0, "engines_tried": 1, "physics": "pymunk",
          "least_attribute": 0.9}


@given(agree=st.fixed_dictionaries({name: st.booleans() for name in ALTERNATIVES}),
       failed=st.sets(st.sampled_from([*ALTERNATIVES, "scene_p"])),
       p=st.floats(0.0, 1.0), floor=st.floats(0.0, 1.0), category=st.sampled_from(["CF/O", "D/2Q", "C/N", None]),
       answer=st.sampled_from(["0", "1", "3"]), warning=st.booleans())
def test_failure_can_only_lower_the_confidence(agree: dict[str, bool], failed: set[str], p: float, floor: float,
                                               category: str | None, answer: str, warning: bool) -> None:
    """For the same answer, the confidence with any inputs failed is at most the confidence with them measured,
    whatever they measured (the scene probability at least its floor: the probability of the most likely
    reading, in which the answer holds)."""
    model = default_model()
    floor = min(floor, p)
    full = {**INPUTS, "category": category, "answer": answer, "agree": agree, "scene_p": p}
    broken = {**full, "agree": {k: v for k, v in agree.items() if k not in failed},
              "scene_p": None if "scene_p" in failed else p, "failed": {k: "RuntimeError: broke" for k in failed}}
    if "scene_p" in failed:
        broken["scene_p_floor"] = floor
    assert model.confidence(broken, warning=warning) <= model.confidence(full, warning=warning)
    assert rescore(Answer(Question(0, 0, "?"), answer, confidence_inputs=broken)).confidence == \
        model.confidence(broken)


def test_the_confidence_of_inputs_without_failures_is_unchanged() -> None:
    model = default_model()
    inputs = {**INPUTS, "scene_p": 0.98, "agree": {"engine": True, "resimulate": False, "derived": True}}
    z = model.logit(inputs)
    assert model.confidence(inputs) == round(1.0 / (1.0 + np.exp(-z)), 6)


def test_fitting_leaves_out_answers_with_failed_inputs() -> None:
    rng = np.random.default_rng(3)
    inputs: list[dict[str, Any]] = []
    correct = []
    for _ in range(200):
        differs = bool(rng.random() < 0.3)
        inputs.append({**INPUTS, "scene_p": 1.0, "agree": {"engine": not differs, "resimulate": True,
                                                            "derived": True}})
        correct.append(bool(rng.random() < (0.5 if differs else 0.95)))
    model = confidence.fit_model(inputs, correct, [False] * 200, l2=0.0)
    broken = [{**x, "failed": {"engine": "RuntimeError"}} for x in inputs[:50]]
    assert confidence.fit_model(inputs + broken, correct + [False] * 50, [False] * 250, l2=0.0) == model


# -- the video's probes --------------------------------------------------------------------------------------------


def _write_mp4(path: Path, frames: int = 12) -> Path:
    import av

    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=10)
        stream.width = stream.height = 64
        stream.pix_fmt = "yuv420p"
        for k in range(frames):
            image = np.full((64, 64, 3), 20 * k % 255, dtype=np.uint8)
            for packet in stream.encode(av.VideoFrame.from_ndarray(image, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path


def _probes_fail(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make PyAV's ``open`` raise for the probes (which open a file without naming its format), not for decoding."""
    import av

    original = av.open

    def open_(file: Any, *args: Any, **kwargs: Any) -> Any:
        if "format" not in kwargs and not args:
            raise OSError("the container is gone")
        return original(file, *args, **kwargs)

    monkeypatch.setattr(av, "open", open_)


def test_a_probe_that_fails_says_what_it_could_not_check(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    video = _write_mp4(tmp_path / "000003.mp4")
    assert incomplete(video, 12) is None and stated_rate(video) is not None
    _probes_fail(monkeypatch)
    with collect_unchecked() as unchecked:
        assert incomplete(video, 12) is None
        assert stated_rate(video) is None
    assert len(unchecked) == 2
    assert "whether frames were lost could not be checked" in unchecked[0] and "the container is gone" in unchecked[0]
    assert "frame rate its container states could not be read" in unchecked[1]
    with pytest.warns(VideoCheckWarning, match="whether frames were lost could not be checked"):
        incomplete(video, 12)  # no collector: a warning
    with collect_unchecked() as outer:
        with collect_unchecked() as inner:
            not_checked("inner")
        not_checked("outer")
    assert inner == ["inner"] and outer == ["outer"]


def test_what_the_video_probes_could_not_check_reaches_every_answer_and_the_details(
        scene: PerceivedScene) -> None:
    unchecked = ["000000.mp4: the frame rate its container states could not be read (OSError: gone): the rate is "
                 "inferred from the frame count"]
    flagged = scene.model_copy(update={"meta": {**(scene.meta or {}), "unchecked": unchecked}})
    for a in answer_questions(flagged, QUESTIONS, votes=0, confidence=False):
        assert a.unchecked == tuple(unchecked) and json.loads(json.dumps(a.to_json()))["unchecked"] == unchecked
    assert "unchecked" not in answer_questions(scene, QUESTIONS[:1], votes=0, confidence=False)[0].to_json()


def test_a_video_whose_probes_fail_is_read_and_its_answers_say_so(
        users_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from reader_helpers import reencoded

    from craft_dsl.reader.perceive import perceive_video
    from craft_dsl.reader.whole import why_not_whole

    mpg = sorted((users_dataset / "videos").rglob("*.mpg"))[0]
    video = reencoded(mpg, tmp_path / f"{mpg.stem}.mp4")
    _probes_fail(monkeypatch)
    perception = perceive_video(video)
    [note] = perception.scene.meta["unchecked"]
    assert "frame rate its container states could not be read" in note and perception.frame_rate.source == "count"
    [answer] = answer_questions(perception.scene, QUESTIONS[:1], votes=0)
    assert answer.to_json()["unchecked"] == [note]
    why = why_not_whole(str(video), perception, steps=200)  # a check that could not be made: the worst case
    assert why is not None and "it may not be" in why and "whether frames were lost could not be checked" in why
    capped = rescore(Answer(answer.question, answer.answer, confidence_inputs=answer.confidence_inputs,
                            warning=f"the video is not whole: {why}"))
    assert capped.confidence is not None and answer.confidence is not None
    assert capped.confidence <= min(answer.confidence, default_model().guess_rate("count"))


# -- no import circle ----------------------------------------------------------------------------------------------


def _reader_imports(path: Path) -> set[str]:
    """The reader modules a reader module imports (at the top, in functions or for type checking)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            out.update([node.module.split(".")[0]] if node.module else [a.name for a in node.names])
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("craft_dsl.reader."):
            out.add((node.module or "").split(".")[2])
    return out


def test_no_reader_module_imports_one_that_imports_it_back() -> None:
    folder = Path(craft_dsl.reader.__file__).parent
    modules = {p.stem: p for p in folder.glob("*.py")}
    edges = {name: _reader_imports(path) & set(modules) - {name} for name, path in modules.items()}

    def reaches(start: str) -> set[str]:
        seen: set[str] = set()
        todo = list(edges[start])
        while todo:
            m = todo.pop()
            if m not in seen:
                seen.add(m)
                todo += edges[m]
        return seen

    circles = sorted(name for name in modules if name in reaches(name))
    assert circles == []
    from craft_dsl.reader import Answer as Exported
    from craft_dsl.reader.answer import Answer as FromAnswer
    from craft_dsl.reader.answer import format_answer
    from craft_dsl.reader.records import Answer as Record
    from craft_dsl.reader.records import format_answer as formatted

    assert Exported is FromAnswer is Record and format_answer is formatted
