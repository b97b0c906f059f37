"""Command ``craft-dsl stats DIR``: statistics tables (CSV), charts (PNG, SVG) and the heuristic baselines.

Exit codes: 0 done; 2 not a dataset folder, unreadable file, or charts asked for without matplotlib.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from ..atomic import atomic_path


def cmd_stats(args: argparse.Namespace) -> int:
    from .folder import DatasetFolder
    from .stats import all_tables, format_baselines

    folder = DatasetFolder(args.dataset)
    out = Path(args.out) if args.out else folder.root / "stats"
    tables = all_tables(folder)
    written: list[Path] = []
    for table in tables:
        path = out / f"{table.name}.csv"
        with atomic_path(path) as tmp:
            tmp.write_text(table.to_csv(), encoding="utf-8")
        written.append(path)
    if not args.no_charts:
        from .charts import write_charts

        written += write_charts(tables, out)
    baselines = next(t for t in tables if t.name == "baselines")
    if args.json:
        print(json.dumps({"tables": {t.name: t.to_json() for t in tables}, "files": [str(p) for p in written]}))
    else:
        print(f"{len(folder.records)} questions; heuristic baselines, expected test accuracy (%):")
        print(format_baselines(baselines))
    print(f"wrote {len(written)} files to {out}", file=sys.stderr)
    return 0


def add_commands(sub: Any) -> None:
    p = sub.add_parser("stats", help="statistics of a dataset folder: CSV tables, charts, heuristic baselines",
                       description="Write the statistics of a CRAFT-format dataset folder (answers per template "
                                   "and per category, question types per scene, events per video, objects per "
                                   "scene, the paper's heuristic baselines per split beside its figures) as CSV "
                                   "and as PNG/SVG charts (docs/dataset-users.md).")
    p.add_argument("dataset", help="dataset folder (holds dataset_minimal.json, split_info_*.json, annotations.json)")
    p.add_argument("--out", help="output folder (default: DATASET/stats)")
    p.add_argument("--no-charts", action="store_true", help="CSV only (the charts need matplotlib: pip install "
                                                          "'craft-dsl[stats]')")
    p.add_argument("--json", action="store_true", help="print every table as JSON")
    p.set_defaults(func=cmd_stats)
