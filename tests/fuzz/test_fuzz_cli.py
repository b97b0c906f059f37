"""Fuzz: the command line of the reading commands with hostile arguments and files (missing, directories,
garbage, wrong kinds of file, not UTF-8). Every run ends with an exit code (2 with one `error: ...` line for bad
input), never a traceback, and a failed `export-pairs` leaves no output file.

Long run: python -m pytest tests/ -k fuzz --hypothesis-profile=long
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from craft_dsl import load_simulation
from craft_dsl.cli import main
from craft_dsl.verify import build_dataset, minimal_records
from tests.conftest import E1_PATH
from tests.fuzz.hostile import file_bytes, json_texts

SLOW = settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
DATASET, ANNOTATIONS = build_dataset([load_simulation(E1_PATH)], include_dropped=True)
CONTENT = {
    "e1.json": E1_PATH.read_text(encoding="utf-8"),
    "dataset.json": json.dumps(DATASET),
    "dataset_minimal.json": json.dumps(minimal_records(DATASET)),
    "annotations.json": json.dumps(ANNOTATIONS),
    "preds.json": json.dumps({"0_0": "2", "0_1": "red"}),
    "preds.jsonl": '{"video_index": 0, "question_index": 0, "answer": "2"}\n',
    "nodes.json": json.dumps([{"type": "scene", "inputs": []}, {"type": "count", "inputs": [0]}]),
    "program.craft": "Count(SceneAtStart())",
    "split.json": json.dumps({"test": [{"video_index": 0, "question_index": 0}]}),
}
COMMANDS = {
    "run": ["PROGRAM", "--sim", "FILE"], "check": ["PROGRAM"], "check-nodes": ["--nodes", "FILE"],
    "score": ["--questions", "FILE", "--predictions", "FILE"],
    "score-split": ["--questions", "FILE", "--predictions", "FILE", "--split", "FILE"],
    "verify": ["--dataset", "FILE", "--annotations", "FILE"],
    "evaluate": ["--dataset", "FILE", "--predictions", "FILE", "--annotations", "FILE"],
    "export-pairs": ["--dataset", "FILE", "--out", "OUT"], "ask": ["QUESTION", "--sim", "FILE"],
}


@st.composite
def files(draw: st.DrawFn, folder: Path) -> str:
    """A path argument: a good file of some kind, a broken copy of one, a directory, nothing, or garbage."""
    kind = draw(st.sampled_from(["good", "good", "broken", "bytes", "dir", "missing", "text"]))
    name = draw(st.sampled_from(sorted(CONTENT)))
    if kind == "dir":
        return str(folder)
    if kind == "missing":
        return str(folder / "nope" / name)
    path = folder / f"{draw(st.integers(0, 10**6))}_{name}"
    if kind == "good":
        path.write_text(CONTENT[name])
    elif kind == "broken":
        path.write_text(draw(json_texts(json.loads(CONTENT[name]) if name.endswith(".json") else "x")))
    elif kind == "bytes":
        path.write_bytes(draw(file_bytes(CONTENT[name][:2000])))
    else:
        path.write_text(draw(st.text(max_size=50)))
    return str(path)


@SLOW
@given(st.sampled_from(sorted(COMMANDS)), st.data())
def test_fuzz_command_line(command: str, data: st.DataObject) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        out = folder / "out" / "pairs.jsonl"
        argv = [command.split("-nodes")[0].split("-split")[0]]
        for arg in COMMANDS[command]:
            if arg == "FILE":
                argv.append(data.draw(files(folder)))
            elif arg == "OUT":
                argv.append(str(out))
            elif arg == "PROGRAM":
                argv.append(data.draw(st.one_of(st.sampled_from(["Count(SceneAtStart())", "Count(", "9" * 5000, ""]),
                                                st.builds(lambda p: "@" + p, files(folder)))))
            elif arg == "QUESTION":
                argv.append(data.draw(st.sampled_from(["How many objects fall to the ground?", "", "x" * 3000])))
            else:
                argv.append(arg)
        stdout, stderr = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                code = main(argv)
            except SystemExit as exit:  # argparse: a usage error
                code = exit.code  # type: ignore[assignment]
        err = stderr.getvalue()
        assert code in (0, 1, 2), (argv, code, err)
        assert "Traceback" not in err
        if code == 2 and err.startswith("error: "):
            assert err.count("\n") == 1 and len(err) < 2000, err
        if command == "export-pairs" and code != 0:
            assert not out.exists() and (not out.parent.exists() or not any(out.parent.iterdir()))
