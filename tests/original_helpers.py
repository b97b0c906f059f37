"""What the tests that drive the original CRAFT simulator share: the mark that skips them, saying how to build it."""

from __future__ import annotations

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
