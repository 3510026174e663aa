"""SIGTERM answered within a grace period even where Python cannot answer it (the compiled
``_exit_guard``; see ``guard_termination``).

Python runs a signal's handler only when the main thread next executes Python code: a compiled
kernel or a library call (a convolution, a warp) keeps it away for as long as it runs, and a
thread pool's shutdown or the interpreter's exit waits for its workers. The guard's handler runs
in C when SIGTERM arrives: it passes the signal on to Python's handler (the run ends as usual
when it can) and sets a 1 s alarm; if the process still runs when the alarm rings, the alarm's
handler removes the temporary outputs registered here (``io.atomic`` registers each one it
creates) and exits with 143, as a run ended by SIGTERM does.
"""

from __future__ import annotations

import os

from tankcd_cli.io.atomic import pending_paths

try:
    from tankcd_cli.io._exit_guard import install as _install, track as _track, tracked as _tracked, \
        untrack as _untrack
except ImportError:  # not built: SIGTERM is Python's alone
    _install = None

_INSTALLED: list = []


def guard_termination(grace_seconds: int = 1) -> bool:
    """Install the guard in front of the SIGTERM handler Python has (the command line installs its
    own first); the temporary outputs already pending are registered. False where the guard is
    not built or cannot chain that handler."""
    if _install is None or not _install(grace_seconds):
        return False

    _INSTALLED.append(True)
    for path in pending_paths():
        track(path)
    return True


def track(path: str) -> None:
    """A temporary output the forced exit removes (128 at a time; beyond, the run's own clean-up and
    the next run's clearing of dead parts still apply)."""
    if _INSTALLED:
        _track(os.fsencode(path))


def untrack(path: str) -> None:
    """A temporary output renamed onto its target or removed: no longer the forced exit's."""
    if _INSTALLED:
        _untrack(os.fsencode(path))


def tracked() -> list:
    """The registered temporary outputs (for tests)."""
    return [os.fsdecode(p) for p in _tracked()] if _INSTALLED else []
