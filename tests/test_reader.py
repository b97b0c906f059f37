"""The video reader: colour lookup, layout model and fit, measurement, detection, answering, and the honest
end-to-end run of ``craft-dsl read`` on a dataset stripped to its videos and question texts."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from craft_dsl.cli import main
from craft_dsl.errors import InputFileError, ReaderError
from craft_dsl.physics import simulate
from craft_dsl.reader.answer import Question, answer_questions, find_videos, format_answer, read_questions
from craft_dsl.reader.detect import (
    BLACK,
    PALETTE,
    WHITE,
    Blob,
    blobs,
    color_table,
    grid_floor,
    grid_labels,
    lookup,
)
from craft_dsl.reader.layout import StaticRenderer, fit_statics, observation
from craft_dsl.reader.layout_model import LayoutModel, layout_model
from craft_dsl.reader.measure import measure, measure_many
from craft_dsl.reader.perceive import perceive_frames
from craft_dsl.reader.track import TrackedObject, count_per_color, select_objects
from craft_dsl.render import frames as render_frames
from craft_dsl.render.raster import static_layer, world_to_pixel
from craft_dsl.scenes import Uniform, sample_values, sample_world
from craft_dsl.verify.answers import answers_agree
from craft_dsl.vocabulary import COLORS
from craft_dsl.world import WorldSpec, make_dynamic

# -- colour lookup -----------------------------------------------------------------------------------------


def test_palette_colours_read_as_themselves() -> None:
    got = lookup(PALETTE.astype(np.uint8)[:, None, :])[:, 0]
    assert got[:len(COLORS)].tolist() == list(range(len(COLORS)))
    assert got[WHITE] == WHITE and got[BLACK] == BLACK


def test_a_half_blend_of_a_colour_and_white_is_unlabelled() -> None:
    red = np.array(PALETTE[COLORS.index("red")])
    blend = (0.5 * red + 0.5 * 255).astype(np.uint8)
    assert lookup(blend[None, None, :])[0, 0] == -1


def test_every_colour_reads_as_the_table_entry_of_its_5_bit_bin() -> None:
    r, g = np.meshgrid(np.arange(256, dtype=np.uint8), np.arange(256, dtype=np.uint8), indexing="ij")
    table = color_table()
    for b in range(0, 256, 5):  # every (r, g) pair with blue levels across the range, in 52 frames of 65,536
        pixels = np.stack([r, g, np.full_like(r, b)], axis=-1)
        expected = table[(r.astype(np.int64) // 8) * 1024 + (g.astype(np.int64) // 8) * 32 + b // 8]
        assert np.array_equal(lookup(pixels), expected)


# -- the layout as a function of its draws -------------------------------------------------------------------


@pytest.mark.parametrize("scene", range(1, 21))
def test_layout_model_rebuilds_the_sampled_world(scene: int) -> None:
    model = layout_model(scene)
    for seed in (0, 3):
        values = sample_values(scene, seed)
        world = sample_world(scene, seed)
        attributes = [(b.shape, b.color, b.size) for b in world.bodies if b.dynamic]
        assert model.world({d.path: values[d.path] for d in model.draws}, attributes).bodies == world.bodies


@settings(max_examples=40, deadline=None)
@given(scene=st.integers(1, 20), data=st.data())
def test_every_unit_position_gives_draws_within_their_ranges(scene: int, data: st.DataObject) -> None:
    model = layout_model(scene)
    units = {d.path: data.draw(st.floats(-0.5, 1.5)) for d in model.draws if isinstance(d.quantity, Uniform)}
    values = model.from_unit(units)
    bounds = model.bounds(values)
    for path, value in values.items():
        lo, hi = bounds[path]
        assert lo - 1e-9 <= value <= hi + 1e-9, (path, value, lo, hi)


def test_static_fit_recovers_the_draws_of_a_drawn_layout() -> None:
    scene, seed = 3, 11
    model = LayoutModel(scene)
    truth = sample_values(scene, seed)
    drawn = static_layer(sample_world(scene, seed))
    lum, weight = observation(drawn)
    values, rms = fit_statics(model, lum, weight)
    assert rms < 1.0
    for path in model.static_paths:
        lo, hi = model.bounds(values)[path]
        assert abs(values[path] - truth[path]) < 1e-3 * max(hi - lo, 1.0), path


def test_static_renderer_matches_the_renderer() -> None:
    model = layout_model(8)
    values = sample_values(8, 2)
    ours = StaticRenderer(model).render(values)
    theirs = static_layer(sample_world(8, 2)).astype(np.float32).mean(axis=-1)
    assert np.abs(ours - theirs).max() <= 1.0


# -- measurement -------------------------------------------------------------------------------------------


def _red_body_window(shape: str, *others: tuple[str, str, str, tuple[float, float]]
                     ) -> tuple[np.ndarray, np.ndarray, tuple[int, int], tuple[float, float]]:
    """A 48-px window (frame, background, origin) around a large red ``shape`` drawn at rest in scene 3's layout,
    with ``others`` (shape, colour, size, position) drawn too; and the red body's centre (pixels)."""
    world = sample_world(3, 0)
    background = static_layer(world)
    bodies = [make_dynamic(0, shape, "red", "large", (1.237, 30.61))]
    bodies += [make_dynamic(k + 1, s, c, z, p) for k, (s, c, z, p) in enumerate(others)]
    sim = simulate(WorldSpec(bodies=tuple(b for b in world.bodies if not b.dynamic) + tuple(bodies)), steps=1)
    frame = render_frames(sim)[0]
    x, y = world_to_pixel(*sim.trajectory.positions[1, sim.trajectory.column(0)])
    y0, x0 = int(y) - 24, int(x) - 24
    return frame[y0:y0 + 48, x0:x0 + 48].copy(), background[y0:y0 + 48, x0:x0 + 48], (y0, x0), (x, y)


@pytest.mark.parametrize("shape", ["cube", "triangle", "circle"])
def test_a_large_body_is_measured_at_its_centre(shape: str) -> None:
    window, background, origin, (x, y) = _red_body_window(shape)
    m = measure(window, background, COLORS.index("red"), origin)
    assert m is not None and m.complete
    assert math.hypot(m.x - x, m.y - y) < 0.05
    angle = m.eye_angle()
    assert angle is not None and abs((angle - math.pi + math.pi) % (2 * math.pi) - math.pi) < 0.35


@pytest.mark.parametrize("shape", ["cube", "triangle", "circle"])
def test_a_band_of_another_colour_along_the_outline_is_the_bodys_own_bleeding(shape: str) -> None:
    # lossy video shifts a saturated edge's colour: a red body's outline reads brown in places, two pixels wide at
    # most; that is not another body touching it
    window, background, origin, _centre = _red_body_window(shape)
    red = COLORS.index("red")
    clean = measure(window, background, red, origin)
    mask = lookup(window) == red
    grown = mask.copy()
    grown[:, 1:] |= mask[:, :-1]
    grown[:, 2:] |= mask[:, :-2]
    band = grown & ~mask
    band[:, :24] = False  # along the right half of the outline
    dark_red = np.array([140, 60, 40], dtype=np.uint8)  # reads as brown
    assert (lookup(dark_red[None, None]) == COLORS.index("brown")).all()
    bled = window.copy()
    bled[band] = dark_red
    m = measure(bled, background, red, origin)
    assert clean is not None and m is not None and band.sum() >= 12
    assert m.complete
    assert clean.area <= m.area <= clean.area + band.sum()  # the band counts (its pixels nearly wholly red)


@pytest.mark.parametrize("smear", [False, True])
def test_a_smear_of_a_large_body_s_colour_along_a_static_does_not_set_its_radius(smear: bool) -> None:
    # a lossy copy: a large red circle resting on a black bar, its colour smeared 9 px along the bar's top edge
    background = np.full((48, 48, 3), 255, dtype=np.uint8)
    background[35:39] = 0
    window = background.copy()
    rows, cols = np.mgrid[0:48, 0:48] + 0.5
    red = COLORS.index("red")
    window[(cols - 24.0) ** 2 + (rows - 24.5) ** 2 <= 10.3 ** 2] = PALETTE[red]
    if smear:
        window[34, 14:23] = PALETTE[red]
    m = measure(window, background, red, (0, 0))
    assert m is not None
    assert abs(m.radius - 10.3) < 1.0  # the smear reaches 13 px from the centre
    assert m.radius / math.sqrt(m.area) < 0.63  # nearer a circle's 0.55 than a cube's 0.71


def test_gray_specks_of_another_body_are_not_a_gray_body_s() -> None:
    # a large gray circle resting on a small blue cube whose outline and eye rims read gray in places (its blue
    # mixed with black or white): the gray mask's closing must not join them to the circle
    background = np.full((48, 48, 3), 255, dtype=np.uint8)
    rows, cols = np.mgrid[0:48, 0:48] + 0.5
    gray, blue = COLORS.index("gray"), COLORS.index("blue")
    circle = (cols - 24.0) ** 2 + (rows - 18.5) ** 2 <= 10.3 ** 2
    alone = background.copy()
    alone[circle] = PALETTE[gray]
    touched = alone.copy()
    touched[30:42, 16:30] = PALETTE[blue]  # the cube, its top row touching the circle's bottom
    touched[29, 16:30] = PALETTE[gray]  # its outline, gray where blue met black
    touched[33:35, 19:21] = PALETTE[gray]  # an eye rim's specks inside it
    touched[33:35, 25:27] = PALETTE[gray]
    clean = measure(alone, background, gray, (0, 0), seed=(18, 24))
    m = measure(touched, background, gray, (0, 0), seed=(18, 24))
    assert clean is not None and m is not None
    assert abs(m.area - clean.area) < 0.05 * clean.area  # joined to it, the specks made it 20% larger
    assert m.radius / math.sqrt(m.area) < 0.63  # a circle's 0.55, not a cube's 0.71


def test_another_body_touching_is_still_another_body() -> None:
    # a small brown cube resting against the large red cube's right side (half-width 2 m + 1 m)
    window, background, origin, _centre = _red_body_window(
        "cube", ("cube", "brown", "small", (1.237 + 3.05, 29.61)))
    m = measure(window, background, COLORS.index("red"), origin)
    assert m is not None and not m.complete


def test_windows_measured_together_are_measured_as_each_alone() -> None:
    # a video's windows of one body are measured as one stack: the same measurements, to the bit, as one by one
    red = COLORS.index("red")
    cases = [_red_body_window(shape) for shape in ("cube", "triangle", "circle")]
    cases.append(_red_body_window("cube", ("cube", "brown", "small", (1.237 + 3.05, 29.61))))  # another body touches
    window, background, origin, _centre = cases[0]
    speck = window.copy()
    speck[1:4, 1:4] = PALETTE[red]  # a second red piece in a corner
    empty = background.copy()  # no body at all
    windows = np.stack([c[0] for c in cases] + [speck, speck, empty])
    backgrounds = np.stack([c[1] for c in cases] + [background] * 3)
    origins = [c[2] for c in cases] + [origin] * 3
    seeds = [(24, 24)] * len(cases) + [(24, 24), (2, 2), (24, 24)]
    for given_seeds in (seeds, None):
        together = measure_many(windows, backgrounds, red, origins, seeds=given_seeds)
        alone = [measure(w, b, red, o, seed=None if given_seeds is None else s)
                 for w, b, o, s in zip(windows, backgrounds, origins, seeds)]
        assert together == alone
    assert together[-1] is None
    by_seed = measure_many(windows[-3:-1], backgrounds[-3:-1], red, origins[-3:-1], seeds=seeds[-3:-1])
    assert by_seed[0] is not None and by_seed[1] is not None and by_seed[1].area < 20 < by_seed[0].area


# -- detection and perception on rendered (lossless) frames ---------------------------------------------------


@pytest.fixture(scope="module")
def rendered() -> tuple[object, np.ndarray]:
    sim = simulate(14, seed=4, steps=120)
    return sim, render_frames(sim)


def test_blobs_count_the_bodies_of_each_colour(rendered: tuple[object, np.ndarray]) -> None:
    sim, video = rendered
    world = sim.world  # type: ignore[attr-defined]
    labels = grid_labels(video, static_layer(world))
    counts = count_per_color(blobs(labels), len(video))
    truth: dict[int, int] = {}
    for b in world.bodies:
        if b.dynamic:
            truth[COLORS.index(b.color)] = truth.get(COLORS.index(b.color), 0) + 1
    assert counts == truth


def test_a_body_blurred_into_the_ground_line_lies_on_the_floor() -> None:
    """A rescaled video blurs a body lying on the ground into the ground line, the frame's last row: where a static
    is drawn all along the bottom edge such a piece is flagged on the floor; at the other edges, or where the bottom
    edge is not drawn, it is only cut off."""
    world = sample_world(1, 0)
    background = static_layer(WorldSpec(bodies=tuple(b for b in world.bodies if not b.dynamic)), 256)
    floor = grid_floor(background)
    assert floor.all()  # every layout's ground spans the frame's bottom edge
    labels = np.full((1, 128, 128), -1, dtype=np.int8)
    labels[0, 120:128, 40:48] = COLORS.index("green")  # down to the last grid row
    labels[0, 60:68, 0:8] = COLORS.index("red")  # at the left edge
    labels[0, 120:128, 0:8] = COLORS.index("blue")  # in the bottom left corner
    found = {COLORS[b.color]: b for b in blobs(labels, None, floor)}
    assert {c: (b.touches_edge, b.on_floor) for c, b in found.items()} == {
        "green": (True, True), "red": (True, False), "blue": (True, False)}
    assert not any(b.on_floor for b in blobs(labels))  # no floor given
    no_ground = floor.copy()
    no_ground[44] = False
    assert not {COLORS[b.color]: b for b in blobs(labels, None, no_ground)}["green"].on_floor


def _track_over(frames: np.ndarray, color: str, x: float, y: float, area: float, seen: int) -> TrackedObject:
    c = COLORS.index(color)
    return TrackedObject(c, [Blob(k, c, area, x, y, False) if k < seen else None for k in range(len(frames))])


def test_a_small_body_beats_a_larger_piece_of_another_bodys_colour() -> None:
    """Of three gray tracks, two are kept: the small gray body and the large one; the third, as much evidence as
    the small body but with a green centre (a ring of compression gray around a green body), goes."""
    frames = np.full((20, 64, 64, 3), 255, dtype=np.uint8)
    frames[:, 8:14, 8:14] = PALETTE[COLORS.index("gray")]  # a small gray body
    frames[:, 40:60, 40:60] = PALETTE[COLORS.index("gray")]  # a large gray body
    frames[:, 8:14, 40:46] = PALETTE[COLORS.index("green")]  # a green body, ringed by gray
    small = _track_over(frames, "gray", 11.0, 11.0, 36.0, 20)
    large = _track_over(frames, "gray", 50.0, 50.0, 400.0, 20)
    ring = _track_over(frames, "gray", 43.0, 11.0, 40.0, 20)
    kept = select_objects([ring, small, large], 2, frames)
    assert kept == [small, large]
    assert select_objects([ring, small, large], None, frames) == [ring, small, large]


def test_perception_finds_the_layout_the_bodies_and_their_motion(rendered: tuple[object, np.ndarray]) -> None:
    sim, video = rendered
    p = perceive_frames(video)
    assert p.layout.scene == 14
    world = sim.world  # type: ignore[attr-defined]
    assert sorted(p.reconstruction.attributes) == sorted((b.shape, b.color, b.size) for b in world.bodies
                                                         if b.dynamic)
    truth = sim.trajectory  # type: ignore[attr-defined]
    ours = p.reconstruction.simulation.trajectory
    for uid in world.dynamic_uids:
        error = np.hypot(*(ours.positions[:, ours.column(uid)] - truth.positions[:, truth.column(uid)]).T)
        assert float(error.max()) < 0.05  # metres: a quarter of a pixel
    assert p.scene.scene == 14 and p.scene.events is not None


# -- answers -----------------------------------------------------------------------------------------------


def test_answers_are_written_as_the_dataset_writes_them() -> None:
    assert format_answer(True) == "True" and format_answer(3) == "3" and format_answer("red") == "Red"


def test_questions_are_answered_over_a_perceived_scene() -> None:
    from craft_dsl.perception import export_perceived

    sim = simulate(5, seed=2)
    scene = export_perceived(sim)
    questions = [Question(0, 0, "How many objects fall to the ground?"), Question(0, 1, "What is this?")]
    answers = answer_questions(scene, questions)
    from craft_dsl.question_parsing import question_to_program

    assert answers_agree(answers[0].answer, question_to_program(questions[0].text).run(sim))
    assert answers[1].answer is None and "not understood" in (answers[1].error or "")


def test_bad_question_files_are_refused_with_the_record(tmp_path: Path) -> None:
    path = tmp_path / "q.json"
    path.write_text(json.dumps([{"video_index": 0, "question_index": 1, "question": "How many?"},
                                {"video_index": 0, "question_index": 1, "question": "How many?"}]))
    with pytest.raises(ReaderError, match="record 1: question \\(0, 1\\) is listed twice"):
        read_questions(path)
    path.write_text(json.dumps([{"video_index": "0", "question_index": 1, "question": "x"}]))
    with pytest.raises(ReaderError, match="record 0: field 'video_index' must be an integer"):
        read_questions(path)
    path.write_text("[" * 100_000 + "]" * 100_000)  # read by the project's one file reader: no RecursionError
    with pytest.raises(InputFileError, match="nested deeper than 100 levels"):
        read_questions(path)
    with pytest.raises(InputFileError, match="directory"):
        read_questions(tmp_path)
    with pytest.raises(ReaderError, match="no video for video_index 7"):
        find_videos(tmp_path, [7])


# -- honest evaluation: the reader sees the videos and the question texts, nothing else ------------------------


def _stripped_copy(dataset: Path, out: Path) -> Path:
    """``out`` with the dataset's videos and a questions file of (video_index, question_index, question) only."""
    shutil.copytree(dataset / "videos", out / "videos")
    records = json.loads((dataset / "dataset_minimal.json").read_text())
    (out / "questions.json").write_text(json.dumps([{k: r[k] for k in ("video_index", "question_index", "question")}
                                                    for r in records]))
    return out


def test_read_answers_from_videos_and_question_texts_alone(users_dataset: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    work = _stripped_copy(users_dataset, tmp_path / "stripped")
    assert sorted(p.name for p in work.iterdir()) == ["questions.json", "videos"]
    preds = tmp_path / "preds.json"
    assert main(["read", "--steps", "200",
                 "--videos", str(work / "videos"), "--questions", str(work / "questions.json"), "--out",
                 str(preds), "--perceived", str(tmp_path / "perceived"), "--quiet"]) == 0
    predictions = json.loads(preds.read_text())
    records = json.loads((users_dataset / "dataset_minimal.json").read_text())
    assert set(predictions) == {f"{r['video_index']}_{r['question_index']}" for r in records}
    correct = sum(answers_agree(predictions[f"{r['video_index']}_{r['question_index']}"], r["answer"])
                  for r in records)
    assert correct / len(records) >= 0.85  # 93.6 % when written (unfiltered questions of 200-step videos)
    assert len(list((tmp_path / "perceived").glob("*.json"))) == len({r["video_index"] for r in records})
    # the scorer reads the predictions as they are
    assert main(["score", "--questions", str(users_dataset / "dataset_minimal.json"), "--predictions",
                 str(preds), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["missing"] == 0 and report["accuracy"]["All"] == pytest.approx(100 * correct / len(records))


def test_read_reports_a_broken_video_and_keeps_the_others(users_dataset: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    work = _stripped_copy(users_dataset, tmp_path / "stripped")
    videos = sorted((work / "videos").rglob("*.mpg"))
    videos[0].write_bytes(b"not a video")
    questions = json.loads((work / "questions.json").read_text())
    keep = {int(videos[0].stem), int(videos[1].stem)}
    (work / "questions.json").write_text(json.dumps([q for q in questions if q["video_index"] in keep]))
    preds = tmp_path / "preds.json"
    code = main(["read", "--steps", "200",
                 "--videos", str(work / "videos"), "--questions", str(work / "questions.json"), "--out",
                 str(preds), "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    # PyAV finds no frames in it; without PyAV (no reader extra) the ffmpeg pipe refuses it
    assert err.startswith("error: ") and any(f"{videos[0].name}: {why}" in err for why in (
        "the video has no frames", "not a video ffmpeg can read"))
    predictions = json.loads(preds.read_text())
    assert predictions and all(k.startswith(f"{int(videos[1].stem)}_") for k in predictions)


def test_read_runs_as_a_command(users_dataset: Path, tmp_path: Path) -> None:
    work = _stripped_copy(users_dataset, tmp_path / "stripped")
    questions = json.loads((work / "questions.json").read_text())
    first = questions[0]["video_index"]
    (work / "questions.json").write_text(json.dumps([q for q in questions if q["video_index"] == first]))
    preds = tmp_path / "preds.json"
    proc = subprocess.run([sys.executable, "-m", "craft_dsl", "read", "--steps", "200",
                           "--videos", str(work / "videos"),
                           "--questions", str(work / "questions.json"), "--out", str(preds), "--workers", "2"],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert "wrote" in proc.stderr and proc.stdout == ""
    assert len(json.loads(preds.read_text())) == sum(1 for q in questions if q["video_index"] == first)
    bad = subprocess.run([sys.executable, "-m", "craft_dsl", "read", "--videos", str(tmp_path / "none"),
                          "--questions", str(work / "questions.json"), "--out", str(preds)],
                         capture_output=True, text=True, check=False)
    assert bad.returncode == 2 and bad.stderr.startswith("error: --videos")


def test_the_command_line_starts_without_the_pipeline() -> None:
    probe = ("from craft_dsl.cli import build_parser\nbuild_parser()\nimport sys\n"
             "print('scipy' in sys.modules, 'craft_dsl.reader.perceive' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False"]


def test_shade_body_draws_a_body_as_the_renderer_does() -> None:
    from craft_dsl.render.raster import shade_body

    world = sample_world(3, 0)
    body = make_dynamic(0, "triangle", "cyan", "small", (-3.3, 20.7))
    scene = WorldSpec(bodies=tuple(b for b in world.bodies if not b.dynamic) + (body,))
    sim = simulate(scene, steps=1)
    frame = render_frames(sim)[0].astype(np.float32)
    column = sim.trajectory.column(0)
    x, y = world_to_pixel(*sim.trajectory.positions[1, column])
    angle = sim.trajectory.angles[1, column]
    x0, y0, w = int(x) - 12, int(y) - 12, 24
    alpha, base = shade_body(body.geometry, "cyan", np.array([x]), np.array([y]), np.array([angle]),
                             np.array([x0]), np.array([y0]), w)
    background = static_layer(world)[y0:y0 + w, x0:x0 + w].astype(np.float32)
    drawn = background * (1.0 - alpha[0, ..., None]) + base[0]
    assert np.abs(drawn - frame[y0:y0 + w, x0:x0 + w]).max() <= 1.0  # the renderer rounds to uint8


def test_read_gives_probabilities_with_the_distribution(users_dataset: Path, tmp_path: Path) -> None:
    work = _stripped_copy(users_dataset, tmp_path / "stripped")
    questions = json.loads((work / "questions.json").read_text())
    first = questions[0]["video_index"]
    (work / "questions.json").write_text(json.dumps([q for q in questions if q["video_index"] == first]))
    preds, details = tmp_path / "preds.json", tmp_path / "details.jsonl"
    assert main(["read", "--steps", "200",
                 "--videos", str(work / "videos"), "--questions", str(work / "questions.json"), "--out",
                 str(preds), "--details", str(details), "--distribution", "--samples", "16", "--quiet"]) == 0
    predictions = json.loads(preds.read_text())
    lines = [json.loads(line) for line in details.read_text().splitlines()]
    assert len(lines) == len(predictions)
    for line in lines:
        assert predictions[f"{line['video_index']}_{line['question_index']}"] == line["answer"]
        assert 0.0 < line["probability"] <= 1.0 and line["program"]
