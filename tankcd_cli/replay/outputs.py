"""Where a replay's poses and events go, chosen by each output's name (``OUTPUT_FORMATS``, by
suffix: ``output_format``): the poses CSV and the events JSON Lines (any other name; ``-``:
standard output), or Parquet for a name ending in ``.parquet`` (``io.parquet``: typed columns, a
row group per batch, the CRS, conventions and sources in the file's metadata).

A format is a pair of writers (poses, events), each ``write`` per batch and ``finish`` after the
last, and how a fleet joins the parts of a trajectory it split. ``replay_outputs`` opens both
under temporary names and renames them into place together when the block completes
(``io.atomic.committed_together``): an error or a signal leaves neither.
"""

from __future__ import annotations

import contextlib
import json
import shutil
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

from tankcd_cli.io.atomic import atomic_path, committed_together, output_text
from tankcd_cli.io.events import event_line
from tankcd_cli.io.parquet import (
    Coded,
    EventsParquetWriter,
    PosesParquetWriter,
    file_metadata,
    join_files,
    output_metadata,
    pyarrow_modules,
    sha256_of,
)
from tankcd_cli.io import poses_csv
from tankcd_cli.names import PLACED_BY, STATUS
from tankcd_cli.replay.records import ReplayOutputs

# events are few against poses: a row group holds this many, not one chunk's handful
EVENT_ROWS_PER_GROUP = 65536


class PosesText:
    """The poses CSV: the header (with ``entity`` when the rows have entities) before the first chunk,
    each chunk's rows flushed as they come (a reader of standard output sees them)."""

    def __init__(self, fh):
        self.fh = fh
        self.headed = False

    @staticmethod
    def open(stack: contextlib.ExitStack, path: str | None, entity: bool, metadata: Callable[[], dict]):
        fh = stack.enter_context(output_text(path, ".csv", newline=""))
        return PosesText(fh) if fh is not None else None

    def write(self, chunk, poses) -> None:
        if not self.headed:
            self.fh.write(poses_csv.header(entity=chunk.has_entity))
            self.headed = True
        entity = chunk.entity if chunk.has_entity else None
        self.fh.write(poses_csv.format_rows(chunk.step, chunk.t, poses, PLACED_BY, STATUS, entity, chunk.entity_names))
        self.fh.flush()

    def finish(self) -> None:
        if not self.headed:  # no rows: the header alone
            self.fh.write(poses_csv.header())
            self.headed = True


class PosesParquet:
    """The poses as Parquet: a row group per chunk, ``entity`` (dictionary-encoded) when the
    trajectory has entities."""

    def __init__(self, writer):
        self.writer = writer

    @staticmethod
    def open(stack: contextlib.ExitStack, path: str | None, entity: bool, metadata: Callable[[], dict]):
        return PosesParquet(stack.enter_context(PosesParquetWriter(path, metadata(), entity=entity)))

    def write(self, chunk, poses) -> None:
        entity = Coded(chunk.entity, list(chunk.entity_names)) if chunk.has_entity else None
        self.writer.write_chunk(chunk.step, chunk.t, poses, PLACED_BY, STATUS, entity)

    def finish(self) -> None:
        pass


class EventsText:
    """The events JSON Lines: one line per event."""

    def __init__(self, fh):
        self.fh = fh

    @staticmethod
    def open(stack: contextlib.ExitStack, path: str | None, entity: bool, metadata: Callable[[], dict]):
        fh = stack.enter_context(output_text(path, ".jsonl"))
        return EventsText(fh) if fh is not None else None

    def write(self, events) -> None:
        if events:
            self.fh.write("".join(event_line(e.step, e.t, e.kind, e.a, e.b, **e.extra) for e in events))

    def finish(self) -> None:
        pass


class EventsParquet:
    """The events as Parquet, gathered into row groups of ``EVENT_ROWS_PER_GROUP``."""

    def __init__(self, writer):
        self.writer = writer
        self.pending: list = []

    @staticmethod
    def open(stack: contextlib.ExitStack, path: str | None, entity: bool, metadata: Callable[[], dict]):
        return EventsParquet(stack.enter_context(EventsParquetWriter(path, metadata())))

    def write(self, events) -> None:
        self.pending.extend(events)
        if len(self.pending) >= EVENT_ROWS_PER_GROUP:
            self._flush()

    def _flush(self) -> None:
        pending, self.pending = self.pending, []
        self.writer.write_events(pending)

    def finish(self) -> None:
        self._flush()


def _join_text(poses: str, events: str, parts: Sequence[tuple[str, str]]) -> None:
    """The parts' poses CSVs (one header) and events JSON Lines, in order, into ``poses`` and ``events``."""
    with committed_together(), atomic_path(poses, ".csv") as tmp_poses, atomic_path(events, ".jsonl") as tmp_events:
        for k, (part_poses, part_events) in enumerate(parts):
            _append(tmp_poses, part_poses, skip_header=k > 0)
            _append(tmp_events, part_events, skip_header=False)


def _append(target: str, source: str, skip_header: bool) -> None:
    with open(source, "rb") as src, open(target, "ab") as dst:
        if skip_header:
            src.readline()
        shutil.copyfileobj(src, dst, 1 << 20)


def _join_parquet(poses: str, events: str, parts: Sequence[tuple[str, str]]) -> None:
    """The parts' row groups, in order (their schema is one), into ``poses`` and ``events``; the
    trajectory's SHA-256 added to the sources (a part does not hash the whole file it reads a part
    of: the join hashes it once)."""
    sources = json.loads(file_metadata(parts[0][0]).get("tankcd.sources", "[]"))
    for source in sources:
        if source.get("role") == "trajectory" and "sha256" not in source:
            source["sha256"] = sha256_of(source["path"])
    meta = {"tankcd.sources": json.dumps(sources)}
    with committed_together():
        join_files(poses, [p for p, _ in parts], meta)
        join_files(events, [e for _, e in parts], meta)


def _needs_nothing(path: str | None) -> None:
    pass


@dataclass(frozen=True)
class OutputFormat:
    """One output format: the name's ending that asks for it (None: any other name), its writers
    (``open(stack, path, entity, metadata)`` -> a writer with ``write`` and ``finish``, or None for
    no output), a fleet's NAME.poses and NAME.events suffixes, how a fleet joins a split
    trajectory's parts (``join(poses, events, [(part poses, part events), ...])``), and ``check(path)``
    raising an ``InputError`` before any work when what it needs is not installed."""

    name: str
    suffix: str | None
    poses: Callable
    events: Callable
    fleet_suffixes: tuple[str, str]
    join: Callable[[str, str, Sequence[tuple[str, str]]], None]
    check: Callable[[str | None], None] = _needs_nothing


# by name (a fleet's --out-format); a path's is found by its suffix (``output_format``)
OUTPUT_FORMATS = {
    "csv": OutputFormat("csv", None, PosesText.open, EventsText.open, (".poses.csv", ".events.jsonl"), _join_text),
    "parquet": OutputFormat("parquet", ".parquet", PosesParquet.open, EventsParquet.open,
                            (".poses.parquet", ".events.parquet"), _join_parquet, pyarrow_modules),
}
DEFAULT_FORMAT = "csv"


def output_format(path: str | None) -> OutputFormat:
    """The format an output's name asks for: the one whose suffix it ends in (any case), else CSV
    and JSON Lines (``-``, standard output, included)."""
    name = str(path).lower() if path else ""
    for fmt in OUTPUT_FORMATS.values():
        if fmt.suffix is not None and name.endswith(fmt.suffix):
            return fmt
    return OUTPUT_FORMATS[DEFAULT_FORMAT]


def check_writable(*paths: str | None) -> None:
    """An ``InputError`` for the first output whose format cannot be written here (Parquet without
    pyarrow): called before any work, so that a run that cannot write its output does not start."""
    for path in paths:
        if path:
            output_format(path).check(path)


@contextlib.contextmanager
def replay_outputs(outputs: ReplayOutputs, entity: bool, metadata: Callable[[], dict]) -> Iterator[tuple]:
    """(poses, events) writers for a replay (each None where ``outputs`` says none): ``write`` per
    chunk, ``finish`` after the last. Both files are renamed into place together when the block
    completes; an error in it leaves neither. ``entity``: the rows carry entities (the poses'
    Parquet schema has the column); ``metadata()``: the Parquet files' key-value metadata, asked
    for once and only when one is written (it hashes the sources), ``tankcd.table`` added to it
    (``poses`` or ``events``)."""
    known: list = []

    def metadata_of(table: str) -> Callable[[], dict]:
        def made() -> dict:
            if not known:
                known.append(metadata())
            return {**known[0], "tankcd.table": table}
        return made

    with committed_together(), contextlib.ExitStack() as stack:
        poses = output_format(outputs.poses).poses(stack, outputs.poses, entity, metadata_of("poses"))
        events = output_format(outputs.events).events(stack, outputs.events, entity, metadata_of("events"))
        yield poses, events


def replay_metadata(world, trajectories, options, hash_trajectories: bool = True,
                    time_origin: str | None = None) -> dict:
    """A replay's Parquet metadata (``io.parquet.output_metadata``): the terrain's CRS, the units
    and conventions, tankcd's version, ``tankcd.replay`` (the options: matcher, escalate,
    tolerance, mode; ``time_origin``: the UTC instant of t = 0, ISO 8601 ``...Z``, or null where the
    trajectory's times are relative) and ``tankcd.sources``, each with its ``role``:

    - trajectory: each trajectory file with its SHA-256 (without, when ``hash_trajectories`` is
      False: a part of a trajectory, whose whole file the fleet hashes once when it joins them);
    - scene, obstacle, vehicle_mesh: the scene and the files it names, with their SHA-256;
    - terrain: the input as given; a store (which may be gigabytes) is not read again for a hash:
      its own record of what it was classified from (``source``, ``source_sha256``) stands for
      it; a DEM or mesh classified for this replay has its own SHA-256 (computed when it was read).
    """
    sources = [{"role": "trajectory", "path": p, **({"sha256": sha256_of(p)} if hash_trajectories else {})}
               for p in trajectories if p and p != "-"]
    scene = world.scene
    if scene is not None:
        sources.append({"role": "scene", "path": scene.path, "sha256": sha256_of(scene.path)})
        for ob in scene.obstacles:
            sources.append({"role": "obstacle", "name": ob.name, "path": ob.path, "sha256": sha256_of(ob.path)})
        if scene.vehicle_mesh:
            sources.append({"role": "vehicle_mesh", "path": scene.vehicle_mesh,
                            "sha256": sha256_of(scene.vehicle_mesh)})
        for kind in world.kinds[1:]:  # the [[entity]] tables' own meshes
            if kind.mesh:
                sources.append({"role": "vehicle_mesh", "name": kind.label, "path": kind.mesh,
                                "sha256": sha256_of(kind.mesh)})
    sources.append(_terrain_source(world))
    how = {"matcher": options.matcher, "escalate": options.escalate, "tolerance": options.tolerance,
           "attitude_tolerance": options.attitude_tolerance,
           "mode": "continuous" if options.continuous else "discrete", "time_origin": time_origin}
    return output_metadata(world.crs, sources, replay=how)


def _terrain_source(world) -> dict:
    """The terrain's entry in ``tankcd.sources``, from the store's attributes (no file read whole)."""
    opened = world.terrain
    if opened.mesh_store is not None:
        attrs = dict(opened.mesh_store.attrs)
    else:
        from tankcd_cli.terrain.store import read_attrs

        attrs = read_attrs(opened.store_path) if opened.store_path else {}
    spec = world.spec
    if spec is not None and spec.store is not None:  # a fleet's, classified once for its workers: name the input
        terrain = world.scene.terrain_path if world.scene is not None else spec.terrain
        return {"role": "terrain", "path": terrain, "sha256": str(attrs.get("source_sha256", ""))}
    given_a_store = opened.store_path is not None and opened.source == opened.store_path and not opened.classified
    if given_a_store:
        return {"role": "terrain", "path": opened.source, "source": str(attrs.get("source", "")),
                "source_sha256": str(attrs.get("source_sha256", ""))}
    return {"role": "terrain", "path": opened.source, "sha256": str(attrs.get("source_sha256", ""))}
