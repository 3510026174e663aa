"""Outputs: a regular file is written to a temporary name beside it and renamed onto it when
complete; standard output, a named pipe, a character device or a process substitution
(``/dev/stdout``, ``/dev/fd/N``) is written in place, never replaced (docs/formats.md).

Temporary names are ``.tankcd-HOST-PID-RANDOM[suffix].part``: a run that creates one in a folder
first removes that folder's parts left by dead processes of the same host (a run killed by
SIGKILL, whose clean-up never ran).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import stat
import sys
import tempfile
from typing import Iterator

from tankcd_cli.errors import InputError

# temporary outputs not yet renamed onto their targets or removed. A signal can land where a
# writer's ``finally`` never runs (inside contextlib's exit, before it resumes the writer), and
# the command exits without collecting garbage: the exit removes what is left here.
_PENDING: set = set()


# open ``committed_together`` blocks, innermost last: each collects its outputs' (temporary, target, how)
_GROUPS: list = []

# open ``atomic_path`` blocks' (temporary, target), innermost last: whose an OSError is
_OPEN: list = []

# folders whose stale parts this process has cleared (once each)
_CLEARED: set = set()

_PART_PREFIX = ".tankcd-"

# paths that name one of this process's open files: written in place whatever they resolve to
_IN_PLACE_PREFIXES = ("/dev/stdout", "/dev/stderr", "/dev/fd/", "/proc/self/fd/")


def remove_pending() -> None:
    """Remove every temporary output still pending (at a command's exit: nothing is writing)."""
    for path in list(_PENDING):
        with contextlib.suppress(OSError):
            os.unlink(path)
        _forget(path)


def writes_in_place(target: str) -> bool:
    """Whether ``target`` is written in place (opened and written, never replaced): ``-``, a path
    naming one of the process's open files (``/dev/stdout``, ``/dev/fd/N``: a process
    substitution), or an existing file that is not a regular file nor a folder (a named pipe, a
    character device). A block device or a folder is refused (``InputError``) where written."""
    if target == "-":
        return True
    if os.path.abspath(target).startswith(_IN_PLACE_PREFIXES):
        return True
    try:
        mode = os.stat(target).st_mode
    except OSError:
        return False
    return not stat.S_ISREG(mode) and not stat.S_ISDIR(mode)


def _check_target(target: str) -> None:
    """InputError for a target no output may be written to: a folder, a block device (a disk)."""
    try:
        mode = os.stat(target).st_mode
    except OSError:
        return
    if stat.S_ISDIR(mode):
        raise InputError(target, "is a directory, not a file")
    if stat.S_ISBLK(mode):
        raise InputError(target, "is a block device: not written as an output")


def check_folders(*targets: str | None) -> None:
    """InputError naming the first of ``targets`` that cannot be written: its folder missing, or
    the target a folder or a block device. Called before any work, so that a run whose last
    output could not be written does not start (and leaves nothing)."""
    for target in targets:
        if not target or target == "-":
            continue
        _check_target(target)
        if writes_in_place(target):
            continue
        if not os.path.isdir(os.path.dirname(os.path.realpath(target))):
            raise InputError(target, "output directory does not exist")


def _write_error(target: str, exc: OSError) -> InputError:
    return InputError(target, f"cannot write output: {exc.strerror or exc}")


@contextlib.contextmanager
def atomic_path(target: str, suffix: str = "") -> Iterator[str]:
    """Yield a temporary path to write the whole output to; when the block completes it goes to
    ``target``: renamed onto a regular file (or a new name), copied into a target written in
    place (``writes_in_place``: ``-`` is standard output; binary formats such as HDF5, PNG or
    Parquet are built whole and then copied). Inside ``committed_together`` that happens when the
    outermost block completes. On any error the temporary file is removed and ``target`` is left
    untouched, so no command leaves a truncated output behind. An OSError of the block is named
    as this target's unless its ``filename`` is another open output's."""
    _check_target(target)
    in_place = writes_in_place(target)
    if in_place:
        directory = tempfile.gettempdir()
    else:
        directory = os.path.dirname(os.path.realpath(target))
        if not os.path.isdir(directory):
            raise InputError(target, "output directory does not exist")
    tmp = None
    entry = None
    try:
        with _signals_held():  # a signal between creating the file and noting it would leave it behind
            tmp = _create_beside(target, directory, suffix)
            _remember(tmp)
        entry = (tmp, target)
        _OPEN.append(entry)
        try:
            yield tmp
        except OSError as exc:
            if isinstance(exc, BrokenPipeError) or _owned_elsewhere(exc, entry):
                raise
            raise _write_error(target, exc) from None
        finally:
            _OPEN.remove(entry)
        # renamed onto the file a link names (the link stays), copied into one written in place
        done = [tmp, target, "copy"] if in_place else [tmp, target, os.path.realpath(target)]
        if _GROUPS:  # the block renames it with the others
            _GROUPS[-1].append(done)
            tmp = None
        else:
            _commit([done])
            tmp = None
    finally:
        if tmp is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            _forget(tmp)


def _owned_elsewhere(exc: OSError, entry: tuple) -> bool:
    """Whether ``exc`` names another open output's temporary or target (that block names it)."""
    names = {n for n in (getattr(exc, "filename", None), getattr(exc, "filename2", None)) if n}
    if not names or entry[0] in names or entry[1] in names:
        return False
    return any(tmp in names or target in names for tmp, target in _OPEN if (tmp, target) != entry)


def _commit(entries: list) -> None:
    """Outputs to their targets: first the copies into targets written in place (a reader may take
    its time: SIGINT and SIGTERM stay free), then the renames with SIGINT and SIGTERM held back:
    a signal leaves all of them or none. Each done entry's temporary becomes None. An entry is
    [temporary, target, "copy" or the path to rename onto]."""
    for entry in entries:
        tmp, target, how = entry
        if tmp is None or how != "copy":
            continue
        _copy_into(tmp, target)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        _forget(tmp)
        entry[0] = None
    with _signals_held():
        for entry in entries:
            tmp, target, how = entry
            if tmp is None:
                continue
            try:
                os.replace(tmp, how)
            except OSError as exc:
                raise _write_error(target, exc) from None
            _forget(tmp)
            entry[0] = None


def _copy_into(tmp: str, target: str) -> None:
    """A complete temporary file written into a target written in place (``-``: standard output)."""
    with open(tmp, "rb") as src:
        if target == "-":
            shutil.copyfileobj(src, sys.stdout.buffer)
            sys.stdout.buffer.flush()
            return
        try:
            with _open_in_place(target, binary=True) as dst:
                shutil.copyfileobj(src, dst)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _write_error(target, exc) from None


def _open_in_place(target: str, binary: bool = False, newline: str | None = None):
    """A target written in place, opened for writing: never created, truncated or replaced (an
    append-mode open of the pipe, device or open file it is; a FIFO's open waits for its reader)."""
    fd = os.open(target, os.O_WRONLY | os.O_APPEND)
    if binary:
        return os.fdopen(fd, "ab")
    return os.fdopen(fd, "a", encoding="utf-8", newline=newline)


@contextlib.contextmanager
def committed_together() -> Iterator[None]:
    """The outputs completed inside this block (``atomic_path``, ``output_text``) go to their
    targets together when it completes (``_commit``: renames with SIGINT and SIGTERM held back,
    a signal leaves all of them or none); a failure of the block removes them all. Blocks nest:
    an inner block's outputs join the outer one's, committed when the outermost completes (a
    command's outputs, its summary and picture too, all or none)."""
    group: list = []
    _GROUPS.append(group)
    try:
        yield
        _drop_group(group)
        if _GROUPS:
            _GROUPS[-1].extend(group)
            group.clear()
        else:
            _commit(group)
    finally:
        _drop_group(group)
        for entry in group:
            if entry[0] is not None:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(entry[0])
                _forget(entry[0])


def _drop_group(group: list) -> None:
    """``group`` out of ``_GROUPS`` (by identity: two empty groups are equal lists)."""
    for k, g in enumerate(_GROUPS):
        if g is group:
            del _GROUPS[k]
            return


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT, SIGTERM and SIGALRM back (they are delivered on leaving) where the platform can."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM, signal.SIGALRM}
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _host_tag() -> str:
    """This machine in a part's name (letters and digits of its name, at most 16): a folder shared
    between machines is cleared only of this machine's dead parts."""
    node = os.uname().nodename if hasattr(os, "uname") else os.environ.get("COMPUTERNAME", "")
    return "".join(ch for ch in node if ch.isalnum())[:16] or "host"


def part_owner(name: str) -> tuple[str, int] | None:
    """(host tag, pid) of a temporary part's file name, None for a name that is not one of ours."""
    if not (name.startswith(_PART_PREFIX) and name.endswith(".part")):
        return None
    fields = name[len(_PART_PREFIX):].split("-", 2)
    if len(fields) != 3 or not fields[1].isdigit():
        return None  # an older tankcd's part (no pid): not known to be dead
    return fields[0], int(fields[1])


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # exists (another user's), or cannot tell: keep its parts
    return True


def clear_stale_parts(directory: str) -> list:
    """Remove the parts in ``directory`` that dead processes of this host left (SIGKILL, a crash):
    the paths removed. A live process's parts, another host's and an older tankcd's are kept."""
    removed = []
    host, me = _host_tag(), os.getpid()
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        owner = part_owner(entry.name)
        if owner is None or owner[0] != host or owner[1] == me or _alive(owner[1]):
            continue
        with contextlib.suppress(OSError):
            os.unlink(entry.path)
            removed.append(entry.path)
    return removed


def _create_beside(target: str, directory: str, suffix: str) -> str:
    """Create a new empty file with a fresh name in ``directory`` (its dead processes' parts
    cleared first, once a process); the usual permissions (0666 less the umask), as a finished
    output should have. (tempfile's mkstemp would cost its imports on every command's start and
    make the file 0600.)"""
    if directory not in _CLEARED:
        _CLEARED.add(directory)
        clear_stale_parts(directory)
    stem = f"{_PART_PREFIX}{_host_tag()}-{os.getpid()}-"
    for _ in range(100):
        tmp = os.path.join(directory, f"{stem}{os.urandom(6).hex()}{suffix}.part")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return tmp
        except FileExistsError:
            continue
        except OSError as exc:
            raise _write_error(target, exc) from None
    raise InputError(target, "cannot write output: no free temporary name beside it")


def pending_paths() -> list:
    """The temporary outputs not yet renamed nor removed."""
    return list(_PENDING)


def _remember(tmp: str) -> None:
    _PENDING.add(tmp)
    guard = sys.modules.get("tankcd_cli.io.exit_guard")
    if guard is not None:  # removed by the forced exit too (a SIGTERM the run does not answer)
        guard.track(tmp)


def _forget(tmp: str) -> None:
    _PENDING.discard(tmp)
    guard = sys.modules.get("tankcd_cli.io.exit_guard")
    if guard is not None:
        guard.untrack(tmp)


class NamedStream:
    """A text output's stream whose OSErrors (a full disk, a vanished reader's device) name its own
    target as bad output; everything else is the stream's."""

    def __init__(self, fh, target: str):
        self._fh = fh
        self._target = target

    def _do(self, call, *args):
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _write_error(self._target, exc) from None

    def write(self, text):
        return self._do(self._fh.write, text)

    def writelines(self, lines):
        return self._do(self._fh.writelines, lines)

    def flush(self):
        return self._do(self._fh.flush)

    def close(self):
        return self._do(self._fh.close)

    def __getattr__(self, name):
        return getattr(self._fh, name)

    def __iter__(self):
        return iter(self._fh)


def _open_text(path: str, newline: str | None):
    """A temporary text output opened for writing (UTF-8, as every text file tankcd writes)."""
    return open(path, "w", encoding="utf-8", newline=newline)


@contextlib.contextmanager
def output_text(target: str | None, suffix: str = "", newline: str | None = None) -> Iterator:
    """The one way a command writes a text output: ``None`` gives no stream (None), ``-`` standard
    output, a target written in place (``writes_in_place``: a named pipe, a device,
    ``/dev/stdout``, a process substitution) that file opened and written as rows come, anything
    else a file written beside the target and renamed onto it when complete (see
    ``atomic_path``: an error leaves the target untouched). A write's OSError names ``target``."""
    if target is None:
        yield None
    elif target == "-":
        yield sys.stdout
        sys.stdout.flush()
    elif writes_in_place(target):
        _check_target(target)
        try:
            fh = _open_in_place(target, newline=newline)
        except OSError as exc:
            raise _write_error(target, exc) from None
        stream = NamedStream(fh, target)
        try:
            yield stream
        except BaseException:
            with contextlib.suppress(OSError):
                fh.close()
            raise
        stream.close()
    else:
        with atomic_path(target, suffix) as tmp:
            stream = NamedStream(_open_text(tmp, newline), target)
            try:
                yield stream
            except BaseException:
                with contextlib.suppress(OSError):
                    stream._fh.close()
                raise
            stream.close()
