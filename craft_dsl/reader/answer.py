"""Questions in words + a perceived scene -> answers (with their probability where a distribution is asked for).

The reader sees a questions file and video files only. Of each question record it reads ``video_index``,
``question_index`` and ``question`` (the text): never a program, template id, answer or simulation. The question's
program comes from its text (:func:`craft_dsl.question_parsing.question_to_program`); the video is found by its
index written in six digits (``<id6>.mpg``, ``.mp4``, ... anywhere under the videos folders, or a file given by
path; folder names, which hold the scene id in the published layout, are not read), or named in a mapping file
(:func:`read_video_map`). The records, :class:`Question` and :class:`Answer`, and :func:`format_answer` live in
:mod:`craft_dsl.reader.records` and are importable from here.
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import CraftError, ReaderError
from ..files import read_json, read_text
from ..oracle.outcome import explain_invalid
from ..perception.distribution import answer_distributions
from ..perception.premise import premise_reading
from ..perception.schema import PerceivedScene
from ..perception.world import SceneModel
from ..program import Program
from ..question_parsing import question_to_program
from ..types import DslType
from .confidence import with_confidence
from .records import Answer, Question, format_answer
from .votes import VOTES, vote_counterfactuals

#: The containers a video may come in (every one PyAV decodes); of several files of one index, ``.mpg`` is taken.
VIDEO_SUFFIXES = (".mpg", ".mpeg", ".mp4", ".avi", ".mkv", ".webm", ".mov", ".gif")
#: The header line of a CSV mapping file.
VIDEO_MAP_HEADER = ("video_index", "path")


def _int_field(record: Mapping[str, Any], name: str, where: str) -> int:
    value = record.get(name)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ReaderError(f"{where}: field {name!r} must be an integer, got {value!r}")
    return value


def read_questions(path: str | os.PathLike[str]) -> list[Question]:
    """The questions of a ``dataset_minimal.json``-style file: a list of records with ``video_index``,
    ``question_index`` and ``question`` (other fields are not read)."""
    p = Path(path)
    data = read_json(p, "questions file")  # missing, a directory, not UTF-8, not JSON, too deep: InputFileError
    if not isinstance(data, list):
        raise ReaderError(f"{p}: expected a list of question records (as dataset_minimal.json), got "
                          f"{type(data).__name__}")
    out = []
    seen: set[tuple[int, int]] = set()
    for i, record in enumerate(data):
        where = f"{p}: record {i}"
        if not isinstance(record, Mapping):
            raise ReaderError(f"{where}: expected an object with video_index, question_index and question")
        vi = _int_field(record, "video_index", where)
        qi = _int_field(record, "question_index", where)
        text = record.get("question")
        if not isinstance(text, str) or not text.strip():
            raise ReaderError(f"{where}: field 'question' must be the question text, got {text!r}")
        if (vi, qi) in seen:
            raise ReaderError(f"{where}: question ({vi}, {qi}) is listed twice")
        seen.add((vi, qi))
        out.append(Question(vi, qi, text))
    return out


VideoSources = str | os.PathLike[str] | Sequence[str | os.PathLike[str]]
_INDEX = re.compile(r"[0-9]+")


def _suffixes() -> str:
    return f"{', '.join(VIDEO_SUFFIXES[:-1])} or {VIDEO_SUFFIXES[-1]}"


def _mapped_file(path_text: str, base: Path, where: str) -> Path:
    """The file a mapping entry names (relative to the mapping file's folder ``base``), which must exist."""
    target = base / path_text
    if target.is_dir():
        raise ReaderError(f"{where}: {target} is a folder; expected a video file")
    if not target.is_file():
        raise ReaderError(f"{where}: no such file {target} (a relative path is read from the folder of the "
                          f"mapping file, {base})")
    return target


def _map_index(text: str, where: str) -> int:
    if not _INDEX.fullmatch(text):
        raise ReaderError(f"{where}: video_index {text!r} is not a whole number; expected digits such as 12 or "
                          "000012")
    return int(text)


def read_video_map(path: str | os.PathLike[str]) -> dict[int, Path]:
    """The video file of each index a mapping file names: CSV with the header ``video_index,path`` (paths with a
    comma quoted), or JSON ``{"<video_index>": "path"}`` (a ``.json`` file). A relative path is relative to the
    mapping file's folder; every file named must exist, and each index may be named once."""
    p = Path(path)
    base = p.parent
    out: dict[int, Path] = {}
    if p.suffix.lower() == ".json":
        data = read_json(p, "video mapping file")
        if not isinstance(data, dict):
            raise ReaderError(f"--video-map {p}: expected a JSON object {{\"<video_index>\": \"path\", ...}}, got "
                              f"{type(data).__name__}")
        keys: dict[int, str] = {}
        for key, value in data.items():
            where = f"--video-map {p}: key {key!r}"
            index = _map_index(key, where)
            if index in keys:
                raise ReaderError(f"{where}: names video_index {index}, as key {keys[index]!r} does; each "
                                  "video_index may be mapped once")
            if not isinstance(value, str) or not value.strip():
                raise ReaderError(f"{where}: expected the video's path as a string, got {value!r}")
            keys[index] = key
            out[index] = _mapped_file(value.strip(), base, where)
        return out
    text = read_text(p, "video mapping file")
    rows = csv.reader(io.StringIO(text, newline=""))
    header = next(rows, None)
    if header is None:
        raise ReaderError(f"--video-map {p}: the file is empty; expected the header line video_index,path, then "
                          "one line per video (or a .json file {\"<video_index>\": \"path\"})")
    if tuple(c.strip() for c in header) != VIDEO_MAP_HEADER:
        raise ReaderError(f"--video-map {p}: line 1: header {','.join(header)!r}; expected video_index,path (a CSV "
                          "file; a JSON mapping needs the .json extension)")
    lines: dict[int, int] = {}
    for row in rows:
        if not row or (len(row) == 1 and not row[0].strip()):
            continue  # a blank line
        where = f"--video-map {p}: line {rows.line_num}"
        if len(row) != 2:
            raise ReaderError(f"{where}: {len(row)} fields; expected 2, video_index,path (quote a path that holds "
                              "a comma)")
        index = _map_index(row[0].strip(), where)
        if index in lines:
            raise ReaderError(f"{where}: video_index {index} is mapped again (first on line {lines[index]}); each "
                              "video_index may be mapped once")
        if not row[1].strip():
            raise ReaderError(f"{where}: the path is empty; expected the video's path")
        lines[index] = rows.line_num
        out[index] = _mapped_file(row[1].strip(), base, where)
    return out


def _listed(paths: Sequence[Path], most: int = 3) -> str:
    shown = ", ".join(map(str, paths[:most]))
    return shown if len(paths) <= most else f"{shown} and {len(paths) - most} more"


def find_videos(sources: VideoSources, indices: Sequence[int],
                video_map: str | os.PathLike[str] | None = None) -> dict[int, Path]:
    """The video file of each index: the one ``video_map`` names (:func:`read_video_map`), else ``<id6>`` with a
    suffix of :data:`VIDEO_SUFFIXES` anywhere under the folders of ``sources`` or among its files. Of several files
    of one index with different suffixes the ``.mpg`` is taken; other ties are refused, naming the files."""
    given = [sources] if isinstance(sources, (str, os.PathLike)) else list(sources)
    folders: list[Path] = []
    files: list[Path] = []
    by_stem: dict[str, dict[Path, Path]] = {}  # stem -> {resolved: as found}
    for source in given:
        p = Path(source)
        found: Iterable[Path]
        if p.is_dir():
            folders.append(p)
            found = (f for f in p.rglob("*") if f.suffix.lower() in VIDEO_SUFFIXES and f.is_file())
        elif p.is_file():
            if p.suffix.lower() not in VIDEO_SUFFIXES or not _INDEX.fullmatch(p.stem):
                raise ReaderError(f"--videos {p}: a video given by path is named by its video_index in six digits "
                                  f"with the suffix {_suffixes()} (e.g. 000012.mkv); name other files in a "
                                  "--video-map file")
            files.append(p)
            found = [p]
        else:
            raise ReaderError(f"--videos {p}: no such folder or file")
        for f in found:
            by_stem.setdefault(f.stem, {}).setdefault(f.resolve(), f)
    mapped = read_video_map(video_map) if video_map is not None else {}
    out: dict[int, Path] = {}
    missing: list[int] = []
    for index in indices:
        if index in mapped:
            out[index] = mapped[index]
            continue
        candidates = sorted(by_stem.get(f"{index:06d}", {}).values())
        if not candidates:
            missing.append(index)
            continue
        if len(candidates) > 1 and len({f.suffix.lower() for f in candidates}) == len(candidates):
            candidates = [f for f in candidates if f.suffix.lower() == ".mpg"] or candidates
        if len(candidates) > 1:
            raise ReaderError(f"video_index {index}: several files: {', '.join(map(str, candidates))}; keep one, or "
                              "name the one to read in a --video-map file")
        out[index] = candidates[0]
    if missing:
        index = missing[0]
        tried = []
        if folders:
            tried.append(f"{index:06d} with the suffix {_suffixes()} under {_listed(folders)} (searched "
                         "recursively)")
        if files:
            tried.append(f"the files given ({_listed(files)})")
        if video_map is not None:
            tried.append(f"--video-map {video_map} (no entry {index})")
        others = "" if len(missing) == 1 else \
            f"; {len(missing) - 1} other indices have no video either: {', '.join(map(str, missing[1:6]))}" + \
            (", ..." if len(missing) > 6 else "")
        raise ReaderError(f"no video for video_index {index}: tried {'; '.join(tried) or 'nothing (no --videos)'}"
                          f"{others}")
    return out


def answer_questions(scene: PerceivedScene, questions: Sequence[Question], distribution: bool = False,
                     samples: int = 64, seed: int = 0, confidence: bool = True, votes: int = VOTES) -> list[Answer]:
    """Answer each question over ``scene``: on its most likely world, or as the mode of its answer distribution
    (with that answer's probability) when ``distribution`` is set; a counterfactual question's answer is the
    majority of the replay and ``votes`` perturbed replays (:func:`vote_counterfactuals`; 0: the replay alone);
    with ``confidence``, each answer carries its confidence (:func:`craft_dsl.reader.confidence.with_confidence`).
    What the scene's ``meta["unchecked"]`` says could not be checked about the video goes to each answer's
    ``unchecked``."""
    model = SceneModel(scene)
    answers = _answer_questions(model, questions, distribution, samples, seed)
    unchecked = tuple(str(m) for m in (scene.meta or {}).get("unchecked", ()))
    if unchecked:  # what could not be checked about the video: every answer says so
        answers = [replace(a, unchecked=unchecked) for a in answers]
    if votes > 0:
        answers = vote_counterfactuals(model, answers, votes)
    if not confidence:
        return answers
    return with_confidence(scene, questions, answers, samples=samples, seed=seed, base=model)


def _answer_questions(model: SceneModel, questions: Sequence[Question], distribution: bool,
                      samples: int, seed: int) -> list[Answer]:
    sim = model.simulation()
    programs: list[Program | None] = []
    errors: list[str | None] = []
    for q in questions:
        try:
            programs.append(question_to_program(q.text))
            errors.append(None)
        except CraftError as err:
            programs.append(None)
            errors.append(f"question not understood: {err}")
    dists: dict[int, Any] = {}
    if distribution:
        valid = [i for i, p in enumerate(programs) if p is not None]
        computed = answer_distributions(model, [programs[i] for i in valid], samples=samples,  # type: ignore[misc]
                                        seed=seed)
        dists = dict(zip(valid, computed))
    out = []
    for i, (q, program) in enumerate(zip(questions, programs)):
        if program is None:
            out.append(Answer(q, None, error=errors[i]))
            continue
        if i in dists:
            d = dists[i]
            out.append(Answer(q, format_answer(d.mode), d.p(d.mode), str(program)))
            continue
        try:
            value = program.run(sim)
        except CraftError as err:
            out.append(Answer(q, fallback_answer(program), program=str(program), error=f"cannot be answered: {err}",
                              fallback=True))
            continue
        answer = format_answer(value)
        if answer is None:  # the objects it names are not in the most likely world: weigh every reading
            d = answer_distributions(model, [program], samples=samples, seed=seed)[0]
            answer = format_answer(d.mode)
            premise = None
            if answer is None:  # the question names an object no reading holds: the premise says which it is
                premise = premise_reading(model, program)
                answer = None if premise is None else format_answer(premise.value)
            if answer is None:
                where, why = explain_invalid(program, sim)
                out.append(Answer(q, fallback_answer(program), None, str(program),
                                  f"INVALID in every reading: {why}" + (f" (at {where})" if where else ""),
                                  fallback=True))
                continue
            if premise is not None:
                out.append(Answer(q, answer, None, str(program), premise=premise.describe()))
                continue
            out.append(Answer(q, answer, d.p(d.mode), str(program)))
            continue
        out.append(Answer(q, answer, None, str(program)))
    return out


#: The guess for a question that has no answer over the perceived scene, by the program's answer type.
FALLBACK = {DslType.BOOL: "False", DslType.INTEGER: "0", DslType.COLOR: "Gray", DslType.SHAPE: "Cube",
            DslType.SIZE: "Small"}


def fallback_answer(program: Program) -> str:
    """A guess of the program's answer type (predictions files hold an answer for every question)."""
    return FALLBACK.get(program.type, "False")


__all__ = ["FALLBACK", "VIDEO_MAP_HEADER", "VIDEO_SUFFIXES", "Answer", "Question", "answer_questions",
           "fallback_answer", "find_videos", "format_answer", "read_questions", "read_video_map"]
