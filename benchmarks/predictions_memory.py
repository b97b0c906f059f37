"""Peak memory of scoring a large predictions file, as a ratio to the file's size.

Writes a questions file of the paper's size (57,524 questions over 9,917 videos, ``dataset_minimal.json``) and a
predictions file of ``--mb`` megabytes (default 200: about ten million answers, the questions' own and the rest
for questions the file does not have), then scores it in a fresh subprocess per measurement and reads the peak
resident memory (``resource.getrusage``) of that process:

* ``score``: ``craft_dsl.verify.score`` with the path (the predictions are read as a stream);
* ``imports``: the same process reading only the questions (what any run costs before the predictions);
* ``json.load`` (baseline, same run): parsing the predictions file whole with the json module, which is what the
  scorer did before it streamed (``--no-baseline`` skips it: it needs about 3 GB).

``--forms object,array,jsonl`` measures the three file forms; ``--compare-readers`` also times the two streaming
readers over the object form: ijson (used) and the byte-offset indexer of ``craft_dsl.verify.annotations``.

    python benchmarks/predictions_memory.py [--mb 200] [--forms object] [--no-baseline] [--compare-readers]
"""

from __future__ import annotations

import argparse
import json
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

QUESTIONS = 57_524
VIDEOS = 9_917
ANSWERS = ("True", "False", "0", "1", "2", "3", "red", "blue", "cube", "circle", "small", "large")

_MEASURE = r"""
import json, resource, sys, time
kind, questions, predictions = sys.argv[1:4]
start = time.perf_counter()
if kind == "score":
    from craft_dsl.verify import score
    report = score(questions, predictions)
    extra = {"scored": report.total, "unknown": report.unknown_count, "accuracy": report.columns["All"].accuracy}
elif kind == "imports":
    from craft_dsl.verify import read_questions
    extra = {"questions": len(read_questions(questions))}
elif kind == "json.load":
    from craft_dsl.verify import read_questions
    read_questions(questions)
    with open(predictions, encoding="utf-8") as fh:
        data = json.load(fh)
    extra = {"entries": len(data)}
elif kind == "reader:ijson":
    from craft_dsl.jsonstream import iter_members
    extra = {"entries": sum(1 for _ in iter_members(predictions, "predictions file"))}
elif kind == "reader:indexer":
    from craft_dsl.verify.annotations import index_json_object
    extra = {"entries": len(index_json_object(predictions))}
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"peak": peak, "seconds": seconds, **extra}))
"""


def write_questions(path: Path, rng: random.Random) -> list[tuple[int, int, str]]:
    """A dataset_minimal.json of QUESTIONS questions; returns (video_index, question_index, answer) of each."""
    from craft_dsl.templates import templates

    ids = sorted(templates())
    records, keys = [], []
    for n in range(QUESTIONS):
        video, index = n % VIDEOS, n // VIDEOS
        answer = rng.choice(ANSWERS)
        records.append({"question": "", "answer": answer, "template_id": ids[n % len(ids)], "video_index": video,
                        "question_index": index})
        keys.append((video, index, answer))
    path.write_text(json.dumps(records), encoding="utf-8")
    return keys


def write_predictions(path: Path, form: str, megabytes: float, keys: list[tuple[int, int, str]],
                      rng: random.Random) -> int:
    """A predictions file of about ``megabytes`` MB: every question (half of them right), then predictions for
    questions beyond the file's videos. Returns the number of entries."""
    limit = int(megabytes * 1e6)

    def entries() -> Any:
        for video, index, answer in keys:
            yield video, index, answer if rng.random() < 0.5 else rng.choice(ANSWERS)
        n = 0
        while True:
            yield VIDEOS + n // 1000, n % 1000, rng.choice(ANSWERS)
            n += 1

    size = count = 0
    with path.open("w", encoding="utf-8") as fh:
        fh.write({"object": "{", "array": "[", "jsonl": ""}[form])
        for video, index, answer in entries():
            if form == "object":
                text = f'"{video}_{index}": "{answer}"'
            else:
                text = json.dumps({"video_index": video, "question_index": index, "answer": answer})
            sep = "\n" if form == "jsonl" else ("" if count == 0 else ", ")
            fh.write(sep + text)
            size += len(sep) + len(text)
            count += 1
            if size >= limit:
                break
        fh.write({"object": "}\n", "array": "]\n", "jsonl": "\n"}[form])
    return count


def measure(kind: str, questions: Path, predictions: Path) -> dict[str, Any]:
    out = subprocess.run([sys.executable, "-c", _MEASURE, kind, str(questions), str(predictions)],
                         capture_output=True, text=True, check=True)
    result: dict[str, Any] = json.loads(out.stdout)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mb", type=float, default=200.0, help="size of the predictions file in MB (default 200)")
    parser.add_argument("--forms", default="object", help="file forms to measure: object,array,jsonl (default object)")
    parser.add_argument("--no-baseline", action="store_true", help="skip the json.load baseline (about 3 GB)")
    parser.add_argument("--compare-readers", action="store_true", help="also time ijson against the indexer")
    parser.add_argument("--seed", type=int, default=0, help="seed of the generated answers (default 0)")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        questions = folder / "dataset_minimal.json"
        keys = write_questions(questions, rng)
        for form in args.forms.split(","):
            predictions = folder / f"predictions.{'jsonl' if form == 'jsonl' else 'json'}"
            started = time.perf_counter()
            count = write_predictions(predictions, form, args.mb, keys, rng)
            size = predictions.stat().st_size
            print(f"{form}: {size / 1e6:.0f} MB, {count:,} predictions ({QUESTIONS:,} questions), written in "
                  f"{time.perf_counter() - started:.0f} s")
            base = measure("imports", questions, predictions)
            run = measure("score", questions, predictions)
            print(f"  imports + questions : peak {base['peak'] / 1e6:7.0f} MB")
            print(f"  score (streaming)   : peak {run['peak'] / 1e6:7.0f} MB = {run['peak'] / size:.2f}x the file "
                  f"({(run['peak'] - base['peak']) / size:.2f}x above the imports), {run['seconds']:.1f} s, "
                  f"{run['unknown']:,} unknown predictions, accuracy {run['accuracy']:.1f} %")
            if not args.no_baseline and form != "jsonl":
                old = measure("json.load", questions, predictions)
                print(f"  json.load (baseline): peak {old['peak'] / 1e6:7.0f} MB = {old['peak'] / size:.2f}x the file, "
                      f"{old['seconds']:.1f} s; streaming needs {run['peak'] / old['peak']:.2f}x its memory")
            if args.compare_readers and form == "object":
                fast = measure("reader:ijson", questions, predictions)
                slow = measure("reader:indexer", questions, predictions)
                print(f"  readers: ijson {fast['seconds']:.1f} s (peak {fast['peak'] / 1e6:.0f} MB), byte-offset "
                      f"indexer {slow['seconds']:.1f} s (peak {slow['peak'] / 1e6:.0f} MB): ijson takes "
                      f"{fast['seconds'] / slow['seconds']:.2f}x the time")
            predictions.unlink()


if __name__ == "__main__":
    main()
