"""`import craft_dsl` stays light: heavy libraries load when a feature first needs them."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("networkx", "numpy", "pydantic", "lark", "pymunk", "Box2D", "imageio_ffmpeg", "tqdm")


def _loaded_after(code: str) -> list[str]:
    probe = f"{code}\nimport sys\nprint(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    return out.split()


def test_plain_import_loads_no_heavy_library() -> None:
    assert _loaded_after("import craft_dsl") == []


def test_parsing_and_running_text_needs_no_heavy_library() -> None:
    code = ("import craft_dsl\np = craft_dsl.parse('Count(FilterDynamic(SceneAtStart()))')\n"
            "p.to_tokens(); craft_dsl.Program.from_tokens(p.to_tokens())")
    assert _loaded_after(code) == []


def test_features_load_their_libraries_on_first_use() -> None:
    assert "pydantic" in _loaded_after("import craft_dsl\ncraft_dsl.load_simulation('tests/data/e1.json')")
    assert "lark" in _loaded_after("import craft_dsl\ncraft_dsl.parse('Var X = SceneAtStart()\\nCount(X)')")
