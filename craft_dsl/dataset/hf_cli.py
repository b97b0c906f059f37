"""Command ``craft-dsl hf DIR``: (re)write the Hugging Face files of a dataset folder (JSONL, Parquet, card).

``craft-dsl generate`` writes them already; this command makes them for a folder written before, or for the
published CRAFT dataset. Exit codes: 0 done; 2 not a dataset folder, or ``--parquet`` without pyarrow.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any


def cmd_hf(args: argparse.Namespace) -> int:
    from .hf import write_hf

    parquet = True if args.parquet else False if args.no_parquet else None
    result = write_hf(args.dataset, parquet=parquet)
    if args.json:
        print(json.dumps({"files": list(result.files), "counts": result.counts, "parquet": result.parquet}))
    else:
        for split, parts in result.counts.items():
            print(f"{split}: " + ", ".join(f"{part} {n}" for part, n in parts.items()))
        print(f"load it: datasets.load_dataset({str(args.dataset)!r}, 'random')")
    print(f"wrote {len(result.files)} files" + _jsonl_only_note(result.parquet, args.no_parquet), file=sys.stderr)
    return 0


def _jsonl_only_note(parquet: bool, no_parquet: bool) -> str:
    """Why no Parquet file was written, and how to get them."""
    if parquet:
        return ""
    if no_parquet:
        return " (JSONL only, as asked)"
    return " (JSONL only: no pyarrow; pip install 'craft-dsl[hf]' adds Parquet)"


def add_commands(sub: Any) -> None:
    p = sub.add_parser("hf", help="write the Hugging Face files of a dataset folder (JSONL, Parquet, card)",
                       description="Write hf/<split>/<part>.jsonl (and .parquet) for the random and hard splits "
                                   "and the dataset card README.md, so that datasets.load_dataset(DIR, 'random') "
                                   "loads the folder offline (docs/dataset-users.md).")
    p.add_argument("dataset", help="dataset folder (holds dataset_minimal.json, dataset.json, split_info_*.json)")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--parquet", action="store_true",
                       help="require Parquet (needs pyarrow: pip install 'craft-dsl[hf]'); without --parquet or "
                            "--no-parquet: Parquet when pyarrow is installed")
    group.add_argument("--no-parquet", action="store_true", help="JSONL only")
    p.add_argument("--json", action="store_true", help="print what was written as JSON")
    p.set_defaults(func=cmd_hf)
