"""Where a replay's poses and events go, chosen by each output's name: the poses CSV and the events
JSON Lines (``-``: standard output), or Parquet for a name ending in ``.parquet`` (``io.parquet``:
typed columns, a row group per batch, the CRS, conventions and sources in the file's metadata).

``replay_outputs`` opens both under temporary names and renames them into place together when the
block completes (``io.atomic.committed_together``): an error or a signal leaves neither.
"""

from __future__ import annotations

import contextlib
from typing import Callable, Iterator

from tankcd_cli.replay.records import ReplayOutputs

# events are few against poses: a row group holds this many, not one chunk's handful
EVENT_ROWS_PER_GROUP = 65536


class PosesText:
    """The poses CSV: the header (with ``entity`` when the rows have entities) before the first chunk,
    each chunk's rows flushed as they come (a reader of standard output sees them)."""

    def __init__(self, fh):
        self.fh = fh
        self.headed = False

    def write(self, chunk, poses) -> None:
        from tankcd_cli.io.poses_csv import format_rows, header
        from tankcd_cli.matching.match import PLACED_BY, STATUS

        if not self.headed:
            self.fh.write(header(entity=chunk.has_entity))
            self.headed = True
        entity = chunk.entity if chunk.has_entity else None
        self.fh.write(format_rows(chunk.step, chunk.t, poses, PLACED_BY, STATUS, entity, chunk.entity_names))
        self.fh.flush()

    def finish(self) -> None:
        from tankcd_cli.io.poses_csv import header

        if not self.headed:  # no rows: the header alone
            self.fh.write(header())
            self.headed = True


class PosesParquet:
    """The poses as Parquet: a row group per chunk, ``entity`` (dictionary-encoded) when the
    trajectory has entities."""

    def __init__(self, writer):
        self.writer = writer

    def write(self, chunk, poses) -> None:
        from tankcd_cli.io.parquet import Coded
        from tankcd_cli.matching.match import PLACED_BY, STATUS

        entity = Coded(chunk.entity, list(chunk.entity_names)) if chunk.has_entity else None
        self.writer.write_chunk(chunk.step, chunk.t, poses, PLACED_BY, STATUS, entity)

    def finish(self) -> None:
        pass


class EventsText:
    """The events JSON Lines: one line per event."""

    def __init__(self, fh):
        self.fh = fh

    def write(self, events) -> None:
        from tankcd_cli.io.events import event_line

        if events:
            self.fh.write("".join(event_line(e.step, e.t, e.kind, e.a, e.b, **e.extra) for e in events))

    def finish(self) -> None:
        pass


class EventsParquet:
    """The events as Parquet, gathered into row groups of ``EVENT_ROWS_PER_GROUP``."""

    def __init__(self, writer):
        self.writer = writer
        self.pending: list = []

    def write(self, events) -> None:
        self.pending.extend(events)
        if len(self.pending) >= EVENT_ROWS_PER_GROUP:
            self._flush()

    def _flush(self) -> None:
        pending, self.pending = self.pending, []
        self.writer.write_events(pending)

    def finish(self) -> None:
        self._flush()


@contextlib.contextmanager
def replay_outputs(outputs: ReplayOutputs, entity: bool, metadata: Callable[[], dict]) -> Iterator[tuple]:
    """(poses, events) writers for a replay (each None where ``outputs`` says none): ``write`` per
    chunk, ``finish`` after the last. Both files are renamed into place together when the block
    completes; an error in it leaves neither. ``entity``: the rows carry entities (the poses'
    Parquet schema has the column); ``metadata()``: the Parquet files' key-value metadata, asked
    for once and only when one is written (it hashes the sources), ``tankcd.table`` added to it
    (``poses`` or ``events``)."""
    from tankcd_cli.io.atomic import committed_together, output_text
    from tankcd_cli.io.parquet import EventsParquetWriter, PosesParquetWriter, is_parquet

    known: list = []

    def metadata_of(table: str) -> dict:
        if not known:
            known.append(metadata())
        return {**known[0], "tankcd.table": table}

    with committed_together(), contextlib.ExitStack() as stack:
        if is_parquet(outputs.poses):
            poses = PosesParquet(stack.enter_context(PosesParquetWriter(outputs.poses, metadata_of("poses"),
                                                                        entity=entity)))
        else:
            fh = stack.enter_context(output_text(outputs.poses, ".csv", newline=""))
            poses = PosesText(fh) if fh is not None else None
        if is_parquet(outputs.events):
            events = EventsParquet(stack.enter_context(EventsParquetWriter(outputs.events, metadata_of("events"))))
        else:
            fh = stack.enter_context(output_text(outputs.events, ".jsonl"))
            events = EventsText(fh) if fh is not None else None
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
    from tankcd_cli.io.parquet import output_metadata, sha256_of

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
