"""How well programs() shrinks: for every module M, the planted failure "no program uses M" (over programs of M's
output type) and the size of the counterexample hypothesis reports, against the smallest program that uses M
(computed here from the registry).

The smallest program using M is M at the root with the smallest argument of each input type (a literal where
one may stand: ``EqualColor("gray", "gray")`` has 1 call, ``EventPartner(FilterFirst(Events()),
Unique(SceneAtStart()))`` 5). Printed per module: calls of the reported counterexample, calls of the smallest
program, and their ratio (1.00 = hypothesis found the smallest program); then the share of modules shrunk to
the smallest program and the mean and worst ratios. Deterministic (derandomized hypothesis).

    python benchmarks/strategies_shrinking.py [--modules Count,FilterFirst,...]
"""

from __future__ import annotations

import argparse
import re
import statistics
import time
from functools import partial

from hypothesis import find, settings

from craft_dsl import MODULES, REGISTRY, DslType, Program
from craft_dsl.strategies import programs
from craft_dsl.types import SIDE_INPUT_TYPES


def smallest_sizes() -> dict[str, int]:
    """Calls of the smallest program that uses each module."""

    def literal_allowed(spec_index: int, position: int) -> bool:
        expected = {ov.inputs[position] for ov in MODULES[spec_index].overloads}
        return expected == {DslType.INTEGER} or (len(expected) == 1 and expected <= set(SIDE_INPUT_TYPES))

    cost: dict[DslType, int] = {}
    changed = True
    while changed:
        changed = False
        for k, spec in enumerate(MODULES):
            for ov in spec.overloads:
                parts = [0 if literal_allowed(k, i) else cost.get(t) for i, t in enumerate(ov.inputs)]
                if any(p is None for p in parts):
                    continue
                total = 1 + sum(p for p in parts if p is not None)
                if total < cost.get(ov.output, 10**9):
                    cost[ov.output] = total
                    changed = True
    sizes = {}
    for k, spec in enumerate(MODULES):
        sizes[spec.name] = min(1 + sum(0 if literal_allowed(k, i) else cost[t] for i, t in enumerate(ov.inputs))
                               for ov in spec.overloads)
    return sizes


def _mentions(pattern: re.Pattern[str], program: Program) -> bool:
    """``program``'s text calls the module ``pattern`` matches."""
    return bool(pattern.search(str(program)))


def calls(program: Program) -> int:
    return str(program).count("(")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--modules", default="", help="comma-separated module names (default: every module)")
    args = parser.parse_args()
    names = [m for m in args.modules.split(",") if m] or [m.name for m in MODULES]
    smallest = smallest_sizes()
    quiet = settings(database=None, max_examples=1000, deadline=None, derandomize=True)
    ratios = []
    start = time.perf_counter()
    print(f"{'module':30s} {'found':>5s} {'least':>5s} {'ratio':>6s}  counterexample")
    for name in names:
        pattern = re.compile(rf"\b{name}\(")
        # programs of the module's output type: the smallest program using a module has it at the root, and
        # hypothesis draws unevenly enough that a few modules would need many examples of programs() first
        outputs = tuple(dict.fromkeys(ov.output for ov in REGISTRY[name].overloads))
        found = find(programs(outputs), partial(_mentions, pattern), settings=quiet)
        ratio = calls(found) / smallest[name]
        ratios.append(ratio)
        text = str(found).replace("\n", "; ")
        print(f"{name:30s} {calls(found):5d} {smallest[name]:5d} {ratio:6.2f}  {text}")
    optimal = sum(r == 1.0 for r in ratios)
    print(f"\n{optimal}/{len(ratios)} modules shrunk to the smallest program; ratio mean "
          f"{statistics.mean(ratios):.2f}, worst {max(ratios):.2f} ({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
