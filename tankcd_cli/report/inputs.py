"""A replay's outputs read into a ``Review`` and checked against each other (docs/formats.md,
"Outputs for review"): the poses (CSV or Parquet) and the events (JSON Lines or Parquet).

Only what a review draws is kept: per pose row the step (int64), t, x, y, z, yaw_deg and the
quaternion (float64) and the status (uint8). The poses CSV is read in blocks of bytes by the
project's compiled CSV kernel (``io.csv_kernels.parse_rows``), three passes a block: the numbers
every row has and the entity, the status, then z and the quaternion, which a row with status
``off`` leaves empty (over the block with its empty cells filled by ``EMPTY``, read back as NaN, so
that such rows stay on the compiled path). A line the kernel leaves (a bad cell) is read here in
Python, which names the line and the column.

Every refusal is an ``InputError`` (exit 3) naming the file and the line, row or event.
"""

from __future__ import annotations

import json
import os

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.report.review import STATUS, Review, Source, Track

POSE_COLUMNS = ("step", "t", "x", "y", "z", "yaw_deg", "qw", "qx", "qy", "qz")
"""The numeric columns a review reads, in this order (``status`` too, and ``entity`` when there)."""
PLACED = ("z", "qw", "qx", "qy", "qz")  # empty on a row with status off, finite on every other row
TIME_SLACK = 1e-6  # s: how far an event's t may lie from its row's (both are rounded to 6 decimals)
BLOCK = 1 << 22  # bytes of the poses CSV read at a time
EMPTY = -1e-300  # what an empty number cell is read as (no writer writes it), then NaN
_EMPTY_TEXT = b"-1e-300"
_OFF = STATUS.index("off")


def is_parquet(path: str) -> bool:
    return str(path).lower().endswith(".parquet")


def read_review(poses: str, events: str, crs_wkt: str = "", sources=(), vehicle_length: float = 6.86,
                vehicle_width: float = 3.46) -> Review:
    """The review of a replay's ``poses`` and ``events`` files (a name ending in ``.parquet``, any
    case: Parquet; else the poses CSV and the events JSON Lines), checked against each other.

    crs_wkt : the terrain's CRS (WKT); '' takes the Parquet metadata's, if any
    sources : further ``Source`` records (the scene or terrain the caller read)
    vehicle_length, vehicle_width : the hull footprint, m
    """
    for path in (poses, events):
        if path == "-":
            raise InputError("-", "a review reads its poses and events from files, not standard input")
        if os.path.isdir(path):
            raise InputError(path, "is a directory, not a file")
        if not os.path.exists(path):
            raise InputError(path, "no such file")
    meta_poses = _parquet_metadata(poses) if is_parquet(poses) else {}
    meta_events = _parquet_metadata(events) if is_parquet(events) else {}
    _same_run(poses, meta_poses, events, meta_events)
    tracks = read_poses_parquet(poses) if is_parquet(poses) else read_poses_csv(poses)
    evs, where = read_events_parquet(events) if is_parquet(events) else read_events_jsonl(events)
    check_events(tracks, evs, where, events)

    from tankcd_cli.io.parquet import sha256_of

    found = [Source("poses", poses, sha256_of(poses)), Source("events", events, sha256_of(events)), *sources]
    for meta in (meta_poses, meta_events):
        for s in _metadata_sources(meta):
            if s not in found:
                found.append(s)
    meta = meta_poses or meta_events
    settings = {}
    if meta.get("tankcd.replay"):
        try:
            settings = json.loads(meta["tankcd.replay"])
        except ValueError:
            raise InputError(poses if meta_poses else events, "metadata tankcd.replay is not JSON") from None
    return Review(tracks=tuple(tracks), events=evs, crs_wkt=crs_wkt or meta.get("tankcd.crs_wkt", ""),
                  sources=tuple(found), settings=settings if isinstance(settings, dict) else {},
                  tankcd_version=meta.get("tankcd.version", ""), vehicle_length=float(vehicle_length),
                  vehicle_width=float(vehicle_width))


# --- Parquet metadata ------------------------------------------------------------------------------

def _parquet_metadata(path: str) -> dict:
    """tankcd's key-value metadata of a Parquet input (``io.parquet.file_metadata``), its failures
    one line naming the file."""
    try:
        import pyarrow as pa
    except ImportError:
        raise InputError(path, "reading Parquet needs pyarrow: pip install 'tankcd[parquet]'") from None
    from tankcd_cli.io.parquet import file_metadata

    try:
        return file_metadata(path)
    except (pa.ArrowInvalid, OSError) as exc:
        raise InputError(path, f"not a Parquet file ({str(exc).splitlines()[0][:120]})") from None


def _metadata_list(meta: dict) -> list:
    try:
        got = json.loads(meta.get("tankcd.sources") or "[]")
    except ValueError:
        return []
    return [s for s in got if isinstance(s, dict)] if isinstance(got, list) else []


def _metadata_sources(meta: dict) -> list:
    """The replay's own sources as ``Source`` records (a store: its own record of what it came from)."""
    out = []
    for s in _metadata_list(meta):
        sha = s.get("sha256") or s.get("source_sha256") or ""
        out.append(Source(str(s.get("role", "")), str(s.get("path", "")), str(sha)))
    return out


def _same_run(poses: str, meta_poses: dict, events: str, meta_events: dict) -> None:
    """Poses and events whose metadata both name the trajectories they came from name the same."""
    def hashes(meta):
        return sorted(str(s.get("sha256", "")) for s in _metadata_list(meta) if s.get("role") == "trajectory")

    a, b = hashes(meta_poses), hashes(meta_events)
    if a and b and a != b:
        raise InputError(events, f"poses and events come from different runs: the trajectory SHA-256 in "
                                 f"{poses}'s metadata ({', '.join(h[:12] for h in a)}) is not this file's "
                                 f"({', '.join(h[:12] for h in b)})")


# --- poses ---------------------------------------------------------------------------------------

class _Columns:
    """Pose rows gathered chunk by chunk, then split into tracks by entity code."""

    def __init__(self):
        self.parts: list = []
        self.names: list = []  # entity names in code order (first appearance)

    def add(self, step: np.ndarray, values: np.ndarray, status: np.ndarray, codes: np.ndarray | None) -> None:
        """step (n,) int64; values (n, 9) float64: ``POSE_COLUMNS[1:]`` (t, x, y, z, yaw_deg, qw..qz);
        status (n,) uint8; codes (n,) the rows' entity codes (None: one unnamed vehicle)."""
        n = len(values)
        self.parts.append((np.asarray(step, np.int64), np.ascontiguousarray(values, np.float64),
                           status.astype(np.uint8),
                           np.zeros(n, np.int64) if codes is None else codes.astype(np.int64)))

    def tracks(self) -> list:
        names = self.names or [""]
        if not self.parts:
            return []
        step = np.concatenate([p[0] for p in self.parts])
        num = np.concatenate([p[1] for p in self.parts])
        status = np.concatenate([p[2] for p in self.parts])
        codes = np.concatenate([p[3] for p in self.parts])
        self.parts = []
        order = np.argsort(codes, kind="stable")  # each entity's rows in file order; entities by first row
        ends = np.cumsum(np.bincount(codes, minlength=len(names)))
        out = []
        for k, name in enumerate(names):
            rows = order[(ends[k - 1] if k else 0):ends[k]]
            if not len(rows):
                continue
            v = num[rows]
            out.append(Track(entity=name, step=step[rows], t=v[:, 0].copy(), x=v[:, 1].copy(), y=v[:, 2].copy(),
                             z=v[:, 3].copy(), yaw_deg=v[:, 4].copy(), quaternion=np.ascontiguousarray(v[:, 5:9]),
                             status=status[rows]))
        return out


def _check_rows(name: str, values: np.ndarray, status: np.ndarray, where) -> None:
    """Rows not off have finite t, x, y, z, yaw_deg and quaternion (values (n, 9) as ``_Columns.add``
    takes them); every row its x, y. ``where(i)`` names row i."""
    cols = POSE_COLUMNS[1:]
    finite = np.isfinite(values)
    bad = np.flatnonzero((status != _OFF) & ~finite.all(axis=1))
    if len(bad):
        i = int(bad[0])
        col = cols[int(np.flatnonzero(~finite[i])[0])]
        raise InputError(name, f"{col} is empty or not finite on a row with status {STATUS[status[i]]} "
                               "(only rows with status off go without a pose)", where=where(i))
    off = np.flatnonzero((status == _OFF) & ~np.isfinite(values[:, 1:3]).all(axis=1))
    if len(off):
        raise InputError(name, "x or y is empty or not finite (every row keeps its position)",
                         where=where(int(off[0])))


def read_poses_csv(path: str, block: int = BLOCK) -> list:
    """The tracks of a poses CSV (``Track`` per entity, in order of first appearance)."""
    from tankcd_cli.io.csv_kernels import POW10, Interner, parse_rows

    with open(path, "rb") as fh:
        head = fh.readline()
        line0 = 1
        if head.startswith(b"\xef\xbb\xbf"):
            head = head[3:]
        try:
            header = [h.strip().strip('"').strip() for h in head.decode("utf-8").rstrip("\r\n").split(",")]
        except UnicodeDecodeError:
            raise InputError(path, "not UTF-8 text (poses are a CSV file)", where="line 1") from None
        if not head.strip():
            raise InputError(path, "file is empty (a poses CSV starts with its header: step,t,x,y,z,...)")
        need = POSE_COLUMNS + ("status",)
        missing = [c for c in need if c not in header]
        if missing:
            raise InputError(path, f"header lacks the poses column{'s' if len(missing) > 1 else ''} "
                                   f"{', '.join(missing)} (found: {', '.join(header)[:200]}; poses are what "
                                   "`tankcd replay --poses` writes)", where="line 1")
        dup = [c for c in need + ("entity",) if header.count(c) > 1]
        if dup:
            raise InputError(path, f"column {dup[0]} appears twice in the header", where="line 1")
        width = len(header)
        entity = "entity" in header
        # three compiled passes over each block: (1) the numbers every row has and the entity, (2) the
        # status as text, (3) the numbers a row with status off leaves empty, over the block with its
        # empty cells filled by EMPTY (so that such rows stay on the compiled path), read back as NaN
        text_col = len(POSE_COLUMNS) if entity else -1
        always = np.full(width, -1, np.int32)
        placed = np.full(width, -1, np.int32)
        for j, c in enumerate(POSE_COLUMNS):
            (placed if c in PLACED else always)[header.index(c)] = j
        if entity:
            always[header.index("entity")] = text_col
        statuses = np.full(width, -1, np.int32)
        statuses[header.index("status")] = 0
        cols = _Columns()
        ent = Interner() if entity else None
        stat = Interner()
        status_of: list = []  # status interner code -> STATUS index
        reader = _CsvPass(path, header, width)
        rest = b""
        line = line0
        while True:
            chunk = fh.read(block)
            data = rest + chunk
            if not data:
                break
            if chunk:
                cut = data.rfind(b"\n") + 1
                if cut == 0:
                    rest = data
                    continue
                data, rest = data[:cut], data[cut:]
            else:
                rest = b""
            buf = np.frombuffer(data, np.uint8)
            m = data.count(b"\n") + 1
            vals = np.empty((len(POSE_COLUMNS), m))
            lines, spans, n, line_end = reader.run(data, buf, always, text_col, vals, line, parse_rows, POW10)
            slines, sspans, n2, _ = reader.run(data, buf, statuses, 0, np.empty((1, m)), line, parse_rows, POW10)
            if n2 != n:  # pragma: no cover (the passes skip the same blank lines)
                raise RuntimeError("poses CSV passes disagree on the rows")
            line = line_end
            if n == 0:
                continue
            got, first, firsts = stat.codes(buf, sspans[:n], n)
            for k in range(first, len(stat)):
                word = stat.name(k).decode("utf-8", errors="replace")
                if word not in STATUS:
                    raise InputError(path, f"status {word[:40]!r} is not one of {', '.join(STATUS)}",
                                     where=f"line {slines[int(firsts[k - first])]}")
                status_of.append(STATUS.index(word))
            status = np.asarray(status_of, np.uint8)[got]
            # without a row off in the block, its z and quaternion cells are all numbers (the careful
            # reader names an empty one); with one, the empty cells are filled first (``_fill_empty``)
            filled = _fill_empty(data) if (status == _OFF).any() else data
            _, _, n3, _ = reader.run(filled, np.frombuffer(filled, np.uint8), placed, -1, vals, line, parse_rows,
                                     POW10)
            if n3 != n:  # pragma: no cover
                raise RuntimeError("poses CSV passes disagree on the rows")
            if filled is not data:
                vals[:, :n][vals[:, :n] == EMPTY] = np.nan
            codes = None
            if entity:
                codes, first, firsts = ent.codes(buf, spans[:n], n)
                for k in range(first, len(ent)):
                    try:
                        cols.names.append(ent.name(k).decode("utf-8"))
                    except UnicodeDecodeError:
                        raise InputError(path, "not UTF-8 text (poses are a CSV file)",
                                         where=f"line {lines[int(firsts[k - first])]}") from None
            values = vals[1:, :n].T
            _check_rows(path, values, status, lambda i: f"line {lines[i]}")
            cols.add(vals[0, :n].astype(np.int64), values, status, codes)
            if not chunk:
                break
    return cols.tracks()


def _fill_empty(data: bytes) -> bytes:
    """The lines with every empty cell (between two commas, or last) holding ``EMPTY``."""
    for _ in range(2):  # ",,," takes two: each replacement consumes the comma after it
        data = data.replace(b",,", b"," + _EMPTY_TEXT + b",")
    return data.replace(b",\r\n", b"," + _EMPTY_TEXT + b"\r\n").replace(b",\n", b"," + _EMPTY_TEXT + b"\n")


class _CsvPass:
    """One pass of the compiled kernel over a block of whole lines, with the lines it leaves read here."""

    def __init__(self, name: str, header: list, width: int):
        self.name, self.header, self.width = name, header, width

    def run(self, data, buf, colmap, text_col, values, line, parse_rows, pow10):
        """(line of each row (m,), text spans (m, 2), rows, the last line number) of the whole lines
        ``data`` (bytes; ``buf`` the same as uint8), the numbers into ``values`` (columns, m)."""
        m = values.shape[1]
        line_of = np.empty(m, np.int64)
        span = np.zeros((m, 2), np.int64)
        iso_s, iso_ns = np.empty(m, np.int64), np.empty(m, np.int64)
        end = len(buf)
        pos = r = 0
        checked_utf8 = False
        while True:
            r, pos, line, state = parse_rows(buf, pos, end, True, m, self.width, 44, colmap, text_col, -1, pow10,
                                             values, line_of, span, iso_s, iso_ns, r, line)
            if state & 2 and not checked_utf8:
                self._utf8(buf, line)
                checked_utf8 = True
            if not state & 1:
                return line_of, span, r, line
            nl = data.find(b"\n", pos)
            nl = end if nl < 0 else nl
            line += 1
            cells, starts = self._cells(data[pos:nl], line)
            if cells is not None:
                for c, j in enumerate(colmap.tolist()):
                    if j < 0:
                        continue
                    cell = cells[c].strip(b" \t")
                    if j == text_col:
                        if not cell:
                            raise InputError(self.name, f"{self.header[c]} is empty", where=f"line {line}")
                        lead = len(cells[c]) - len(cells[c].lstrip(b" \t"))
                        span[r] = (pos + starts[c] + lead, pos + starts[c] + lead + len(cell))
                    else:
                        values[j, r] = self._number(cell, line, self.header[c])
                line_of[r] = line
                r += 1
            pos = min(nl + 1, end)

    def _cells(self, raw: bytes, line: int):
        try:
            raw.decode("utf-8")
        except UnicodeDecodeError:
            raise InputError(self.name, "not UTF-8 text (poses are a CSV file)", where=f"line {line}") from None
        body = raw[:-1] if raw.endswith(b"\r") else raw
        if not body.strip():
            return None, None
        cells = body.split(b",")
        if len(cells) != self.width:
            raise InputError(self.name, f"expected {self.width} columns as in the header, found {len(cells)}",
                             where=f"line {line}")
        starts = np.cumsum([0] + [len(c) + 1 for c in cells[:-1]]).tolist()
        return cells, starts

    def _number(self, cell: bytes, line: int, column: str) -> float:
        if not cell:
            if column == "step":
                raise InputError(self.name, "step is empty", where=f"line {line}")
            return np.nan  # a row without a pose (status off): judged with its status
        try:
            value = float(cell)
        except ValueError:
            raise InputError(self.name, f"not a number: {cell.decode(errors='replace')[:40]!r}",
                             where=f"line {line} column {column}") from None
        if not np.isfinite(value):
            raise InputError(self.name, f"non-finite value {cell.decode()!r}", where=f"line {line} column {column}")
        if column == "step" and value != int(value):
            raise InputError(self.name, f"step {cell.decode()!r} is not a whole number", where=f"line {line}")
        return value

    def _utf8(self, buf, line: int) -> None:
        data = bytes(buf)
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as exc:
            at = line + data[:exc.start].count(b"\n") + 1
            raise InputError(self.name, "not UTF-8 text (poses are a CSV file)", where=f"line {at}") from None


def read_poses_parquet(path: str) -> list:
    """The tracks of a poses Parquet file, read by row group, only the columns a review needs."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        pf = pq.ParquetFile(path)
    except (pa.ArrowInvalid, OSError) as exc:
        raise InputError(path, f"not a Parquet file ({str(exc).splitlines()[0][:120]})") from None
    names = pf.schema_arrow.names
    need = POSE_COLUMNS + ("status",)
    missing = [c for c in need if c not in names]
    if missing:
        raise InputError(path, f"lacks the poses column{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
                               f"(found: {', '.join(names)[:200]}; poses are what `tankcd replay --poses` writes)")
    entity = "entity" in names
    cols = _Columns()
    index: dict = {}

    def entity_code(word):
        if word not in index:
            index[word] = len(cols.names)
            cols.names.append(word)
        return index[word]

    first_row = 0
    for batch in pf.iter_batches(columns=list(need) + (["entity"] if entity else []), batch_size=65536):
        n = batch.num_rows
        step = batch.column("step")
        if step.null_count:
            i = int(np.flatnonzero(np.asarray(step.is_null()))[0])
            raise InputError(path, "step is null", where=f"row {first_row + i + 1}")
        values = np.empty((n, len(POSE_COLUMNS) - 1))
        for j, c in enumerate(POSE_COLUMNS[1:]):  # null: NaN
            values[:, j] = np.asarray(batch.column(c).to_numpy(zero_copy_only=False), dtype=np.float64)
        status = _coded(path, batch.column("status"), "status", first_row,
                        lambda w: STATUS.index(w) if w in STATUS else None)
        codes = _coded(path, batch.column("entity"), "entity", first_row, entity_code) if entity else None
        _check_rows(path, values, status, lambda i: f"row {first_row + i + 1}")
        cols.add(np.asarray(step.to_numpy(zero_copy_only=False), np.int64), values, status, codes)
        first_row += n
    return cols.tracks()


def _coded(path, col, name, first_row, code_of) -> np.ndarray:
    """A text column (dictionary or plain strings) as codes (n,) int64, by ``code_of(word)`` once per
    distinct word in order of first appearance; a null, or a word ``code_of`` refuses (None), is
    named by its row."""
    import pyarrow as pa

    if not pa.types.is_dictionary(col.type):
        col = col.dictionary_encode()
    if col.null_count:
        i = int(np.flatnonzero(np.asarray(col.is_null()))[0])
        raise InputError(path, f"{name} is null", where=f"row {first_row + i + 1}")
    words = col.dictionary.to_pylist()
    idx = np.asarray(col.indices.to_numpy(zero_copy_only=False), np.int64)
    table = np.full(len(words), -1, np.int64)
    present, first = np.unique(idx, return_index=True)
    for i, k in sorted(zip(first.tolist(), present.tolist())):  # (first row, word index)
        got = code_of(words[k])
        if got is None:
            raise InputError(path, f"{name} {str(words[k])[:40]!r} is not one of {', '.join(STATUS)}",
                             where=f"row {first_row + i + 1}")
        table[k] = got
    return table[idx]


# --- events --------------------------------------------------------------------------------------

def read_events_jsonl(path: str) -> tuple[list, list]:
    """(the events as dicts, where each is: its line) of an events JSON Lines file."""
    events, where = [], []
    try:
        with open(path, encoding="utf-8") as fh:
            for lineno, line in enumerate(fh, 1):
                if not line.strip():
                    continue
                try:
                    e = json.loads(line)
                except ValueError as exc:
                    raise InputError(path, f"not a JSON object ({exc.msg})", where=f"line {lineno}") from None
                if not isinstance(e, dict):
                    raise InputError(path, "not a JSON object (an event is one object a line)", where=f"line {lineno}")
                events.append(e)
                where.append(f"line {lineno}")
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text (events are JSON Lines)") from None
    return events, where


def read_events_parquet(path: str) -> tuple[list, list]:
    """(the events as the JSON Lines' dicts, where each is: its row) of an events Parquet file."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from tankcd_cli.io.parquet import EVENT_SCHEMA, event_dicts

    try:
        table = pq.read_table(path)
    except (pa.ArrowInvalid, OSError) as exc:
        raise InputError(path, f"not a Parquet file ({str(exc).splitlines()[0][:120]})") from None
    missing = [n for n, _ in EVENT_SCHEMA if n not in table.column_names]
    if missing:
        raise InputError(path, f"lacks the events column{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
                               "(events are what `tankcd replay --events` writes)")
    events = event_dicts(table)
    return events, [f"row {i + 1}" for i in range(len(events))]


def check_events(tracks: list, events: list, where: list, name: str) -> None:
    """Each event against the poses: its step a pose row's, its entity (a vehicle event's a and b)
    a vehicle of the poses, the step a row of that vehicle, its t that row's (an event at a row; a
    vehicle event's may be b's row at ``b_step``, where b begins to exist) or between that row's
    and the vehicle's next row's (``"between": true``), to ``TIME_SLACK``.
    The first event in the file's order that fails is named."""
    n = len(events)
    if n == 0:
        return
    by_name = {tr.entity: k for k, tr in enumerate(tracks)}
    step = np.empty(n, np.int64)
    t = np.full(n, np.nan)
    owner = np.full(n, -1, np.int64)
    between = np.zeros(n, bool)
    # a vehicle event at a row may be at the other vehicle's row: where that one begins to exist
    other = np.full(n, -1, np.int64)
    other_step = np.zeros(n, np.int64)
    first_bad: dict = {}  # check -> first event failing it (checks by Python per event, then vectorized ones)
    for i, e in enumerate(events):
        s = e.get("step")
        if isinstance(s, bool) or not isinstance(s, (int, float)) or s != s or int(s) != s:
            raise InputError(name, f"event has no whole-number step ({s!r})", where=where[i])
        step[i] = int(s)
        if e.get("t") is not None:
            if isinstance(e["t"], bool) or not isinstance(e["t"], (int, float)):
                raise InputError(name, f"event t {e['t']!r} is not a number", where=where[i])
            t[i] = float(e["t"])
        ent = e.get("entity", e.get("a") if e.get("kind") == "vehicle" else "")
        owner[i] = by_name.get(ent if isinstance(ent, str) else "", -1)
        if owner[i] < 0 and "entity" not in first_bad:
            first_bad["entity"] = (i, f"entity {ent!r} has no pose rows" if "entity" in e or e.get("kind") == "vehicle"
                                   else "the event names no entity, and the poses' vehicles all have names")
        if e.get("kind") == "vehicle":
            for side in ("a", "b"):
                if e.get(side) not in by_name and "entity" not in first_bad:
                    first_bad["entity"] = (i, f"vehicle event's {side} {e.get(side)!r} has no pose rows")
        between[i] = e.get("between") is True
        if e.get("kind") == "vehicle" and isinstance(e.get("b_step"), int) and not isinstance(e["b_step"], bool):
            other[i], other_step[i] = by_name.get(e.get("b"), -1), e["b_step"]
    all_steps = np.unique(np.concatenate([tr.step for tr in tracks])) if tracks else np.zeros(0, np.int64)
    known = np.isin(step, all_steps)
    if not known.all():
        i = int(np.flatnonzero(~known)[0])
        first_bad["step"] = (i, f"step {step[i]} is no pose row's step")
    row_t = np.full(n, np.nan)
    other_t = np.full(n, np.nan)  # a vehicle event's b at its b_step
    next_t = np.full(n, np.nan)
    for k, tr in enumerate(tracks):  # a loop per vehicle, vectorized over its events
        order = np.argsort(tr.step, kind="stable")
        theirs = np.flatnonzero(other == k)
        if len(theirs):
            at = np.minimum(np.searchsorted(tr.step[order], other_step[theirs]), len(order) - 1)
            found = tr.step[order][at] == other_step[theirs]
            other_t[theirs[found]] = tr.t[order[at[found]]]
        mine = np.flatnonzero((owner == k) & known)
        if not len(mine):
            continue
        at = np.searchsorted(tr.step[order], step[mine])
        hit = at < len(order)
        hit[hit] = tr.step[order][at[hit]] == step[mine][hit]
        if not hit.all():
            i = int(mine[np.flatnonzero(~hit)[0]])
            if "row" not in first_bad or i < first_bad["row"][0]:
                first_bad["row"] = (i, f"step {step[i]} is not a row of {tr.entity or 'the vehicle'!s}")
        rows = order[at[hit]]
        row_t[mine[hit]] = tr.t[rows]
        nxt = np.minimum(rows + 1, len(tr) - 1)
        next_t[mine[hit]] = tr.t[nxt]
    slack = TIME_SLACK * (1 + 1e-9)
    timed = np.isfinite(t) & np.isfinite(row_t)
    at_row = timed & ~between & (np.abs(t - row_t) > slack) & ~(np.abs(t - other_t) <= slack)
    if at_row.any():
        i = int(np.flatnonzero(at_row)[0])
        first_bad["t"] = (i, f"t {t[i]:.6f} is not its row's t {row_t[i]:.6f} (step {step[i]}; an event at a row "
                             "has the row's time)")
    off = timed & between & ((t < row_t - slack) | (t > np.where(np.isfinite(next_t), next_t, row_t) + slack))
    if off.any():
        i = int(np.flatnonzero(off)[0])
        if "t" not in first_bad or i < first_bad["t"][0]:
            first_bad["t"] = (i, f"t {t[i]:.6f} of an event between rows lies outside its row's t {row_t[i]:.6f} "
                                 f"and the vehicle's next row's t {next_t[i]:.6f} (step {step[i]})")
    if first_bad:
        i, what = min(first_bad.values(), key=lambda v: v[0])
        priority = [first_bad[c] for c in ("step", "entity", "row", "t") if c in first_bad and first_bad[c][0] == i]
        raise InputError(name, priority[0][1], where=f"{where[i]} (event {i + 1})")
