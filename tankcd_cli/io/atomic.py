"""Atomic output: write to a temporary name beside the target, rename when complete."""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Iterator

from tankcd_cli.errors import InputError


@contextlib.contextmanager
def atomic_path(target: str, suffix: str = "") -> Iterator[str]:
    """Yield a temporary path; on success it is renamed onto ``target``.

    ``target == "-"`` writes to a temporary file and copies it to stdout when
    complete (binary formats such as HDF5 cannot be streamed as they are built).
    On any error the temporary file is removed and ``target`` is left untouched,
    so no command leaves a truncated output behind.
    """
    to_stdout = target == "-"
    directory = tempfile.gettempdir() if to_stdout else str(Path(target).resolve().parent)
    if not to_stdout and not os.path.isdir(directory):
        raise InputError(target, "output directory does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".tankcd-", suffix=suffix + ".part", dir=directory)
    except OSError as exc:
        raise InputError(target, f"cannot write output: {exc.strerror or exc}") from None
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a finished output gets the usual permissions
    try:
        yield tmp
        if to_stdout:
            with open(tmp, "rb") as src:
                shutil.copyfileobj(src, sys.stdout.buffer)
            sys.stdout.buffer.flush()
        else:
            os.replace(tmp, target)
    except OSError as exc:
        if isinstance(exc, BrokenPipeError):
            raise
        raise InputError(target, f"cannot write output: {exc.strerror or exc}") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
