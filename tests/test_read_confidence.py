"""Every reader answer carries a confidence: the probability that it is right (craft_dsl/reader/confidence.py)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks.reader_calibration import ece, ece_interval, reliability, risk_coverage
from craft_dsl.cli import main
from craft_dsl.perception import export_perceived
from craft_dsl.physics import simulate
from craft_dsl.reader.answer import Question, answer_questions
from craft_dsl.reader.confidence import (
    MODEL_PATH,
    PREMISE_RATE,
    ConfidenceModel,
    default_model,
    feature_vector,
    fit_logistic,
    fit_model,
    rescore,
)


@pytest.fixture(scope="module")
def answered() -> list:
    sim = simulate(1, seed=0, steps=200)
    dynamic = [o for o in sim.objects if o.dynamic]
    present = dynamic[0]
    questions = [
        Question(0, 0, "How many objects fall to the ground?"),
        Question(0, 1, f"How many objects does the {present.size} {present.color} {present.shape} cause to fall "
                       "to the ground?"),
        Question(0, 2, "What color is the first object that collided with the large purple cube?"),  # not there
        Question(0, 3, "Is this a question?"),  # not understood
        # two objects that are not there: no reading that reads one object otherwise holds both
        Question(0, 4, "Does the small purple circle enter the basket before the small yellow triangle does?"),
    ]
    return answer_questions(export_perceived(sim), questions)


def test_every_answer_has_a_confidence_in_the_unit_interval(answered: list) -> None:
    for a in answered:
        assert a.confidence is not None and 0.0 <= a.confidence <= 1.0
        record = a.to_json()
        assert record["confidence"] == round(a.confidence, 6)
        assert record["confidence_inputs"] == a.confidence_inputs
    read = answered[:2]
    for a in read:
        assert not a.fallback and set(a.confidence_inputs["agree"]) == {"engine", "resimulate", "derived"}
        assert a.confidence_inputs["category"] in ("D/N-V", "C/N") and a.confidence_inputs["type"] == "count"


def test_guesses_get_a_low_confidence_and_unanswered_questions_none(answered: list) -> None:
    read, premise, unanswered, guess = answered[:2], answered[2], answered[3], answered[4]
    assert guess.fallback and guess.answer == "False"
    assert guess.confidence == pytest.approx(default_model().guess_rate("bool"), abs=1e-6)
    assert guess.confidence <= 0.5 and all(guess.confidence < a.confidence for a in read)
    # the object named is read into the scene (another object read otherwise): the premise rate
    assert premise.premise is not None and not premise.fallback and premise.confidence == PREMISE_RATE
    assert unanswered.answer is None and unanswered.confidence == 0.0


def test_an_answer_from_a_video_that_is_not_whole_is_at_most_a_guess(answered: list) -> None:
    a = answered[0]
    warned = rescore(replace(a, warning="the video is not whole: cut short"))
    assert warned.confidence == min(a.confidence, default_model().guess_rate("count"))
    assert rescore(a).confidence == a.confidence


def test_the_model_file_loads_and_names_every_feature() -> None:
    data = json.loads(MODEL_PATH.read_text())
    model = default_model()
    assert model == ConfidenceModel.from_json(data)
    assert model.features == tuple(feature_vector({}))
    assert len(model.weights) == len(model.mean) == len(model.scale) == len(model.features)
    assert all(s > 0 for s in model.scale) and all(math.isfinite(w) for w in model.weights)
    assert all(0.0 < p < 1.0 for p in model.fallback.values()) and "*" in model.fallback
    with pytest.raises(ValueError, match="differ in length"):
        ConfidenceModel.from_json({**data, "weights": data["weights"][:-1]})


def test_the_model_says_less_when_the_other_executions_disagree() -> None:
    inputs = {"category": "CF/O", "type": "bool", "answer": "True", "mean_stray_px": 1.0, "max_stray_px": 3.0,
              "anchors": 2, "refits": 1, "layout_rms": 8.0, "engines_tried": 1, "physics": "pymunk",
              "least_attribute": 1.0, "scene_p": 1.0, "agree": {"engine": True, "resimulate": True, "derived": True}}
    model = default_model()
    sure = model.confidence(inputs)
    doubt = model.confidence({**inputs, "agree": {"engine": False, "resimulate": False, "derived": False}})
    assert 0.0 <= doubt < sure <= 1.0


def test_ece_reliability_and_risk_coverage_on_known_values() -> None:
    conf = [0.9, 0.9, 0.9, 0.9, 0.1, 0.1]
    ok = [True, True, True, False, False, True]
    assert reliability(conf, ok) == [(0.1, 0.2, 2, pytest.approx(0.1), 0.5), (0.9, 1.0, 4, pytest.approx(0.9), 0.75)]
    assert ece(conf, ok) == pytest.approx((4 * 0.15 + 2 * 0.4) / 6)
    assert ece([1.0, 0.0], [True, False]) == 0.0  # 1.0 falls in the last bin
    assert ece([], []) == 0.0
    assert ece_interval([1.0] * 20, [True] * 20, resamples=50) == (0.0, 0.0)
    low, high = ece_interval(conf, ok, resamples=200, seed=3)
    assert 0.0 <= low <= high <= 1.0 and ece_interval(conf, ok, resamples=200, seed=3) == (low, high)
    table = risk_coverage(conf, ok, (1.0, 0.5))
    assert table == [(1.0, 6, pytest.approx(4 / 6)), (0.5, 3, 1.0)]


def test_logistic_fit_recovers_known_weights() -> None:
    rng = np.random.default_rng(20261126)
    x = rng.normal(size=(20000, 2))
    p = 1.0 / (1.0 + np.exp(-(1.5 * x[:, 0] - 0.5 * x[:, 1] + 0.3)))
    y = (rng.random(20000) < p).astype(float)
    w, b = fit_logistic(x, y, l2=0.0)
    assert w == pytest.approx([1.5, -0.5], abs=0.08) and b == pytest.approx(0.3, abs=0.06)


def test_fit_model_gives_guess_rates_and_a_calibrated_mean() -> None:
    rng = np.random.default_rng(7)
    inputs = []
    correct = []
    for _ in range(400):
        differs = bool(rng.random() < 0.3)
        inputs.append({"category": "D/N-V", "type": "count", "answer": "1",
                       "agree": {"engine": not differs, "resimulate": True, "derived": True}})
        correct.append(bool(rng.random() < (0.5 if differs else 0.95)))
    fallbacks = [False] * 400 + [True] * 4
    inputs += [{"type": "color", "answer": "Gray"}] * 4
    correct += [False, False, False, True]
    model = fit_model(inputs, correct, fallbacks, l2=0.0)
    assert model.guess_rate("color") == pytest.approx((1 + 2 / 8) / 6) and model.guess_rate("*") == pytest.approx(2 / 6)
    assert model.guess_rate("shape") == pytest.approx(1 / 3)  # no guess of this type: chance
    conf = [model.confidence(i) for i in inputs[:400]]
    assert np.mean(conf) == pytest.approx(np.mean(correct[:400]), abs=1e-3)  # a logistic fit's mean is the rate


def test_details_carry_the_confidence_and_predictions_stay_answers(users_dataset: Path, tmp_path: Path) -> None:
    records = json.loads((users_dataset / "dataset_minimal.json").read_text())
    video = records[0]["video_index"]
    questions = tmp_path / "questions.json"
    questions.write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")}
                                     for r in records if r["video_index"] == video]))
    preds, details = tmp_path / "preds.json", tmp_path / "details.jsonl"
    assert main(["read", "--steps", "200",
                 "--videos", str(users_dataset / "videos"), "--questions", str(questions), "--out",
                 str(preds), "--details", str(details), "--workers", "1", "--quiet"]) == 0
    predictions = json.loads(preds.read_text())
    lines = [json.loads(line) for line in details.read_text().splitlines()]
    assert len(lines) == len(predictions) > 0
    for line in lines:
        assert predictions[f"{line['video_index']}_{line['question_index']}"] == line["answer"]
        assert isinstance(line["answer"], str) and 0.0 <= line["confidence"] <= 1.0
        assert line["confidence_inputs"]["category"]


def test_a_measurement_that_fails_leaves_the_answers_standing(monkeypatch: pytest.MonkeyPatch) -> None:
    import craft_dsl.perception.distribution as distribution
    from craft_dsl.reader import confidence

    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("no distribution today")

    monkeypatch.setattr(distribution, "answer_distributions", broken)
    monkeypatch.setitem(confidence.ALTERNATIVES, "bogus", {"events": "nonsense"})  # refused by ExecutionOptions
    scene = export_perceived(simulate(1, seed=0, steps=200))
    [a] = answer_questions(scene, [Question(0, 0, "How many objects fall to the ground?")])
    assert a.answer is not None and a.confidence is not None and 0.0 <= a.confidence <= 1.0
    assert a.confidence_inputs["scene_p"] is None and "bogus" not in a.confidence_inputs["agree"]
    # each failure named with its reason (tests/test_reader_confidence_failures.py: the confidence only falls)
    assert "no distribution today" in a.confidence_inputs["failed"]["scene_p"]
    assert "nonsense" in a.confidence_inputs["failed"]["bogus"]
