"""Atomic output: write to a temporary name beside the target, rename when complete."""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Iterator

from tankcd_cli.errors import InputError

# temporary outputs not yet renamed onto their targets or removed. A signal can land where a
# writer's ``finally`` never runs (inside contextlib's exit, before it resumes the writer), and
# the command exits without collecting garbage: the exit removes what is left here.
_PENDING: set = set()


# open ``committed_together`` blocks, innermost last: each collects its outputs' (temporary, target)
_GROUPS: list = []


def remove_pending() -> None:
    """Remove every temporary output still pending (at a command's exit: nothing is writing)."""
    for path in list(_PENDING):
        with contextlib.suppress(OSError):
            os.unlink(path)
        _PENDING.discard(path)


@contextlib.contextmanager
def atomic_path(target: str, suffix: str = "") -> Iterator[str]:
    """Yield a temporary path; on success it is renamed onto ``target``.

    ``target == "-"`` writes to a temporary file and copies it to stdout when
    complete (binary formats such as HDF5 cannot be streamed as they are built).
    On any error the temporary file is removed and ``target`` is left untouched,
    so no command leaves a truncated output behind.
    """
    to_stdout = target == "-"
    if to_stdout:
        import tempfile

        directory = tempfile.gettempdir()
    else:
        directory = os.path.dirname(os.path.realpath(target))
    if not to_stdout and not os.path.isdir(directory):
        raise InputError(target, "output directory does not exist")
    tmp = None
    try:
        with _signals_held():  # a signal between creating the file and noting it would leave it behind
            tmp = _create_beside(target, directory, suffix)
            _PENDING.add(tmp)
        yield tmp
        if to_stdout:
            import shutil

            with open(tmp, "rb") as src:
                shutil.copyfileobj(src, sys.stdout.buffer)
            sys.stdout.buffer.flush()
        elif _GROUPS:  # the block renames it with the others
            _GROUPS[-1].append((tmp, target))
            tmp = None
        else:
            os.replace(tmp, target)
    except OSError as exc:
        if isinstance(exc, BrokenPipeError):
            raise
        raise InputError(target, f"cannot write output: {exc.strerror or exc}") from None
    finally:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            _PENDING.discard(tmp)


@contextlib.contextmanager
def committed_together() -> Iterator[None]:
    """The outputs completed inside this block (``atomic_path``, ``output_text``) are renamed onto
    their targets together when it completes, with SIGINT and SIGTERM held back across the
    renames: a signal leaves all of them or none, and a failure of the block removes them all."""
    group: list = []
    _GROUPS.append(group)
    try:
        yield
        with _signals_held():
            for k, (tmp, target) in enumerate(group):
                try:
                    os.replace(tmp, target)
                except OSError as exc:
                    raise InputError(target, f"cannot write output: {exc.strerror or exc}") from None
                _PENDING.discard(tmp)
                group[k] = (None, target)
    finally:
        _GROUPS.remove(group)
        for tmp, _ in group:
            if tmp is not None:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(tmp)
                _PENDING.discard(tmp)


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT and SIGTERM back (they are delivered on leaving) where the platform can."""
    import signal

    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM}
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _create_beside(target: str, directory: str, suffix: str) -> str:
    """Create a new empty file with a fresh name in ``directory``; the usual permissions (0666
    less the umask), as a finished output should have. (tempfile's mkstemp would cost its
    imports on every command's start and make the file 0600.)"""
    for _ in range(100):
        tmp = os.path.join(directory, f".tankcd-{os.urandom(6).hex()}{suffix}.part")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp
        except FileExistsError:
            continue
        except OSError as exc:
            raise InputError(target, f"cannot write output: {exc.strerror or exc}") from None
    raise InputError(target, "cannot write output: no free temporary name beside it")


@contextlib.contextmanager
def output_text(target: str | None, suffix: str = "", newline: str | None = None) -> Iterator:
    """The one way a command writes a text output: ``None`` gives no stream (None), ``-`` standard
    output, anything else a file written beside the target and renamed onto it when complete
    (see ``atomic_path``: an error leaves the target untouched)."""
    if target is None:
        yield None
    elif target == "-":
        yield sys.stdout
        sys.stdout.flush()
    else:
        with atomic_path(target, suffix) as tmp:
            with open(tmp, "w", newline=newline) as fh:
                yield fh
