"""How long `import craft_dsl` takes, against a bare interpreter start measured in the same run.

    python benchmarks/import_time.py [--repeat 15]

Printed: the best wall time of ``python -c "import craft_dsl"`` and of ``python -c "pass"`` over the runs, and
the import's own cost (the difference; target <= 0.15 s). Heavy libraries (networkx, numpy, pydantic, lark,
pymunk) load on first use, and tests/test_imports.py checks that a plain import does not load them.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time


def best(code: str, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    bare = best("pass", args.repeat)
    full = best("import craft_dsl", args.repeat)
    print(f"python -c pass              : {bare:.3f} s")
    print(f"python -c 'import craft_dsl': {full:.3f} s")
    print(f"import craft_dsl itself     : {full - bare:.3f} s   (target <= 0.15 s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
