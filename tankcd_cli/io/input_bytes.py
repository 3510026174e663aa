"""How a trajectory input's bytes are opened (docs/formats.md, "Trajectory inputs: formats"), so
that every reader sees the same bytes: standard input read once (its first bytes kept to tell
the format, then replayed), gzip decompressed as a stream; and the magic numbers the first bytes
are told by.

An input is gzip-compressed when its first two bytes are gzip's magic (1f 8b), whatever its name
(a ``.gz`` file that is not gzip is read as it is, and fails as what it holds). It is then read
through Python's ``gzip`` as a stream (never all in memory); a corrupt or cut gzip stream is an
InputError naming the file. Which format an input is: ``io.trajectory.formats``.
"""

from __future__ import annotations

import io
import sys

from tankcd_cli.errors import InputError
from tankcd_cli.io.files import open_input

GZIP_MAGIC = b"\x1f\x8b"
# pcap's magic in the file's byte order -> (big-endian, nanosecond timestamps)
PCAP_MAGIC = {b"\xd4\xc3\xb2\xa1": (False, False), b"\xa1\xb2\xc3\xd4": (True, False),   # microseconds
              b"\x4d\x3c\xb2\xa1": (False, True), b"\xa1\xb2\x3c\x4d": (True, True)}     # nanoseconds
PCAPNG_SHB = b"\x0a\x0d\x0d\x0a"
HEAD_BYTES = 64  # what is read of an input to tell its format


def input_head(path: str) -> bytes | None:
    """The first bytes of an input as stored (not decompressed), or None where it cannot be read."""
    if path == "-":
        return _stdin().head
    try:
        with open(path, "rb") as fh:
            return fh.read(HEAD_BYTES)
    except OSError:
        return None


def decompressed_head(path: str, head: bytes) -> bytes:
    """The first bytes of a gzip-compressed input once decompressed (``head``: its first bytes as stored;
    empty where the stream cannot be read)."""
    import zlib

    if path == "-":
        return _stdin().unzipped_head()
    try:
        import gzip

        with gzip.open(path, "rb") as fh:
            return fh.read(HEAD_BYTES)
    except (OSError, EOFError, zlib.error):
        return b""


def open_trajectory_input(path: str, compressed: bool | None = None):
    """(name for messages, binary stream) of a trajectory input: '-' standard input (``<stdin>``), else
    the file; decompressed where gzip (``compressed`` None: by its first bytes). The stream reads,
    ``readinto``/``readinto1``, ``readline`` and (for files) seeks; closing it never closes standard
    input. Raises InputError for a file that cannot be opened."""
    if path == "-":
        stdin = _stdin()
        name, raw = "<stdin>", stdin.stream()
        if compressed is None:
            compressed = stdin.head.startswith(GZIP_MAGIC)
    else:
        name, raw = open_input(path, text=False)
        if compressed is None:
            try:
                compressed = raw.peek(2)[:2] == GZIP_MAGIC
            except OSError:
                compressed = False
    if not compressed:
        return name, raw
    import gzip

    return name, io.BufferedReader(_Guarded(gzip.GzipFile(fileobj=raw, mode="rb"), raw, name), 1 << 16)


class _Guarded(io.RawIOBase):
    """A gzip stream whose errors are InputErrors naming the file; closing it closes the file (not
    standard input)."""

    def __init__(self, gz, raw, name: str):
        self.gz, self.raw, self.name_ = gz, raw, name

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return self.gz.seekable()

    def readinto(self, b) -> int:
        import zlib

        try:
            return self.gz.readinto(b)
        except (OSError, EOFError, zlib.error) as exc:
            raise InputError(self.name_, f"not a whole gzip stream ({exc})") from None

    def seek(self, offset: int, whence: int = 0) -> int:
        import zlib

        try:
            return self.gz.seek(offset, whence)
        except (OSError, EOFError, zlib.error) as exc:
            raise InputError(self.name_, f"not a whole gzip stream ({exc})") from None

    def tell(self) -> int:
        return self.gz.tell()

    def close(self) -> None:
        if not self.closed:
            self.gz.close()
            self.raw.close()
        super().close()


class _StdinHead:
    """Standard input read once: ``head`` its first bytes (kept to tell the format), ``stream()`` all of
    it from the start (the head replayed), made once."""

    def __init__(self, buffer):
        self.buffer = buffer
        head = b""
        while len(head) < HEAD_BYTES:  # what has arrived, until enough to tell (a pipe's rows stream on)
            more = buffer.read1(HEAD_BYTES - len(head)) if hasattr(buffer, "read1") else buffer.read(
                HEAD_BYTES - len(head))
            if not more:
                break
            head += more
            if len(head) >= 8 and not head.startswith(GZIP_MAGIC):
                break
        self.head = head
        self._stream = None

    def stream(self):
        if self._stream is None:
            self._stream = io.BufferedReader(_Replay(self.head, self.buffer), 1 << 16)
        return self._stream

    def unzipped_head(self) -> bytes:
        """The first bytes once decompressed (reading more of standard input if the head holds too few; what
        is read is kept for the stream)."""
        import zlib

        d = zlib.decompressobj(31)
        got = b""
        data = self.head
        try:
            got = d.decompress(data)
            while len(got) < 8 and not d.eof:
                more = self.buffer.read1(4096) if hasattr(self.buffer, "read1") else self.buffer.read(4096)
                if not more:
                    break
                self.head += more
                got += d.decompress(more)
        except zlib.error:
            pass
        return got


class _Replay(io.RawIOBase):
    """``head``, then the rest of ``buffer`` (reads give what has arrived); closing leaves ``buffer`` open."""

    def __init__(self, head: bytes, buffer):
        self.head = memoryview(head)
        self.buffer = buffer

    def readable(self) -> bool:
        return True

    def readinto(self, b) -> int:
        if len(self.head):
            n = min(len(b), len(self.head))
            b[:n] = self.head[:n]
            self.head = self.head[n:]
            return n
        read = getattr(self.buffer, "readinto1", None) or self.buffer.readinto
        return read(b)


_STDIN: list = []


def _stdin() -> _StdinHead:
    """Standard input's head, made once for each ``sys.stdin`` (a test's runner gives its own)."""
    buffer = getattr(sys.stdin, "buffer", sys.stdin)
    if not _STDIN or _STDIN[0].buffer is not buffer:
        _STDIN[:] = [_StdinHead(buffer)]
    return _STDIN[0]
