"""The two edits tools/box2d128/build.sh makes to box2d-py 2.3.8's source: polygons of up to 128 vertices (the
original CRAFT simulator's Box2D setting), and the distribution's name and version (box2d 2.3.10+craft128, which
craft-dsl's requirement box2d==2.3.10 accepts). Each edit must apply exactly once: a source that differs stops the
build with the file and what was looked for.

Usage: python edit_source.py SOURCE_DIR VERSION
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

EDITS: tuple[tuple[str, str, str], ...] = (
    ("Box2D/Common/b2Settings.h", r"(#define b2_maxPolygonVertices\s+)16\b", r"\g<1>128"),
    ("setup.py", r'name(\s*)=(\s*)"box2d-py"', r'name\1=\2"box2d"'),
    ("setup.py", r"version(\s*)=(\s*)version_str,", r'version\1=\2"{version}",'),
)


def edit(source: Path, version: str) -> None:
    for relative, pattern, replacement in EDITS:
        path = source / relative
        text = path.read_text()
        new, count = re.subn(pattern, replacement.format(version=version), text)
        if count != 1:
            raise SystemExit(f"edit_source.py: error: {path}: expected one match of {pattern!r}, found {count}")
        path.write_text(new)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    edit(Path(sys.argv[1]), sys.argv[2])
