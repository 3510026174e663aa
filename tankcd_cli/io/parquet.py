"""Parquet outputs, streamed: the poses and the events as typed columns, one row group per batch.

Used like the CSV writers: open at a path (written beside it under a temporary name and renamed
onto it when complete, ``io.atomic``: an error leaves nothing), write batches, close. pyarrow is
an extra (``pip install 'tankcd[parquet]'``), imported only when a Parquet file is written; without
it, :class:`ParquetUnavailable` (bad input: the command line's exit 3, as a missing Dask is) carries
the one line that says so, naming the output (``PYARROW_MISSING``).

Columns are typed (the schema is fixed when the file is opened): ``float64``, ``int64``,
``int32``, ``int16``, ``uint8``, ``bool``, ``string``, ``dict`` (a string column dictionary-encoded:
for repetitive text such as matcher, status, region or entity names) and ``json`` (a string of
JSON text). A float NaN is written as null (no value: the CSV's empty cell).

File metadata (Parquet key-value metadata, as given by the caller; see :func:`output_metadata`
for tankcd's keys): the CRS WKT, units, conventions, tankcd's version, the SHA-256 of the sources.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import sys
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.pose_table import TYPES as POSE_TYPES
from tankcd_cli.io.pose_table import pose_table

PYARROW_MISSING = "Parquet output needs pyarrow: pip install 'tankcd[parquet]'"
COLUMN_TYPES = ("float64", "int64", "int32", "int16", "uint8", "bool", "string", "dict", "json")
CONVENTIONS = ("world frame x east, y north, z up in the terrain's CRS (m); angles in degrees; attitude ROS REP 103: "
               "R = Rz(yaw) Ry(pitch) Rx(roll), yaw counter-clockwise from grid east, nose-up pitch negative, "
               "right side down roll positive; quaternion (qw, qx, qy, qz) with qw >= 0; t in s")
UNITS = "m, s, deg"


class ParquetUnavailable(InputError):
    """pyarrow is not installed: ``str()`` is the one line to show, ``target: PYARROW_MISSING`` (or
    ``PYARROW_MISSING`` alone without a target)."""

    def __init__(self, target: str | None = None):
        super().__init__(target, PYARROW_MISSING)


def pyarrow_modules(target: str | None = None):
    """(pyarrow, pyarrow.parquet), or ParquetUnavailable naming ``target``."""
    try:
        import pyarrow
        import pyarrow.parquet
    except ImportError:
        raise ParquetUnavailable(target) from None
    return pyarrow, pyarrow.parquet


def check_writable(*targets: str | None) -> None:
    """ParquetUnavailable for the first of ``targets`` that asks for Parquet when pyarrow is missing:
    called before any work, so that a run that cannot write its output does not start."""
    for target in targets:
        if is_parquet(target):
            pyarrow_modules(target)


def is_parquet(path: str | None) -> bool:
    """Whether an output path asks for Parquet (its name ends in ``.parquet``, any case)."""
    return bool(path) and str(path).lower().endswith(".parquet")


@dataclass
class Masked:
    """A number column given as values and a null mask (True: no value): written without a copy of the
    values (the NaN rule does not apply)."""

    values: np.ndarray
    null: np.ndarray


@dataclass
class Coded:
    """A text column given as integer codes into ``labels`` (a code outside them is null): written as a
    dictionary column without making a string per row."""

    codes: np.ndarray
    labels: Sequence[str]


def sha256_of(path: str, block: int = 1 << 20) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(block), b""):
            h.update(chunk)
    return h.hexdigest()


def output_metadata(crs_wkt: str | None = None, sources: Iterable = (), **extra) -> dict:
    """tankcd's key-value metadata for an output: ``tankcd.version``, ``tankcd.units``,
    ``tankcd.conventions``, ``tankcd.crs_wkt`` (empty without a CRS), ``tankcd.sources`` (JSON:
    a list of {"path", "sha256"} for each path in ``sources``; a dict there is taken as it is, for a
    source described otherwise), and ``tankcd.<key>`` for each extra key (JSON unless a str)."""
    from tankcd_cli import __version__

    described = [dict(p) if isinstance(p, dict) else {"path": str(p), "sha256": sha256_of(p)}
                 for p in sources if isinstance(p, dict) or (p and p != "-")]
    out = {"tankcd.version": __version__, "tankcd.units": UNITS, "tankcd.conventions": CONVENTIONS,
           "tankcd.crs_wkt": crs_wkt or "", "tankcd.sources": json.dumps(described)}
    for key, value in extra.items():
        out[f"tankcd.{key}"] = value if isinstance(value, str) else json.dumps(value)
    return out


def _arrow_type(pa, kind: str):
    if kind == "dict":
        return pa.dictionary(pa.int32(), pa.string())
    if kind in ("string", "json"):
        return pa.string()
    if kind == "bool":
        return pa.bool_()
    return getattr(pa, kind)()


class ParquetTableWriter:
    """A Parquet file written batch by batch (a row group each), atomically.

    ``schema``: (name, kind) pairs (``COLUMN_TYPES``); ``metadata``: str -> str, stored in the file.
    ``write(columns)`` takes a dict of the schema's columns, each a numpy array (N,), a list, or a
    :class:`Coded` (for ``dict`` columns); a column left out is all null. ``close()`` completes the
    file (renamed onto ``target``); ``abort()`` (or leaving a ``with`` block by an exception)
    removes it. Compression zstd (level 1); float columns byte-stream-split (their bytes grouped by
    place, which zstd compresses far better for smooth numbers), int64 columns delta-packed; min/max
    statistics for the columns named in ``statistics`` (None: all), which readers use to skip row
    groups. ``threaded``: each row group is encoded and written by a thread of its own while the
    caller goes on (pyarrow lets go of the GIL meanwhile), one at a time: at most two batches are
    held; an error there is raised by the next ``write`` or by ``close``.
    """

    def __init__(self, target: str, schema: Sequence[tuple[str, str]], metadata: dict | None = None,
                 compression: str = "zstd", compression_level: int | None = 1,
                 statistics: Sequence[str] | None = None, threaded: bool = False):
        pa, pq = pyarrow_modules(target)
        from tankcd_cli.io.atomic import atomic_path

        for name, kind in schema:
            if kind not in COLUMN_TYPES:
                raise ValueError(f"column {name}: kind {kind!r} is not one of {COLUMN_TYPES}")
        self.target = target
        self.kinds = dict(schema)
        self._pa = pa
        fields = [pa.field(name, _arrow_type(pa, kind)) for name, kind in schema]
        self.schema = pa.schema(fields, metadata={str(k): str(v) for k, v in (metadata or {}).items()})
        self.rows = 0
        self._pool = None
        self._pending = None
        self._stack = contextlib.ExitStack()
        tmp = self._stack.enter_context(atomic_path(target, ".parquet"))
        # encodings: floats byte-stream-split, 64-bit integers (steps: rising) delta-packed, text dictionaries
        encoding = {name: "BYTE_STREAM_SPLIT" for name, kind in schema if kind == "float64"}
        encoding.update({name: "DELTA_BINARY_PACKED" for name, kind in schema if kind == "int64"})
        try:
            leveled = str(compression).lower() in ("zstd", "gzip", "brotli")
            self._writer = self._disk(pq.ParquetWriter, tmp, self.schema, compression=compression,
                                      compression_level=compression_level if leveled else None,
                                      use_dictionary=[name for name, kind in schema if kind == "dict"] or False,
                                      column_encoding=encoding or None,
                                      write_statistics=True if statistics is None else list(statistics))
        except BaseException:
            self._stack.__exit__(*sys.exc_info())
            raise
        if threaded:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(1, thread_name_prefix="tankcd-parquet")

    def write(self, columns: dict) -> None:
        """One batch: a row group of the columns given (all of one length)."""
        pa = self._pa
        lengths = {len(v.codes) if isinstance(v, Coded) else len(v.values) if isinstance(v, Masked) else len(v)
                   for v in columns.values()}
        if len(lengths) > 1:
            raise ValueError(f"columns of different lengths: {sorted(lengths)}")
        unknown = set(columns) - set(self.kinds)
        if unknown:
            raise ValueError(f"columns not in the schema: {sorted(unknown)}")
        n = lengths.pop() if lengths else 0
        arrays = [self._array(name, kind, columns.get(name), n) for name, kind in self.kinds.items()]
        self._write_table(pa.Table.from_arrays(arrays, schema=self.schema))

    def write_arrow(self, table) -> None:
        """One batch given as a pyarrow table of the schema's columns (a row group of another file of
        this schema, being joined into this one): a row group."""
        self._write_table(table.select(list(self.kinds)).cast(self.schema))

    def _write_table(self, table) -> None:
        if self._pool is None:
            self._disk(self._writer.write_table, table)
        else:
            self._wait()
            self._pending = self._pool.submit(self._writer.write_table, table)
        self.rows += table.num_rows

    def _wait(self) -> None:
        """The row group being written (threaded) is written; its error, if any, raised here."""
        pending, self._pending = self._pending, None
        if pending is not None:
            self._disk(pending.result)

    def _disk(self, call, *args, **kw):
        """``call(*args, **kw)``, an OSError of the disk (full, gone, refused) as bad output naming the
        target, as ``io.atomic`` says it of every output (the command line's exit 3, one line)."""
        try:
            return call(*args, **kw)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise InputError(self.target, f"cannot write output: {exc.strerror or exc}") from None

    def _array(self, name, kind, values, n):
        pa = self._pa
        typ = _arrow_type(pa, kind)
        if values is None:
            return pa.nulls(n, type=typ)
        if kind == "dict":
            if isinstance(values, Coded):
                codes = np.asarray(values.codes, dtype=np.int64)
                labels = list(values.labels)
                bad = (codes < 0) | (codes >= len(labels))
                return pa.DictionaryArray.from_arrays(pa.array(np.where(bad, 0, codes).astype(np.int32), mask=bad),
                                                      pa.array(labels, pa.string()))
            arr = np.asarray(values)
            if arr.dtype.kind in "US":
                labels, inverse = np.unique(arr, return_inverse=True)
                return pa.DictionaryArray.from_arrays(pa.array(inverse.reshape(-1).astype(np.int32)),
                                                      pa.array(labels.astype(str).tolist(), pa.string()))
            return pa.array(list(values), pa.string()).dictionary_encode().cast(typ)
        if kind in ("string", "json"):
            if isinstance(values, np.ndarray) and values.dtype.kind == "U":
                return pa.array(values, pa.string())
            return pa.array(list(values), pa.string())
        if isinstance(values, Masked):
            null = np.asarray(values.null, dtype=bool)
            return pa.array(np.asarray(values.values).astype(kind, copy=False), typ, mask=null if null.any() else None)
        arr = np.asarray(values)
        if kind == "float64":
            arr = arr.astype(np.float64, copy=False)
            nan = np.isnan(arr)
            return pa.array(arr, typ, mask=nan if nan.any() else None)
        if kind == "bool":
            if arr.dtype == object:
                mask = np.array([v is None for v in values])
                return pa.array(np.where(mask, False, arr).astype(bool), typ, mask=mask if mask.any() else None)
            return pa.array(arr.astype(bool), typ)
        if arr.dtype == object:  # integers with None for null
            mask = np.array([v is None for v in values])
            return pa.array(np.where(mask, 0, arr).astype(kind), typ, mask=mask if mask.any() else None)
        return pa.array(arr.astype(kind, copy=False), typ)

    def close(self) -> None:
        """Complete the file: it appears at ``target``."""
        if self._writer is None:
            return
        try:
            self._wait()
        except BaseException:
            self.abort(sys.exc_info())
            raise
        self._stop_pool()
        writer, self._writer = self._writer, None
        try:
            self._disk(writer.close)
        except BaseException:
            self._stack.__exit__(*sys.exc_info())
            raise
        self._stack.close()

    def _stop_pool(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def abort(self, exc_info=None) -> None:
        """Give up: nothing is left at ``target`` (or beside it)."""
        if self._writer is None:
            return
        with contextlib.suppress(BaseException):
            self._wait()
        self._stop_pool()
        writer, self._writer = self._writer, None
        with contextlib.suppress(Exception):
            writer.close()
        exc = exc_info or (InterruptedError, InterruptedError("aborted"), None)
        with contextlib.suppress(BaseException):
            self._stack.__exit__(*exc)

    def __enter__(self):
        return self

    def __exit__(self, typ, exc, tb):
        if typ is None:
            self.close()
        else:
            self.abort((typ, exc, tb))
        return False


# -- poses ------------------------------------------------------------------------------------------------
# the pose table's columns (``io.pose_table``), its coded ones dictionary-encoded
POSE_SCHEMA = tuple((name, "dict" if kind == "coded" else kind) for name, kind in POSE_TYPES.items())


def pose_schema(entity: bool = False) -> tuple:
    """The poses' columns (the CSV's, in its order), and ``entity`` last when there are entities."""
    return POSE_SCHEMA + ((("entity", "dict"),) if entity else ())


def pose_columns(step, t, poses, matcher_names, status_names, entity=None) -> dict:
    """The columns of a chunk of poses: the pose table's cells (``io.pose_table``), a cell without a
    value null, numbers at full precision (the CSV rounds them to its decimals), the coded columns
    as their codes and labels; ``entity`` as given."""
    table = pose_table(step, t, poses, matcher_names, status_names)
    out = {"step": table.step}
    for name, values in table.numbers.items():
        out[name] = Masked(values, ~np.isfinite(values))
    for name, codes in table.codes.items():
        out[name] = Coded(codes, list(table.labels[name]))
    if entity is not None:
        out["entity"] = entity
    return out


class PosesParquetWriter(ParquetTableWriter):
    """The poses as Parquet: ``write_chunk(step, t, poses, matcher_names, status_names, entity=None)``
    as ``poses_csv.format_rows`` takes them (see :func:`pose_columns`); ``entity`` (bool) when the rows
    carry an entity column (a (N,) str array per chunk). Threaded by default (``threaded=False`` not)."""

    def __init__(self, target: str, metadata: dict | None = None, entity: bool = False, **kw):
        # statistics for the columns queries select rows by (the others' cost a third of the writing)
        kw.setdefault("statistics", ("step", "t", "entity") if entity else ("step", "t"))
        kw.setdefault("threaded", True)  # the encoding overlaps the replay's next chunk
        super().__init__(target, pose_schema(entity), metadata, **kw)

    def write_chunk(self, step, t, poses, matcher_names, status_names, entity=None) -> None:
        self.write(pose_columns(step, t, poses, matcher_names, status_names, entity))


# -- events -----------------------------------------------------------------------------------------------
# Every event is a row. The fields the kinds of event share or have are typed columns; anything
# else an event carries is in ``extra``, a JSON object (null when there is nothing else). A field
# an event does not have is null. A 3-vector ``point`` is split into point_x, point_y, point_z.
EVENT_SCHEMA = (
    ("step", "int64"),          # the trajectory row (for a contact between rows: the earlier row)
    ("t", "float64"),           # s: the time of the event (of first contact), null where none
    ("kind", "dict"),           # any kind of replay.effects (docs/formats.md, events "By kind")
    ("a", "dict"), ("b", "dict"),  # the two parts (for kind vehicle: the two entities, sorted)
    ("entity", "dict"),         # the vehicle the event concerns
    ("a_part", "dict"), ("b_part", "dict"),  # kind vehicle: the two vehicles' parts
    ("a_step", "int64"), ("b_step", "int64"),  # kind vehicle: each one's earlier row of the interval they met in
    ("between", "bool"),        # a contact that begins between two rows
    ("point_x", "float64"), ("point_y", "float64"), ("point_z", "float64"),  # the contact's world position, m
    ("depth", "float64"),       # m
    ("closing_speed", "float64"),  # m/s
    ("contacts", "int32"),      # contact count
    ("turret_deg", "float64"), ("gun_deg", "float64"),
    ("status", "dict"),         # off_terrain: off or partly_off
    ("method", "dict"),
    ("extra", "json"),          # every other field, as a JSON object
)
_EVENT_TYPED = {name for name, _ in EVENT_SCHEMA} - {"step", "t", "kind", "a", "b", "extra", "point_x", "point_y",
                                                     "point_z"}


def event_columns(events: Sequence) -> dict:
    """Columns (``EVENT_SCHEMA``) of events: objects with step, t, kind, a, b and a dict ``extra``
    (``replay.effects.Event``), or dicts as in the JSON Lines."""
    rows = [_event_dict(e) for e in events]
    n = len(rows)
    cols = {"step": np.array([int(r["step"]) for r in rows], dtype=np.int64),
            "t": np.array([np.nan if r.get("t") is None or not math.isfinite(r["t"]) else float(r["t"]) for r in rows],
                          dtype=np.float64)}
    for name in ("kind", "a", "b"):
        cols[name] = [str(r[name]) for r in rows]
    point = np.full((n, 3), np.nan)
    extra = []
    typed = {name: [] for name in _EVENT_TYPED}
    for i, r in enumerate(rows):
        rest = {}
        for key, value in r.items():
            if key in ("step", "t", "kind", "a", "b"):
                continue
            if key == "point" and _is_vector(value):
                point[i] = [float(c) for c in value]
            elif key in _EVENT_TYPED and _fits(key, value):
                typed[key].append((i, value))
            else:
                rest[key] = value
        extra.append(json.dumps(rest, separators=(",", ":")) if rest else None)
    cols["point_x"], cols["point_y"], cols["point_z"] = point.T
    kinds = dict(EVENT_SCHEMA)
    for name, values in typed.items():
        kind = kinds[name]
        if kind == "float64":
            col = np.full(n, np.nan)
            for i, v in values:
                col[i] = np.nan if v is None else float(v)
        else:
            col = [None] * n
            for i, v in values:
                col[i] = v if v is None else (str(v) if kind == "dict" else v)
            if kind in ("int32", "int64", "bool"):  # None for null: the writer masks them
                col = np.array(col, dtype=object)
        cols[name] = col
    cols["extra"] = extra
    return cols


def _event_dict(e) -> dict:
    if isinstance(e, dict):
        return e
    d = {"step": e.step, "t": e.t, "kind": e.kind, "a": e.a, "b": e.b}
    d.update(getattr(e, "extra", {}) or {})
    return d


def _is_vector(v) -> bool:
    try:
        return len(v) == 3 and all(isinstance(c, (int, float, np.floating, np.integer)) for c in v)
    except TypeError:
        return False


def _fits(key: str, value) -> bool:
    """Whether an event's field goes into its typed column (else into ``extra``)."""
    kind = dict(EVENT_SCHEMA)[key]
    if value is None:
        return True
    if kind == "float64":
        return isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
    if kind == "int32":
        return isinstance(value, (int, np.integer)) and not isinstance(value, bool) and -2**31 <= value < 2**31
    if kind == "int64":
        return isinstance(value, (int, np.integer)) and not isinstance(value, bool) and -2**63 <= value < 2**63
    if kind == "bool":
        return isinstance(value, (bool, np.bool_))
    return isinstance(value, str)


class EventsParquetWriter(ParquetTableWriter):
    """The events as Parquet (``EVENT_SCHEMA``): ``write_events(events)`` per chunk of events."""

    def __init__(self, target: str, metadata: dict | None = None, **kw):
        super().__init__(target, EVENT_SCHEMA, metadata, **kw)

    def write_events(self, events: Sequence) -> None:
        if events:
            self.write(event_columns(events))


def event_dicts(table) -> list:
    """Events read back from an events Parquet table (pyarrow) as the JSON Lines' dicts: typed columns
    that are null left out, ``point`` a list again, ``extra``'s fields merged back."""
    out = []
    for row in table.to_pylist():
        d = {k: row[k] for k in ("step", "t", "kind", "a", "b")}
        if row["point_x"] is not None:
            d["point"] = [row["point_x"], row["point_y"], row["point_z"]]
        for name in _EVENT_TYPED:
            if row[name] is not None:
                d[name] = row[name]
        if row["extra"]:
            d.update(json.loads(row["extra"]))
        out.append(d)
    return out


def file_metadata(path: str) -> dict:
    """tankcd's key-value metadata of a Parquet file (pyarrow's own ``ARROW:`` keys left out)."""
    _, pq = pyarrow_modules()
    kv = pq.read_schema(path).metadata or {}
    return {k.decode(): v.decode() for k, v in kv.items() if not k.startswith(b"ARROW:")}


def join_files(target: str, paths: Sequence[str], metadata: dict | None = None) -> int:
    """One poses or events Parquet file at ``target`` (atomically) of the row groups of ``paths`` in
    order, files of one schema written by the writers here (the parts of a trajectory replayed on
    several workers); its metadata the first file's, updated by ``metadata``. Returns the rows."""
    _, pq = pyarrow_modules(target)
    names = tuple(pq.read_schema(paths[0]).names)
    meta = {**file_metadata(paths[0]), **(metadata or {})}
    if names in (tuple(n for n, _ in pose_schema(False)), tuple(n for n, _ in pose_schema(True))):
        writer = PosesParquetWriter(target, meta, entity="entity" in names)
    elif names == tuple(n for n, _ in EVENT_SCHEMA):
        writer = EventsParquetWriter(target, meta)
    else:
        raise ValueError(f"{paths[0]}: neither a poses nor an events Parquet file (columns {', '.join(names)})")
    with writer:
        for path in paths:
            part = pq.ParquetFile(path)
            for k in range(part.num_row_groups):
                writer.write_arrow(part.read_row_group(k))
    return writer.rows
