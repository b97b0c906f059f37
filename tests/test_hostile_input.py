"""Issue 15's table, one test per row: every hostile input a user or a model can hand craft_dsl gets a precise
error (what, where, what is allowed), exit code 2 on the command line and a CraftError subclass in the library;
nothing is half-written. The fuzz tests (tests/fuzz/) search the same ground at random."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tracemalloc
from pathlib import Path
from typing import Any

import pytest

from craft_dsl import CraftError, Program, Simulation, load_simulation, parse
from craft_dsl.cli import main
from craft_dsl.errors import (
    DatasetFileError,
    InputFileError,
    ParseError,
    PredictionsFileError,
    SceneFileError,
    SimulationFileError,
    TokenError,
)
from craft_dsl.files import MAX_JSON_DEPTH, read_json
from craft_dsl.scenes import load_layout_file, sample_world
from craft_dsl.verify import (
    build_dataset,
    minimal_records,
    read_dataset,
    read_minimal,
    read_predictions,
    read_split,
    score,
    verify_dataset,
)
from tests.conftest import E1_PATH, e1_data

ROOT = Path(__file__).resolve().parents[1]
DEEP_JSON = "[" * 100_000 + "]" * 100_000


def cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def refused(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """The one-line message of a command that must refuse its input with exit code 2 and no traceback."""
    code, out, err = cli(capsys, *argv)
    assert code == 2, (out, err)
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.fixture(scope="module")
def small_dataset() -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """A dataset of the E1 scene (every template with a binding) and its annotations."""
    return build_dataset([load_simulation(E1_PATH)], include_dropped=True)


@pytest.fixture
def dataset_files(tmp_path: Path, small_dataset: tuple[list[dict[str, Any]], dict[str, Any]]) -> dict[str, Path]:
    dataset, annotations = small_dataset
    paths = {"dataset": tmp_path / "dataset.json", "annotations": tmp_path / "annotations.json",
             "minimal": tmp_path / "dataset_minimal.json", "split": tmp_path / "split.json"}
    paths["dataset"].write_text(json.dumps(dataset))
    paths["annotations"].write_text(json.dumps(annotations))
    minimal = minimal_records(dataset)
    paths["minimal"].write_text(json.dumps(minimal))
    paths["split"].write_text(json.dumps({"test": [{"video_index": r["video_index"],
                                                    "question_index": r["question_index"]} for r in minimal]}))
    return paths


# -- row 1: deep programs --------------------------------------------------------------------------------------


def test_row_valid_program_nested_250_levels_deep_parses_checks_prints_and_runs(e1: Simulation) -> None:
    for depth in (250, 2000):
        # alternating modules with side inputs; typographic quotes send the text through the full grammar
        inner = "SceneAtStart()"
        for k in range(depth):
            inner = (f"FilterColor({inner}, \u201cred\u201d)" if k % 2 else f"FilterShape({inner}, \u201ccube\u201d)")
        text = f"Count({inner})"
        program = parse(text)
        assert program.run(e1) == parse('Count(FilterColor(FilterShape(SceneAtStart(), "cube"), "red"))').run(e1)
        assert str(program) == text.replace("\u201c", '"').replace("\u201d", '"')
        assert len(program.trace(e1)) == depth + 2
        again = Program.from_nodes(program.to_nodes())
        assert again.key == program.key == Program.from_tokens(program.to_tokens()).key


def test_row_chain_of_5000_vars_parses_checks_prints_and_runs(e1: Simulation) -> None:
    lines = ['Var V0 = Events()'] + [f"Var V{k} = FilterAfter(V{k - 1}, FilterFirst(Events()))" for k in range(1, 5000)]
    program = parse("\n".join([*lines, "Count(V4999)"]))
    assert program.run(e1) == parse("Count(FilterAfter(Events(), FilterFirst(Events())))").run(e1)
    printed = str(program)
    assert printed.count("\n") == 5000 and parse(printed).key == program.key
    assert Program.from_nodes(program.to_nodes()).key == program.key


def test_row_from_nodes_on_a_300_node_chain(e1: Simulation) -> None:
    nodes: list[dict[str, Any]] = [{"type": "events", "inputs": []}]
    for k in range(300):
        nodes.append({"type": "filter_collision" if k % 2 else "filter_collision_with_dynamics", "inputs": [k]})
    nodes.append({"type": "count", "inputs": [300]})
    program = Program.from_nodes(nodes)
    assert program.run(e1) == parse("Count(FilterCollisionWithDynamics(Events()))").run(e1)
    assert Program.from_nodes(program.to_nodes()).key == program.key


# -- row 2: huge integers ----------------------------------------------------------------------------------------


def test_row_integer_literal_of_5000_digits(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    huge = "9" * 5000
    text = f"Count(FilterObjectsFromEvents(GetCounterfactEvents({huge})))"
    with pytest.raises(ParseError) as info:
        parse(text)
    assert info.value.line == 1 and info.value.column == text.index(huge) + 1
    assert "5,000 digits" in str(info.value) and "9223372036854775807" in str(info.value)
    with pytest.raises(TokenError, match="token 1: the integer .* out of range"):
        Program.from_tokens(["Count", huge])
    err = refused(capsys, "check", text)
    assert "line 1, column 52" in err and len(err) < 300

    # ... as a variation key of a simulation file
    data = e1_data()
    data["variations_outputs"][huge] = data["variations_outputs"]["3"]
    sim_file = tmp_path / "sim.json"
    sim_file.write_text(json.dumps(data))
    err = refused(capsys, "run", "Count(SceneAtStart())", "--sim", str(sim_file))
    assert "field variations_outputs: key '9999" in err and "is not an object id" in err and len(err) < 300
    # ... as a number in a simulation file (any field)
    sim_file.write_text(json.dumps(e1_data()).replace('"uniqueID": 3', f'"uniqueID": {huge}', 1))
    with pytest.raises(SimulationFileError, match=r"line \d+, column \d+ .*a number with 5000 digits"):
        load_simulation(sim_file)

    # ... as a key, an answer or a video_index of verification and scoring files
    minimal = tmp_path / "minimal.json"
    record = {"answer": "2", "template_id": "descriptive_4", "video_index": 0, "question_index": 0}
    minimal.write_text(json.dumps([record]).replace('"video_index": 0', f'"video_index": {huge}'))
    with pytest.raises(DatasetFileError, match=r"minimal.json: line 1, column \d+ \(field \[0\].video_index\): a "
                                               r"number with 5000 digits; allowed: at most 4300"):
        read_minimal(minimal)
    minimal.write_text(json.dumps([record | {"video_index": 10**400}]))
    with pytest.raises(DatasetFileError, match=r"record 0: field 'video_index': must be an integer from 0 to "
                                               r"999,999,999,999, found an integer of 401 digits"):
        read_minimal(minimal)
    minimal.write_text(json.dumps([record]))
    preds = tmp_path / "preds.json"
    for content, needle in ((f'{{"{huge}_0": "red"}}', "is not '<video_index>_<question_index>'"),
                            (f'{{"0_0": {huge}}}', "an integer out of range; allowed: 64-bit integers"),
                            (f'[{{"video_index": {huge}, "question_index": 0, "answer": 1}}]',
                             "at or after record 0: not valid JSON: an integer out of range")):
        preds.write_text(content)
        with pytest.raises(PredictionsFileError, match=needle):
            read_predictions(preds)
        err = refused(capsys, "score", "--questions", str(minimal), "--predictions", str(preds))
        assert err.startswith(f"error: {preds}: ") and needle in err and len(err) < 300


# -- row 3: files that are not UTF-8 -----------------------------------------------------------------------------


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16"])
def test_row_program_or_simulation_file_not_utf8(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                 encoding: str) -> None:
    program = tmp_path / "q.craft"
    program.write_bytes("Count(SceneAtStart())  # café".encode(encoding))
    sim = tmp_path / "sim.json"
    text = json.dumps(e1_data()).replace("./videos", "./vidéos")
    sim.write_bytes(text.encode(encoding))
    nodes = tmp_path / "nodes.json"
    nodes.write_bytes(json.dumps(parse("Count(SceneAtStart())").to_nodes(), ensure_ascii=False)
                      .replace("count", "count").encode(encoding) + " #é".encode(encoding))
    for argv, name in ((["check", f"@{program}"], "program file"),
                       (["run", "Count(SceneAtStart())", "--sim", str(sim)], "simulation file"),
                       (["check", "--nodes", str(nodes)], "node list")):
        err = refused(capsys, *argv)
        assert f"the {name} is" in err
        if encoding == "utf-16":
            assert "UTF-16 text (it starts with a UTF-16 byte order mark); save it as UTF-8" in err
        else:
            assert "is not UTF-8: byte 0xe9" in err and "line 1, column" in err and "Latin-1" in err
    with pytest.raises(SimulationFileError):
        load_simulation(sim)


# -- row 4: JSON nested 100,000 deep -----------------------------------------------------------------------------


def test_row_json_nested_100000_deep_as_any_input_file(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                       dataset_files: dict[str, Path]) -> None:
    deep = tmp_path / "deep.json"
    deep.write_text(DEEP_JSON)
    needle = f"JSON nested deeper than {MAX_JSON_DEPTH} levels; allowed: at most {MAX_JSON_DEPTH}"
    with pytest.raises(SimulationFileError, match=needle):
        load_simulation(deep)
    assert needle in refused(capsys, "run", "Count(SceneAtStart())", "--sim", str(deep))
    assert needle in refused(capsys, "check", "--nodes", str(deep))
    with pytest.raises(DatasetFileError, match=needle):
        read_dataset(deep)
    with pytest.raises(DatasetFileError, match=needle):
        read_split(deep, "test")
    with pytest.raises(PredictionsFileError, match=needle):
        read_predictions(deep)
    assert needle in refused(capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions",
                             str(deep))
    assert needle in refused(capsys, "score", "--questions", str(deep), "--predictions", str(deep))
    assert needle in refused(capsys, "verify", "--dataset", str(deep), "--annotations",
                             str(dataset_files["annotations"]))
    # inside a predictions object, an annotations file and a JSON Lines file
    nested = tmp_path / "nested.json"
    nested.write_text('{"0_0": ' + DEEP_JSON + "}")
    assert needle in refused(capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions",
                             str(nested))
    lines = tmp_path / "preds.jsonl"
    lines.write_text('{"video_index": 0, "question_index": 0, "answer": "a"}\n' + DEEP_JSON + "\n")
    err = refused(capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions", str(lines))
    assert "preds.jsonl: line 2, column " in err and needle in err
    annotations = tmp_path / "annotations.json"
    annotations.write_text('{"000000": ' + DEEP_JSON + "}")
    with pytest.raises(DatasetFileError, match=r"annotations.json: the value at byte 11 is nested deeper than 100"):
        verify_dataset(dataset_files["dataset"], annotations)
    annotations.write_text('{"000000": {"a": ' + "[" * 200 + "]" * 200 + "}}")  # parseable, too deep for the rules
    report = verify_dataset(dataset_files["dataset"], annotations)
    assert report.errors and all(e.kind == "simulation" and needle in e.message for e in report.errors)


# -- row 5: a directory where a file is expected -----------------------------------------------------------------


def test_row_directory_where_a_file_is_expected(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                dataset_files: dict[str, Path]) -> None:
    folder = str(tmp_path)
    assert f"{folder}: is a directory; expected the simulation file (a file)" in refused(
        capsys, "run", "Count(SceneAtStart())", "--sim", folder)
    assert "is a directory; expected the program file" in refused(capsys, "check", f"@{folder}")
    assert "is a directory; expected the node list" in refused(capsys, "check", "--nodes", folder)
    assert "is a directory; expected the predictions file" in refused(
        capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions", folder)
    assert "is a directory; expected the questions file" in refused(
        capsys, "score", "--questions", folder, "--predictions", str(dataset_files["minimal"]))
    assert "is a directory; expected the split file" in refused(
        capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions", str(dataset_files["minimal"]),
        "--split", folder)
    with pytest.raises(SceneFileError, match="is a directory; expected the scene file"):
        load_layout_file(folder)


# -- row 6: a scene layout whose angle is a complex number -------------------------------------------------------


def test_row_scene_angle_evaluating_to_a_complex_number(tmp_path: Path) -> None:
    layout = json.loads((ROOT / "scenes" / "scene_03.json").read_text())
    layout["static"][0]["angle"] = "(-8)**0.5"
    path = tmp_path / "scene_03.json"
    path.write_text(json.dumps(layout))
    with pytest.raises(SceneFileError) as info:
        sample_world(load_layout_file(path), seed=0)
    message = str(info.value)
    assert message.startswith(f"{path}: static[0].angle: ")
    assert "'(-8) ** 0.5' in '(-8)**0.5' has no real value" in message and "allowed: expressions with a real" in message


# -- row 7: a 400-digit numeric answer --------------------------------------------------------------------------


def test_row_400_digit_numeric_answer_in_score_predictions(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                           dataset_files: dict[str, Path]) -> None:
    preds = tmp_path / "preds.json"
    preds.write_text(json.dumps({"0_0": "9" * 400}))
    err = refused(capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions", str(preds))
    assert f"{preds}: key '0_0': the answer is a number out of range ('9999" in err
    assert "numeric answers have at most 18 digits" in err and len(err) < 300
    for answer in (10**400, -(10**30), 1e300):
        with pytest.raises(PredictionsFileError, match="out of range"):
            score(dataset_files["minimal"], {"0_0": answer})
    # normalising never overflows, whatever the caller hands it
    from craft_dsl.verify import normalise_answer

    assert normalise_answer("9" * 400) == "9" * 400 and normalise_answer(" 007 ") == "7"
    assert normalise_answer(float("inf")) == "inf" and normalise_answer(10**5000).startswith("int:")


# -- row 8: a repeated key -----------------------------------------------------------------------------------------


def test_row_predictions_object_with_the_same_key_twice(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        dataset_files: dict[str, Path]) -> None:
    preds = tmp_path / "preds.json"
    preds.write_text('{"0_0":"a","0_0":"b"}')
    err = refused(capsys, "score", "--questions", str(dataset_files["minimal"]), "--predictions", str(preds))
    assert err == f"error: {preds}: key '0_0' appears twice; a question may be predicted only once\n"
    preds.write_text('{"0_0": "a", "1_2": "b", "00_0": "c"}')
    with pytest.raises(PredictionsFileError, match=r"key '00_0': question 0_0 is already predicted by key '0_0'"):
        score(dataset_files["minimal"], preds)
    preds.write_text('{"77_0": "a", "77_0": "b"}')  # for a question the file does not have: an error too
    with pytest.raises(PredictionsFileError, match="key '77_0' appears twice"):
        score(dataset_files["minimal"], preds)
    preds.write_text('{"0_0": {"answer": "a", "answer": "b"}}')  # inside a prediction
    with pytest.raises(PredictionsFileError, match="the key 'answer' appears twice in one object"):
        score(dataset_files["minimal"], preds)


# -- row 9: a 200 MB predictions file ----------------------------------------------------------------------------


def test_row_large_predictions_file_is_streamed(tmp_path: Path, dataset_files: dict[str, Path]) -> None:
    """At 200 MB the benchmark (benchmarks/predictions_memory.py) measures the peak; here a 4 MB file shows the
    scorer's Python allocations stay well below 3x the file (reading it whole took 15x)."""
    minimal = json.loads(dataset_files["minimal"].read_text())
    preds = tmp_path / "preds.json"
    with preds.open("w") as fh:
        fh.write("{" + ", ".join(f'"{r["video_index"]}_{r["question_index"]}": "{r["answer"]}"' for r in minimal))
        fh.write("".join(f', "{1000 + k // 100}_{k % 100}": "red"' for k in range(200_000)) + "}")
    size = preds.stat().st_size
    tracemalloc.start()
    try:
        report = score(dataset_files["minimal"], preds)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert report.columns["All"].accuracy == 100.0 and report.unknown_count == 200_000
    assert len(report.unknown_predictions) == 1000 and report.unknown_predictions[0] == (1000, 0)
    assert peak < 3 * size, f"peak {peak:,} bytes for a {size:,}-byte file"


# -- row 10: recorded simulations ------------------------------------------------------------------------------


def _mutated(change: Any) -> dict[str, Any]:
    data = e1_data()
    change(data)
    return data


def _objects(data: dict[str, Any], state: int = 0) -> list[dict[str, Any]]:
    objects: list[dict[str, Any]] = data["original_video_output"]["scene_states"][state]["scene"]["objects"]
    return objects


def _events(data: dict[str, Any]) -> list[dict[str, Any]]:
    nodes: list[dict[str, Any]] = data["original_video_output"]["causal_graph"]["nodes"]
    return nodes


REFUSED_BY_DEFAULT = {
    "nan velocity": (lambda d: _objects(d)[5].update({"2dLinearVelocity": [math.nan, 0.0]}),
                     r"scene_states.0.scene.objects.5.2dLinearVelocity.0: Input should be a finite number"),
    "infinite velocity": (lambda d: _objects(d, 1)[6].update({"2dLinearVelocity": [0.0, -math.inf]}),
                          r"scene_states.1.scene.objects.6.2dLinearVelocity.1: Input should be a finite number"),
    "negative event step": (lambda d: _events(d)[3].update({"step": -5}),
                            r"causal_graph.nodes.3.step: a \w+ event has step -5; allowed: 0 or more"),
    "unknown shape": (lambda d: _objects(d)[5].update({"shape": "hexagon"}),
                      r"objects.5.shape: object 3 has shape 'hexagon'; allowed: cube, triangle, circle, ground"),
    "unknown colour": (lambda d: _objects(d)[5].update({"color": "pink"}),
                       r"objects.5.color: object 3 has color 'pink'; allowed: gray, red"),
    "unknown size": (lambda d: _objects(d)[5].update({"size": "huge"}), r"objects.5.size: .* allowed: small, large"),
    "causal cycle": (lambda d: d["original_video_output"]["causal_graph"]["edges"].append({"from": 199, "to": [100]}),
                     r"causal_graph.edges: the causal graph has a cycle \((\d+ -> )+\d+\); an event cannot"),
    "id out of 64 bits": (lambda d: _objects(d)[5].update({"uniqueID": 2**64}),
                          r"uniqueID: must be a 64-bit integer"),
}

REFUSED_WHEN_STRICT = {
    "three scene states": (lambda d: d["original_video_output"]["scene_states"].append(
        d["original_video_output"]["scene_states"][1] | {"step": 300}), "strict: exactly 2"),
    "static object moving": (lambda d: _objects(d)[0].update({"2dLinearVelocity": [0.5, 0]}),
                             "strict: static objects have velocity"),
    "edge back in time": (lambda d: d["original_video_output"]["causal_graph"]["edges"].append(
        {"from": 112, "to": [101]}), "strict: causes come strictly earlier"),
    "two start events": (lambda d: _events(d).append({"id": 150, "type": "Start", "step": -1, "objects": []}),
                         "strict: exactly one"),
    "missing variation": (lambda d: d["variations_outputs"].pop("3"), "strict: one per dynamic object"),
    "dynamic ground": (lambda d: _objects(d)[2].update({"bodyType": 2}) or _objects(d, 1)[2].update(
        {"bodyType": 2}), "strict: dynamic objects are one of cube"),
}


@pytest.mark.parametrize("case", sorted(REFUSED_BY_DEFAULT))
def test_row_recorded_simulation_defects_refused_by_default(case: str, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    change, needle = REFUSED_BY_DEFAULT[case]
    data = _mutated(change)
    with pytest.raises(SimulationFileError, match=needle):
        load_simulation(data)
    path = tmp_path / "sim.json"
    path.write_text(json.dumps(data))  # NaN and Infinity are written as the non-standard constants
    err = refused(capsys, "run", "Count(SceneAtStart())", "--sim", str(path))
    assert err.startswith(f"error: {path}: ")
    if "nan" in case or "infinite" in case:
        assert "is not a JSON number; allowed: finite numbers" in err and "2dLinearVelocity" in err
    else:
        assert needle.split(": ")[-1].split(" ")[0].strip("\\") in err


@pytest.mark.parametrize("case", sorted(REFUSED_WHEN_STRICT))
def test_row_recorded_simulation_strict_adds_what_the_simulator_guarantees(case: str, tmp_path: Path,
                                                                           capsys: pytest.CaptureFixture[str]) -> None:
    change, needle = REFUSED_WHEN_STRICT[case]
    data = _mutated(change)
    load_simulation(data)  # accepted by default
    with pytest.raises(SimulationFileError, match=needle):
        load_simulation(data, strict=True)
    path = tmp_path / "sim.json"
    path.write_text(json.dumps(data))
    assert cli(capsys, "run", "Count(SceneAtStart())", "--sim", str(path))[0] == 0
    assert needle in refused(capsys, "run", "Count(SceneAtStart())", "--sim", str(path), "--strict")


def test_strict_accepts_what_the_simulators_write(tmp_path: Path) -> None:
    from craft_dsl import save_simulation, simulate

    load_simulation(E1_PATH, strict=True)
    for scene in (2, 7):
        path = tmp_path / f"s{scene}.json"
        save_simulation(simulate(scene, seed=1), path)
        load_simulation(path, strict=True)


# -- the error path and nothing half-written ---------------------------------------------------------------------


def test_errors_carry_file_line_column_and_field(tmp_path: Path) -> None:
    path = tmp_path / "x.json"
    path.write_text('{"a": [1, 2, {"b": 1, "b": 2}]}')
    with pytest.raises(InputFileError) as info:
        read_json(path, "test file")
    err = info.value
    assert (err.path, err.line, err.column, err.field) == (str(path), 1, 23, "a[2]")
    assert str(err) == f"{path}: line 1, column 23 (field a[2]): the key 'b' appears twice in one object; a key " \
                       "may be given only once"


def test_cli_turns_stray_system_errors_into_exit_2(monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    import craft_dsl.cli as cli_module

    for exc, message in ((RecursionError(), "the input is nested too deeply to be processed"),
                         (MemoryError(), "out of memory: the input is too large to be processed in memory"),
                         (PermissionError(13, "Permission denied", "/x"), "/x: Permission denied")):
        def fail(_: Any, exc: BaseException = exc) -> int:
            raise exc

        monkeypatch.setattr(cli_module, "_load_program", fail)  # what cmd_check calls first
        assert cli(capsys, "check", "Count(SceneAtStart())") == (2, "", f"error: {message}\n")


def test_bad_input_leaves_no_half_written_output(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                 dataset_files: dict[str, Path]) -> None:
    dataset = json.loads(dataset_files["dataset"].read_text())
    dataset[0]["questions"]["questions"][-1]["program"][0]["type"] = "no_such_module"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(dataset))
    out = tmp_path / "pairs.jsonl"
    err = refused(capsys, "export-pairs", "--dataset", str(bad), "--out", str(out))
    assert "field 'program'" in err and "no_such_module" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["annotations.json", "bad.json", "dataset.json",
                                                           "dataset_minimal.json", "split.json"]


def test_installed_script_refuses_a_directory() -> None:
    res = subprocess.run([sys.executable, "-m", "craft_dsl.cli", "run", "Count(SceneAtStart())", "--sim", "/"],
                         capture_output=True, text=True, check=False)
    assert res.returncode == 2 and res.stderr == "error: /: is a directory; expected the simulation file (a file)\n"


def test_error_classes_are_craft_errors() -> None:
    for cls in (InputFileError, SimulationFileError, SceneFileError, DatasetFileError, PredictionsFileError):
        assert issubclass(cls, CraftError)


def test_messages_quoting_huge_inputs_stay_short(tmp_path: Path) -> None:
    name = "X" * 5000
    with pytest.raises(CraftError) as info:
        parse(f"Count({name}())")
    message = str(info.value)
    assert message.startswith("line 1, column 7: unknown module 'XXXX") and "(5,000 characters)" in message
    assert len(message) < 400
    with pytest.raises(CraftError) as info:
        Program.from_nodes([{"type": "count", "inputs": [10**5000]}])  # an integer Python cannot print
    assert str(info.value).startswith("node 0: count: input an integer of about 5,001 digits does not name an earlier")
    path = tmp_path / "x.json"
    path.write_text(json.dumps([{"a\nb": [1, {"c": float("nan")}]}]))
    with pytest.raises(InputFileError) as info2:
        read_json(path, "test file")
    assert "\n" not in str(info2.value) and "(field [0].'a\\nb'[1].c)" in str(info2.value)
