"""One reader for every trajectory input (docs/formats.md, "Trajectory inputs: formats"): the
format told by ``formats.trajectory_input``, its chunks read by that format's registered
``read_chunks``.
"""

from __future__ import annotations

from tankcd_cli.io.trajectory.chunk import ReadState, TrajectoryChunk, TrajectoryPart
from tankcd_cli.io.trajectory.formats import input_format, trajectory_format


class TrajectoryReader(ReadState):
    """The chunks of one trajectory input, an iterator (``read_trajectory`` makes one). Nothing is
    read before the first ``next``; what it learns is kept here as it goes (the fields of
    :class:`~tankcd_cli.io.trajectory.chunk.ReadState`: ``format``, ``where``, ``coordinates``,
    ``geographic``, ``entity_names``, ``start``, ``time_origin``, ``lonlat``, ``skipped``, ``counts``,
    ``columns``)."""

    def __init__(self, path: str, chunk_rows: int = 65536, part: TrajectoryPart | None = None,
                 crs: str | None = None, fmt: str | None = None, convert: bool = True, lonlat: bool = False):
        spec = input_format(trajectory_format(path, fmt))
        super().__init__(path=path, chunk_rows=max(1, int(chunk_rows)), part=part, crs=crs,
                         convert=convert and not lonlat, lonlat=lonlat, format=spec.name, where=spec.where,
                         coordinates=spec.coordinates,
                         geographic=None if spec.coordinates == "projected" else True)  # a CSV's: its header's
        self._read = spec.read_chunks
        self._gen = None
        if part is not None and not spec.parts:
            raise ValueError("only a trajectory CSV is read in parts")

    def __iter__(self) -> "TrajectoryReader":
        return self

    def __next__(self) -> TrajectoryChunk:
        if self._gen is None:
            self._gen = self._read(self)
        chunk = next(self._gen)
        self.entity_names = chunk.entity_names
        return chunk

    def close(self) -> None:
        if self._gen is not None:
            self._gen.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_trajectory(path: str, chunk_rows: int = 65536, part: TrajectoryPart | None = None, crs: str | None = None,
                    fmt: str | None = None) -> TrajectoryReader:
    """The chunks of a trajectory input in its order (only ``part``'s rows of a CSV, if given: steps and
    line numbers stay those of the whole file), as a :class:`TrajectoryReader` (an iterator).

    ``crs``: the terrain's CRS (WKT, or anything pyproj takes; None or empty: the terrain has none).
    Geographic inputs (a CSV in lon, lat; GPX; DIS captures) are converted to it, and refused
    (InputError naming the file) without one. ``fmt``: a format name of ``formats.INPUT_FORMATS``
    (default: by suffix, else by the first bytes)."""
    return TrajectoryReader(path, chunk_rows, part, crs, fmt)
