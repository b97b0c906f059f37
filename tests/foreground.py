"""Start a command as a terminal starts a foreground job, whatever the test run inherited.

A shell without job control (``pytest ... &`` in a script, some CI runners) starts its background commands with
SIGINT ignored; a child inherits that, and Python then keeps ignoring Ctrl-C. Tests that send Ctrl-C to a command
start it through :func:`restore_ctrl_c` so that they test the command, not how the test run was launched.
"""

from __future__ import annotations

import signal


def restore_ctrl_c() -> None:
    """``preexec_fn`` for ``subprocess.Popen``: Ctrl-C (SIGINT) back to its default action in the child."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
