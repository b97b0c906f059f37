"""Start a command as a terminal starts a foreground job, whatever the test run inherited.

A shell without job control (``pytest ... &`` in a script, some CI runners) starts its background commands with
SIGINT ignored; a child inherits that, and Python then keeps ignoring Ctrl-C. Tests that send Ctrl-C to a command
start it through :func:`popen_foreground` so that they test the command, not how the test run was launched.

No ``preexec_fn``: Python code between fork and exec, in a process with other threads, frees those threads'
thread-local objects in the child, which can hang it. Instead SIGINT gets a handler in this process while the
child starts; exec resets a handled signal to its default action, where an ignored one stays ignored.
"""

from __future__ import annotations

import signal
import subprocess
import threading
from typing import Any


def popen_foreground(cmd: list[str], **kwargs: Any) -> subprocess.Popen[Any]:
    """``subprocess.Popen(cmd, **kwargs)`` with Ctrl-C (SIGINT) at its default action in the child."""
    if threading.current_thread() is not threading.main_thread():
        raise RuntimeError("popen_foreground sets a signal handler: call it from the main thread")
    previous = signal.getsignal(signal.SIGINT)
    if previous is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return subprocess.Popen(cmd, **kwargs)
    finally:
        signal.signal(signal.SIGINT, previous)
