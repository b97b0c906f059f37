"""The import graph of craft_dsl: cycles and imports that run back up the layers.

Every import counts: top-level, inside functions (lazy) and under ``TYPE_CHECKING``. ``python
tools/import_layers.py`` prints the cycles, the back-up imports and the layer table of docs/architecture.md;
tests/test_import_layers.py asserts that there are no cycles, that the back-up imports are exactly
``ALLOWED_BACK_UP`` and that the table in the docs is the one printed here.
"""

from __future__ import annotations

import ast
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "craft_dsl"

# The layers, lowest first: a module may import modules of its own layer or lower ones. A name is a top-level
# module or a subpackage of craft_dsl; ``*/cli`` and ``*_cli`` are the command modules of every package (they
# share the main CLI's helpers). The package ``__init__`` files (public re-exports) are outside the order.
LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "core",
        (
            "errors", "files", "jsonstream", "atomic", "vocabulary", "synonyms", "ranges", "progress", "parallel",
            "pool", "resources", "cluster", "world", "types", "simulation",
        ),
    ),
    (
        "language",
        (
            "registry", "semantics", "ir", "syntax", "tokens", "lark_parser", "checker", "nodes", "parser",
            "evaluator", "program", "templates", "question_parsing",
        ),
    ),
    ("simulation", ("physics", "scenes", "render", "recorded")),
    ("verify", ("verify",)),
    ("judging", ("analysis", "oracle", "perception")),
    ("dataset", ("dataset",)),
    ("applications", ("reader", "harness", "torch", "viewer", "demo", "strategies", "hypothesis_hook")),
    ("commands", ("cli", "__main__", "*/cli", "*_cli")),
)

# Imports that run back up the layers today, each with why (importer, imported module): all lazy, inside functions.
ALLOWED_BACK_UP: Mapping[tuple[str, str], str] = {
    ("craft_dsl.dataset.heldout", "craft_dsl.dataset.cli"):
        "the held-out report draws its bars with the command's bar renderer (`_Bars`)",
    ("craft_dsl.dataset.layout", "craft_dsl.reader.video"):
        "media of original-simulator runs are cut from the original's MPEG-1, decoded by the reader's decoder",
    ("craft_dsl.harness.lmms_reader", "craft_dsl.reader.cli"):
        "the reader as an lmms-eval model reads videos and picks engines as `craft-dsl read` does",
}


def module_name(path: Path) -> str:
    """The dotted module name of a file of the package."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(importer: str, is_package: bool, level: int, module: str | None) -> str:
    base = importer.split(".")
    if not is_package:
        base = base[:-1]
    if level > 1:
        base = base[: len(base) - (level - 1)]
    return ".".join(base + ([module] if module else []))


def imports(path: Path, modules: set[str]) -> Iterator[str]:
    """Every craft_dsl module the file imports, wherever the import statement is."""
    name = module_name(path)
    is_package = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(name, is_package, node.level, node.module) if node.level else node.module or ""
            # ``from package import module`` imports the module; ``from module import name`` the module.
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target.startswith("craft_dsl.") and target != name:
                yield target


def graph() -> dict[str, set[str]]:
    """Module -> the craft_dsl modules it imports."""
    files = sorted(PACKAGE.rglob("*.py"))
    modules = {module_name(path) for path in files}
    return {module_name(path): set(imports(path, modules)) for path in files}


def cycles(edges: Mapping[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(edges.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    sys.setrecursionlimit(max(10_000, sys.getrecursionlimit()))
    for node in sorted(edges):
        if node not in index:
            visit(node)
    return sorted(found)


def unit(module: str) -> str | None:
    """The layered unit of a module (its top-level module or subpackage); None for ``craft_dsl`` itself."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def layer_of(module: str) -> int | None:
    """The layer index of a module; None for the package's ``__init__`` files (public re-exports)."""
    name = unit(module)
    if name is None or module == f"craft_dsl.{name}" and (PACKAGE / name / "__init__.py").exists():
        return None
    last = module.rpartition(".")[2]
    if last.endswith("_cli") or last == "cli" and module != "craft_dsl.cli":
        name = "*_cli" if last.endswith("_cli") else "*/cli"
    for position, (_, members) in enumerate(LAYERS):
        if name in members:
            return position
    raise ValueError(f"{module} is in no layer; add it to LAYERS in tools/import_layers.py")


def back_up(edges: Mapping[str, set[str]]) -> list[tuple[str, str]]:
    """Imports from a lower layer to a higher one, sorted."""
    found = []
    for importer, imported in sorted((a, b) for a, targets in edges.items() for b in targets):
        low, high = layer_of(importer), layer_of(imported)
        if low is not None and high is not None and high > low:
            found.append((importer, imported))
    return found


def layer_table() -> str:
    """The Markdown table of the layers for docs/architecture.md."""
    rows = ["| layer | modules and packages (each may import its own layer and the layers above it here) |",
            "|---|---|"]
    for name, members in LAYERS:
        rows.append(f"| {name} | {', '.join(f'`{member}`' for member in members)} |")
    return "\n".join(rows)


def allowed_list() -> str:
    """The Markdown list of the allowed back-up imports for docs/architecture.md."""
    return "\n".join(f"* `{a}` -> `{b}`: {why}." for (a, b), why in sorted(ALLOWED_BACK_UP.items()))


def main() -> int:
    """Print the cycles, the back-up imports and the layer table; exit 1 on a cycle or an unlisted back-up."""
    edges = graph()
    found_cycles = cycles(edges)
    found_back_up = back_up(edges)
    for component in found_cycles:
        print("cycle:", " <-> ".join(component))
    for importer, imported in found_back_up:
        mark = "allowed" if (importer, imported) in ALLOWED_BACK_UP else "NEW"
        print(f"back-up ({mark}): {importer} -> {imported}")
    print(layer_table())
    print()
    print(allowed_list())
    unlisted = set(found_back_up) - set(ALLOWED_BACK_UP)
    return 1 if found_cycles or unlisted else 0


if __name__ == "__main__":
    raise SystemExit(main())
