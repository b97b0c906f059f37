"""What the tests that drive the original CRAFT simulator share: the mark that skips them, saying how to build it,
and stand-ins for its binary."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from craft_dsl.physics import original as orig
from craft_dsl.physics.original import OriginalSimulatorError


def _built() -> bool:
    try:
        orig.find_binary()
    except OriginalSimulatorError:
        return False
    return True


needs_binary = pytest.mark.skipif(
    not _built(), reason="the original simulator is not built: run `bash tools/original/build.sh` (needs "
                         "../shared/original-craft/ and Debian packages; .ci/run does it)")


def stand_in(tmp_path: Path, body: str) -> Path:
    """A fake simulator: a shell script that gets the controller file as $1."""
    folder = tmp_path / "fake" / "run"
    folder.mkdir(parents=True, exist_ok=True)
    script = folder / "Testbed"
    script.write_text("#!/bin/sh\n" + body + "\n")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script
