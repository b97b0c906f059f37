"""Make docs/images/scenes.png: one frame (one second in) of four CRAFT scenes side by side.

    python examples/make_readme_picture.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from craft_dsl.physics import simulate
from craft_dsl.render import encode_png, frame

SCENES = (1, 2, 9, 13)
OUT = Path(__file__).resolve().parents[1] / "docs" / "images" / "scenes.png"


def main() -> None:
    tiles = [frame(simulate(scene, seed=1, steps=60), 60) for scene in SCENES]
    gap = np.full((256, 4, 3), 255, np.uint8)
    row = np.concatenate([t for tile in tiles for t in (tile, gap)][:-1], axis=1)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_bytes(encode_png(row))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
