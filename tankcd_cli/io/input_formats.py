"""The trajectory inputs' formats in one place (docs/formats.md, "Trajectory inputs: formats"): each
format's name, suffixes and magic numbers, how a path's format is told, and how an input is opened
(standard input, gzip) so that every reader sees the same bytes.

How a format is told (``trajectory_input``), first that applies:

1. the format given (``--format``: csv, gpx, pcap, pcapng);
2. the suffix, after a ``.gz`` (``x.csv.gz`` is a CSV): ``.csv``, ``.txt``, ``.tsv`` a CSV, ``.gpx``
   GPX, ``.pcap`` and ``.pcapng`` captures (the capture reader then goes by the file's own magic);
3. otherwise (no suffix, another one, Wireshark's ``.cap``, standard input) the first bytes (once
   decompressed): a pcap magic (a1b2c3d4 or a1b23c4d, either byte order) is pcap, a pcapng section
   header (0a0d0d0a) pcapng, ``<`` (after a byte-order mark and blanks: XML) GPX, anything else a
   CSV; a ``.cap`` that is neither capture is read as pcap, whose reader names the bytes it found.

An input is gzip-compressed when its first two bytes are gzip's magic (1f 8b), whatever its name
(a ``.gz`` file that is not gzip is read as it is, and fails as what it holds). It is then read
through Python's ``gzip`` as a stream (never all in memory); a corrupt or cut gzip stream is an
InputError naming the file. Standard input is read once: its first bytes are kept to tell the
format and replayed to the reader.
"""

from __future__ import annotations

import io
import os
import sys
from dataclasses import dataclass

from tankcd_cli.errors import InputError

GZIP_MAGIC = b"\x1f\x8b"
# pcap's magic in the file's byte order -> (big-endian, nanosecond timestamps)
PCAP_MAGIC = {b"\xd4\xc3\xb2\xa1": (False, False), b"\xa1\xb2\xc3\xd4": (True, False),   # microseconds
              b"\x4d\x3c\xb2\xa1": (False, True), b"\xa1\xb2\x3c\x4d": (True, True)}     # nanoseconds
PCAPNG_SHB = b"\x0a\x0d\x0d\x0a"
HEAD_BYTES = 64  # what is read of an input to tell its format


@dataclass(frozen=True)
class InputFormat:
    """One trajectory input format: its name (``--format``), the suffixes that name it, and the bytes a
    file of it starts with (empty: told otherwise)."""

    name: str
    suffixes: tuple
    magics: tuple = ()


TRAJECTORY_FORMATS = (
    InputFormat("csv", (".csv", ".txt", ".tsv")),
    InputFormat("gpx", (".gpx",)),
    InputFormat("pcap", (".pcap",), tuple(PCAP_MAGIC)),
    InputFormat("pcapng", (".pcapng", ".ntar"), (PCAPNG_SHB,)),
)
FORMAT_NAMES = tuple(f.name for f in TRAJECTORY_FORMATS)
CAPTURE_SUFFIXES = (".cap",)  # Wireshark's, for pcap and pcapng alike: the magic decides
COMPRESSED_SUFFIXES = (".gz",)


@dataclass(frozen=True)
class TrajectoryInput:
    """How a trajectory input is read: ``format`` (csv, gpx, pcap, pcapng), ``compressed`` (gzip), and
    ``told_by`` ("given", "suffix" or "content")."""

    format: str
    compressed: bool
    told_by: str


class TrajectoryPath(str):
    """A trajectory input's path with its format given (``replay --format``): a ``str``, so every reader,
    message and check takes it as the path it is, and every reader of it (``trajectory_input``) takes
    ``input_format`` where no format is passed."""

    input_format: str

    def __new__(cls, path: str, fmt: str):
        obj = super().__new__(cls, path)
        obj.input_format = check_format(fmt)
        return obj

    def __reduce__(self):
        return TrajectoryPath, (str(self), self.input_format)


def with_format(path, fmt: str | None):
    """``path`` as a :class:`TrajectoryPath` of format ``fmt`` (None: ``path`` as it is)."""
    return path if fmt is None else TrajectoryPath(str(path), fmt)


def check_format(fmt: str) -> str:
    """``fmt`` in lower case, or ValueError naming the formats."""
    name = fmt.lower()
    if name not in FORMAT_NAMES:
        raise ValueError(f"unknown trajectory format {fmt!r} (one of {', '.join(FORMAT_NAMES)})")
    return name


def format_of_head(head: bytes) -> str | None:
    """The format a (decompressed) input's first bytes say, or None where they say nothing: a pcap or
    pcapng magic, or XML (GPX)."""
    for f in TRAJECTORY_FORMATS:
        if any(head.startswith(m) for m in f.magics):
            return f.name
    text = head[3:] if head.startswith(b"\xef\xbb\xbf") else head
    if text.lstrip().startswith(b"<"):
        return "gpx"
    return None


def format_of_suffix(path: str) -> tuple[str | None, bool]:
    """(the format the suffix names or None, the name ends in .gz)."""
    root, ext = os.path.splitext(path)
    gz = ext.lower() in COMPRESSED_SUFFIXES
    if gz:
        ext = os.path.splitext(root)[1]
    ext = ext.lower()
    for f in TRAJECTORY_FORMATS:
        if ext in f.suffixes:
            return f.name, gz
    return None, gz


def trajectory_input(path: str, fmt: str | None = None) -> TrajectoryInput:
    """How ``path`` ('-': standard input) is read (the module's rules). A file that cannot be opened
    goes by its name alone (its reader says what is wrong)."""
    if fmt is None:
        fmt = getattr(path, "input_format", None)
    by_suffix, gz = format_of_suffix(path) if path != "-" else (None, False)
    head = input_head(path)
    compressed = head.startswith(GZIP_MAGIC) if head is not None else gz
    if fmt is not None:
        return TrajectoryInput(check_format(fmt), compressed, "given")
    if by_suffix is not None:
        return TrajectoryInput(by_suffix, compressed, "suffix")
    inner = None
    if head is not None:
        inner = format_of_head(_decompressed_head(path, head) if compressed else head)
    if inner is None and path != "-" and os.path.splitext(path[:-3] if gz else path)[1].lower() in CAPTURE_SUFFIXES:
        inner = "pcap"  # neither magic: the capture reader names what it found
    return TrajectoryInput(inner or "csv", compressed, "content")


def input_head(path: str) -> bytes | None:
    """The first bytes of an input as stored (not decompressed), or None where it cannot be read."""
    if path == "-":
        return _stdin().head
    try:
        with open(path, "rb") as fh:
            return fh.read(HEAD_BYTES)
    except OSError:
        return None


def _decompressed_head(path: str, head: bytes) -> bytes:
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
        from tankcd_cli.io.files import open_input

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
