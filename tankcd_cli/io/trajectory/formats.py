"""The trajectory input formats, one registry (docs/formats.md, "Trajectory inputs: formats"):
``INPUT_FORMATS`` holds each format's name (``--format``), suffixes, magic numbers and reader,
and is the one list the reader, ``info``, ``export``, ``describe`` and the command line's help
read. A new format is one module of this package with a ``read_chunks(state)`` and one line here.

How a format is told (``trajectory_input``), first that applies:

1. the format given (``--format``);
2. the suffix, after a ``.gz`` (``x.csv.gz`` is a CSV): a format's ``suffixes`` (a capture's reader
   then goes by the file's own magic);
3. otherwise (no suffix, another one, a ``content_suffixes`` one such as Wireshark's ``.cap``,
   standard input) the first bytes (once decompressed): a format's ``magics``, or its ``sniff``
   (GPX: XML), anything else ``DEFAULT_FORMAT`` (a CSV); a ``.cap`` that is neither capture is read
   as pcap, whose reader names the bytes it found.

Opening inputs (standard input, gzip): ``io.input_bytes``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable, Iterator

from tankcd_cli.io.input_bytes import GZIP_MAGIC, PCAP_MAGIC, PCAPNG_SHB, decompressed_head, input_head
from tankcd_cli.io.trajectory.capture_input import read_chunks as read_capture
from tankcd_cli.io.trajectory.chunk import ReadState, TrajectoryChunk
from tankcd_cli.io.trajectory.csv_input import read_chunks as read_csv
from tankcd_cli.io.trajectory.gpx_input import looks_like_gpx
from tankcd_cli.io.trajectory.gpx_input import read_chunks as read_gpx


@dataclass(frozen=True)
class InputFormat:
    """One trajectory input format.

    name : its ``--format`` name; suffixes : the suffixes that name it (lower case, with the dot)
    magics : the bytes a file of it starts with (empty: told otherwise)
    read_chunks : its reader, ``read_chunks(state: ReadState) -> Iterator[TrajectoryChunk]``
    where : what its chunks' ``line`` counts ("line", "trkpt", "packet")
    coordinates : its positions as stored: ``projected``, ``geographic`` or ``ecef`` (a CSV's
        header may say ``geographic``: the reader's ``coordinates`` then)
    kind : what ``info`` calls a file of it; family : how messages and help name it ("CSV")
    sniff : told by the first bytes otherwise than by a magic (GPX: XML), or None
    content_suffixes : suffixes that do not decide but fall to this format when the bytes say nothing
    parts : read in parts (``TrajectoryPart``: a CSV only)
    """

    name: str
    suffixes: tuple
    magics: tuple
    read_chunks: Callable[[ReadState], Iterator[TrajectoryChunk]]
    where: str
    coordinates: str
    kind: str
    family: str
    sniff: Callable[[bytes], bool] | None = None
    content_suffixes: tuple = ()
    parts: bool = False


INPUT_FORMATS = (
    InputFormat("csv", (".csv", ".txt", ".tsv"), (), read_csv, "line", "projected", "trajectory", "CSV",
                parts=True),
    InputFormat("gpx", (".gpx",), (), read_gpx, "trkpt", "geographic", "GPX track", "GPX",
                sniff=looks_like_gpx),
    InputFormat("pcap", (".pcap",), tuple(PCAP_MAGIC), read_capture, "packet", "ecef", "DIS capture",
                "DIS capture", content_suffixes=(".cap",)),
    InputFormat("pcapng", (".pcapng", ".ntar"), (PCAPNG_SHB,), read_capture, "packet", "ecef",
                "DIS capture", "DIS capture", content_suffixes=(".cap",)),
)
FORMAT_NAMES = tuple(f.name for f in INPUT_FORMATS)
FAMILIES = tuple(dict.fromkeys(f.family for f in INPUT_FORMATS))  # ("CSV", "GPX", "DIS capture")
DEFAULT_FORMAT = "csv"  # what an input is that nothing else tells
COMPRESSED_SUFFIXES = (".gz",)
_BY_NAME = {f.name: f for f in INPUT_FORMATS}


def input_format(name: str) -> InputFormat:
    """The registered format of that ``--format`` name (lower case; KeyError for another)."""
    return _BY_NAME[name]


@dataclass(frozen=True)
class TrajectoryInput:
    """How a trajectory input is read: ``format`` (a name of ``INPUT_FORMATS``), ``compressed`` (gzip),
    and ``told_by`` ("given", "suffix" or "content")."""

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
    """The format a (decompressed) input's first bytes say, or None where they say nothing: a
    format's magic, else a format's sniff."""
    for f in INPUT_FORMATS:
        if any(head.startswith(m) for m in f.magics):
            return f.name
    for f in INPUT_FORMATS:
        if f.sniff is not None and f.sniff(head):
            return f.name
    return None


def format_of_suffix(path: str) -> tuple[str | None, bool]:
    """(the format the suffix names or None, the name ends in .gz)."""
    root, ext = os.path.splitext(path)
    gz = ext.lower() in COMPRESSED_SUFFIXES
    if gz:
        ext = os.path.splitext(root)[1]
    ext = ext.lower()
    for f in INPUT_FORMATS:
        if ext in f.suffixes:
            return f.name, gz
    return None, gz


def _of_content_suffix(path: str, gz: bool) -> str | None:
    ext = os.path.splitext(path[:-3] if gz else path)[1].lower()
    return next((f.name for f in INPUT_FORMATS if ext in f.content_suffixes), None)


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
        inner = format_of_head(decompressed_head(path, head) if compressed else head)
    if inner is None and path != "-":
        inner = _of_content_suffix(path, gz)  # neither magic: the capture reader names what it found
    return TrajectoryInput(inner or DEFAULT_FORMAT, compressed, "content")


def trajectory_format(path: str, fmt: str | None = None) -> str:
    """The format name of ``path``: ``fmt`` if given, else by the suffix (``.gz`` passed over), else by
    the first bytes (``trajectory_input``)."""
    return trajectory_input(path, fmt).format
