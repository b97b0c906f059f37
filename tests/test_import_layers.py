"""The import graph of craft_dsl (tools/import_layers.py): no cycles, back-up imports only the documented ones."""

from __future__ import annotations

from pathlib import Path

from tests.script_module import load_script

ROOT = Path(__file__).resolve().parent.parent
layers = load_script(ROOT / "tools" / "import_layers.py", "import_layers")


def test_the_graph_sees_lazy_and_type_checking_imports() -> None:
    edges = layers.graph()
    assert "craft_dsl.physics.original" in edges["craft_dsl.physics.live"]  # inside a function and TYPE_CHECKING
    assert "craft_dsl.reader.video" in edges["craft_dsl.dataset.layout"]  # inside a function


def test_cycles_are_found() -> None:
    assert layers.cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycles() -> None:
    assert layers.cycles(layers.graph()) == []


def test_every_module_is_in_a_layer() -> None:
    for module in layers.graph():
        layers.layer_of(module)  # raises for a module in no layer


def test_back_up_imports_are_exactly_the_allowed_ones() -> None:
    assert layers.back_up(layers.graph()) == sorted(layers.ALLOWED_BACK_UP)


def test_architecture_doc_shows_the_layers_and_the_allowed_imports() -> None:
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert layers.layer_table() in text, "regenerate with python tools/import_layers.py"
    assert layers.allowed_list() in text, "regenerate with python tools/import_layers.py"
