"""Opening input files with one clear message for each way it can fail."""

from __future__ import annotations

import io
import os
import stat
import sys

from tankcd_cli.errors import InputError


def open_input(path: str, text: bool = False):
    """(name, stream) for ``path``; '-' is standard input. Text streams are UTF-8 with or without BOM."""
    if path == "-":
        stream = sys.stdin.buffer
        return "<stdin>", io.TextIOWrapper(stream, encoding="utf-8-sig", newline="") if text else stream
    if os.path.isdir(path):
        raise InputError(path, "is a directory, not a file")
    try:
        return path, open(path, encoding="utf-8-sig", newline="") if text else open(path, "rb")
    except FileNotFoundError:
        raise InputError(path, "no such file") from None
    except PermissionError:
        raise InputError(path, "permission denied") from None
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None


def same_path(a: str, b: str) -> bool:
    """Whether two paths name the same file: equal once resolved, or (both existing) the same inode."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def is_character_device(path: str) -> bool:
    """Whether ``path`` names a character device (/dev/null, a terminal), following links."""
    try:
        return stat.S_ISCHR(os.stat(path).st_mode)
    except OSError:
        return False


def read_bytes(path: str, name: str) -> bytes:
    """The whole content of ``path`` ('-': standard input); ``name`` is how errors name it."""
    _, stream = open_input(path)
    try:
        return stream.read()
    except OSError as exc:
        raise InputError(name, f"cannot read: {exc.strerror or exc}") from None
    finally:
        if path != "-":
            stream.close()
