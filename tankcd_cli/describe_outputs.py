"""``tankcd info`` of what tankcd writes: events (JSON Lines), poses and events as Parquet, a replay
summary (JSON) and a fleet's fleet.json (docs/formats.md, "info --json").

Each describer reads its file once, streamed where the file may be long: the JSON Lines line by line,
a Parquet file by its footer (row count, row groups, column statistics, tankcd's key-value metadata)
and then only the few text columns the counts need, one row group at a time. Memory holds one row
group (or one line) and the counters, whose keys are the names the file holds (kinds, obstacles,
parts, entities), never its rows. The facts follow ``describe``'s conventions (plain values,
snake_case keys, ``*_fraction`` a share from 0 to 1).
"""

from __future__ import annotations

import json
import math
import re
from collections import Counter

from tankcd_cli.errors import InputError
from tankcd_cli.replay.effects import ALL_KINDS, KINDS

PARQUET_MAGIC = b"PAR1"
EVENT_KEYS = ("step", "kind", "a", "b")  # what every event carries (docs/formats.md, "Events (JSON Lines)")
SUMMARY_KEYS = ("rows", "collisions", "off_terrain", "effects", "matchers")  # a replay summary's own
FLEET_KEYS = ("trajectories", "tasks", "ok", "failed", "world")  # fleet.json's own
EVENT_KINDS = ALL_KINDS  # every kind of event, in the order formats.md lists them (replay.effects)


# --- which of them a file is ------------------------------------------------------------------

def is_parquet_file(path: str) -> bool:
    """Whether ``path`` starts with Parquet's magic number (``PAR1``; it ends with it too)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(4) == PARQUET_MAGIC
    except OSError:
        return False


def json_kind(path: str) -> str | None:
    """``events``, ``summary``, ``fleet`` or ``json`` (JSON, but none of tankcd's) for a file whose
    first non-blank character is ``{``, by the keys of its first object; None for any other file.

    A file of one JSON object a line is told from one indented object by its first line alone:
    it parses by itself. A first line that does not is the start of one object (fleet.json and
    ``--summary FILE`` are indented), read whole to see its keys."""
    first = _first_line(path)
    if first is None or not first.lstrip().startswith("{"):
        return None
    try:
        obj = json.loads(first)
    except ValueError:
        obj = _load_json(path)
    if not isinstance(obj, dict):
        return "json"
    keys = set(obj)
    if set(EVENT_KEYS) <= keys:
        return "events"
    if set(FLEET_KEYS) <= keys:
        return "fleet"
    if set(SUMMARY_KEYS) <= keys:
        return "summary"
    return "json"


def _first_line(path: str, limit: int = 1 << 20) -> str | None:
    """The file's first non-blank line (at most ``limit`` bytes of it), or None if it is not text."""
    try:
        with open(path, "rb") as fh:
            while True:
                line = fh.readline(limit)
                if not line:
                    return None
                if line.strip():
                    break
    except OSError:
        return None
    try:
        return line.decode("utf-8-sig")
    except UnicodeDecodeError:
        return None


def _load_json(path: str):
    try:
        with open(path, encoding="utf-8-sig") as fh:
            return json.load(fh)
    except ValueError as exc:
        where = f"line {exc.lineno}" if getattr(exc, "lineno", None) else None
        raise InputError(path, f"not valid JSON: {getattr(exc, 'msg', exc)}", where=where) from None
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None


def describe_json(path: str, kind: str) -> dict:
    """The facts of a JSON file ``json_kind`` named."""
    if kind == "events":
        return describe_events_jsonl(path)
    if kind == "summary":
        return describe_summary(path)
    if kind == "fleet":
        return describe_fleet(path)
    raise InputError(path, "a JSON file, but not one tankcd writes (not events, a replay summary or fleet.json)")


# --- events -------------------------------------------------------------------------------------

class EventTally:
    """Counts of events as they stream past: per kind, between rows, the time and step span, and
    the names in them: obstacles (``b`` of an obstacle event), vehicle parts (``a`` of an obstacle,
    internal or terrain event, ``a_part`` and ``b_part`` of a vehicle event) and entities (an
    event's ``entity``, and ``b`` of a vehicle event: both vehicles in contact)."""

    def __init__(self):
        self.events = 0
        self.kinds: Counter = Counter()
        self.between = 0
        self.no_t = 0
        self.t = [math.inf, -math.inf]
        self.step = [math.inf, -math.inf]
        self.obstacles: Counter = Counter()
        self.parts: Counter = Counter()
        self.entities: Counter = Counter()

    def add(self, e: dict) -> None:
        """One event as the JSON Lines' dict."""
        self.events += 1
        kind = str(e["kind"])
        self.kinds[kind] += 1
        if e.get("between") is True:
            self.between += 1
        self._span(self.step, e.get("step"))
        t = e.get("t")
        if isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t):
            self._span(self.t, t)
        else:
            self.no_t += 1
        if kind == "obstacle":
            self.obstacles[str(e["b"])] += 1
        if kind in KINDS:  # a vehicle part against something
            self.parts[str(e["a"])] += 1
        if kind == "vehicle":
            for key in ("a_part", "b_part"):
                if e.get(key) is not None:
                    self.parts[str(e[key])] += 1
            self.entities[str(e["b"])] += 1
            self.entities[str(e.get("entity", e["a"]))] += 1
        elif e.get("entity") is not None:
            self.entities[str(e["entity"])] += 1

    @staticmethod
    def _span(span: list, value) -> None:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            span[0], span[1] = min(span[0], value), max(span[1], value)

    def facts(self) -> dict:
        kinds = {k: self.kinds[k] for k in EVENT_KINDS if self.kinds[k]}
        kinds.update({k: n for k, n in sorted(self.kinds.items()) if k not in kinds})
        return {"events": self.events, "by_kind": kinds, "between": self.between,
                "between_fraction": round(self.between / self.events, 6) if self.events else 0.0,
                "t_first": _time(self.t[0]), "t_last": _time(self.t[1]),
                "step_first": _step(self.step[0]), "step_last": _step(self.step[1]),
                **({"events_without_t": self.no_t} if self.no_t else {}),
                "obstacles": dict(sorted(self.obstacles.items())), "parts": dict(sorted(self.parts.items())),
                "entities": dict(sorted(self.entities.items()))}


def _time(v):
    """A time as info shows it (6 decimals, no -0), None for none."""
    return None if v is None or not math.isfinite(v) else round(float(v), 6) + 0.0


def _step(v):
    return None if v is None or not math.isfinite(v) else int(v)


def describe_events_jsonl(path: str) -> dict:
    """Events JSON Lines (``replay --events``), streamed: through pyarrow's JSON reader by blocks
    when pyarrow is installed and the file is plainly one event a line (else, or when it finds
    anything else, line by line in Python, which names the line that is not an event: not a JSON
    object with step, kind, a and b). Both count as ``EventTally.add`` does (a test)."""
    facts = _events_jsonl_by_arrow(path)
    if facts is None:
        facts = _events_jsonl_by_lines(path)
    return {"file": path, "kind": "events", "format": "JSON Lines", **facts}


def _events_jsonl_by_arrow(path: str, block: int = 1 << 20) -> dict | None:
    """The counts by pyarrow's JSON reader, or None where it cannot vouch for them: no pyarrow, a
    parse or type error, an event without step, kind, a or b, or not one event a line (blank
    lines, two objects on one line): the line reader then says what is wrong."""
    try:
        import pyarrow as pa
        import pyarrow.json as pj
    except ImportError:
        return None
    types = {"int64": pa.int64(), "float64": pa.float64(), "string": pa.string(), "bool": pa.bool_()}
    schema = pa.schema([(name, types[kind]) for name, kind in EVENT_COLUMNS.items()])
    tally = EventTally()
    try:
        reader = pj.open_json(path, read_options=pj.ReadOptions(block_size=block, use_threads=False),
                              parse_options=pj.ParseOptions(explicit_schema=schema, unexpected_field_behavior="ignore"))
        for batch in reader:
            if any(batch.column(k).null_count for k in EVENT_KEYS):
                return None
            tally_batch(tally, batch)
    except (pa.ArrowException, OSError, ValueError):
        return None
    if tally.events != _line_count(path):
        return None
    return tally.facts()


def _line_count(path: str, block: int = 1 << 22) -> int:
    """Lines in the file (a last line without its newline counted)."""
    count, last = 0, b"\n"
    with open(path, "rb") as fh:
        while chunk := fh.read(block):
            count += chunk.count(b"\n")
            last = chunk[-1:]
    return count + (last != b"\n")


def _events_jsonl_by_lines(path: str) -> dict:
    tally = EventTally()
    try:
        with open(path, encoding="utf-8-sig") as fh:
            for number, line in enumerate(fh, 1):
                if not line.strip():
                    continue
                try:
                    e = json.loads(line)
                except ValueError as exc:
                    raise InputError(path, f"not JSON: {getattr(exc, 'msg', exc)}", where=f"line {number}") from None
                if not isinstance(e, dict) or not set(EVENT_KEYS) <= set(e):
                    raise InputError(path, "not an event: an object with step, kind, a and b", where=f"line {number}")
                tally.add(e)
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text: not an events file") from None
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    return tally.facts()


# --- poses CSV ----------------------------------------------------------------------------------------

def is_poses_csv(path: str) -> bool:
    """Whether the file starts with the poses CSV's header (``io.poses_csv.header``, with or without
    ``entity``)."""
    from tankcd_cli.io.poses_csv import header

    first = _first_line(path)
    return first is not None and first.rstrip("\r\n") in (header(False).rstrip("\n"), header(True).rstrip("\n"))


def describe_poses_csv(path: str) -> dict:
    """A poses CSV (``replay --poses``), streamed: rows, the step and time span, rows per status and
    per entity. Through pyarrow's CSV reader by blocks when pyarrow is installed and finds nothing
    wrong, else line by line in Python, which names a row without the header's columns (an
    InputError); both give the same facts (a test)."""
    return _poses_csv_by_arrow(path) or _poses_csv_by_lines(path)


def _poses_csv_by_arrow(path: str, block: int = 1 << 20) -> dict | None:
    """The facts by pyarrow's CSV reader, or None where it finds anything wrong (the line reader
    then names it). Blocks of 1 MiB: the reader keeps some 30 of them in flight (34 MB measured
    on a 164 MB file, 121 MB at 4 MiB blocks)."""
    try:
        import pyarrow as pa
        import pyarrow.compute as pc
        import pyarrow.csv as pcsv
    except ImportError:
        return None
    first = _first_line(path).rstrip("\r\n").split(",")
    wanted = {"step": pa.int64(), "t": pa.float64(), "status": pa.string()}
    if "entity" in first:
        wanted["entity"] = pa.string()
    rows, status, entity = 0, Counter(), Counter()
    t, step = [math.inf, -math.inf], [None, None]
    try:
        reader = pcsv.open_csv(path, read_options=pcsv.ReadOptions(block_size=block, use_threads=False),
                               convert_options=pcsv.ConvertOptions(include_columns=list(wanted), column_types=wanted,
                                                                   strings_can_be_null=False))
        for batch in reader:
            if not batch.num_rows:
                continue
            if batch.column("step").null_count:
                return None
            rows += batch.num_rows
            status += _value_counts(batch.column("status"))
            if "entity" in wanted:
                entity += _value_counts(batch.column("entity"))
            steps = batch.column("step")
            step[0] = steps[0].as_py() if step[0] is None else step[0]
            step[1] = steps[-1].as_py()
            mm = pc.min_max(pc.if_else(pc.is_nan(batch.column("t")), None, batch.column("t")))
            if mm["min"].is_valid:
                t[0], t[1] = min(t[0], mm["min"].as_py()), max(t[1], mm["max"].as_py())
    except (pa.ArrowException, OSError, ValueError):
        return None
    return {"file": path, "kind": "poses (CSV)", "rows": rows, "columns": first,
            "step_first": step[0], "step_last": step[1], "t_first": _time(t[0]), "t_last": _time(t[1]),
            "status": dict(sorted(status.items())),
            **({"entities": dict(sorted(entity.items()))} if "entity" in wanted else {})}


def _poses_csv_by_lines(path: str) -> dict:
    tally_status: Counter = Counter()
    tally_entity: Counter = Counter()
    rows = 0
    t = [math.inf, -math.inf]
    step = [None, None]
    try:
        with open(path, encoding="utf-8-sig") as fh:
            names = fh.readline().rstrip("\r\n").split(",")
            width, has_entity = len(names), "entity" in names
            k_step, k_t = names.index("step"), names.index("t")
            for number, line in enumerate(fh, 2):
                cells = line.rstrip("\r\n").split(",")
                if len(cells) != width:
                    if not line.strip():
                        continue
                    raise InputError(path, f"expected {width} columns as in the header, found {len(cells)}",
                                     where=f"line {number}")
                rows += 1
                tally_status[cells[-1]] += 1
                if has_entity:
                    tally_entity[cells[1]] += 1
                try:
                    s = int(cells[k_step])
                    v = float(cells[k_t]) if cells[k_t] else math.nan
                except ValueError:
                    raise InputError(path, f"step {cells[k_step]!r} or t {cells[k_t]!r} is not a number",
                                     where=f"line {number}") from None
                step[0] = s if step[0] is None else step[0]
                step[1] = s
                if math.isfinite(v):
                    t[0], t[1] = min(t[0], v), max(t[1], v)
    except UnicodeDecodeError:
        raise InputError(path, "not UTF-8 text") from None
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    return {"file": path, "kind": "poses (CSV)", "rows": rows, "columns": names,
            "step_first": step[0], "step_last": step[1], "t_first": _time(t[0]), "t_last": _time(t[1]),
            "status": dict(sorted(tally_status.items())),
            **({"entities": dict(sorted(tally_entity.items()))} if has_entity else {})}


# --- Parquet --------------------------------------------------------------------------------------

_WKT_NAME = re.compile(r'^\s*[A-Za-z_0-9]+\[\s*"([^"]*)"')
KNOWN_METADATA = ("tankcd.table", "tankcd.version", "tankcd.crs_wkt", "tankcd.units", "tankcd.conventions",
                  "tankcd.replay", "tankcd.sources")


def describe_parquet(path: str) -> dict:
    """Poses or events as Parquet: the footer (rows, row groups, columns, tankcd's metadata, the
    ``step`` and ``t`` statistics) and, row group by row group, the counts of the text columns
    (the poses' entities and statuses; the events' kinds, names and ``between``)."""
    from tankcd_cli.io.parquet import pyarrow_modules

    _, pq = pyarrow_modules(path)
    try:
        pf = pq.ParquetFile(path)
    except Exception as exc:  # noqa: BLE001 - pyarrow's errors for a damaged file have no common base
        raise InputError(path, f"not a Parquet file pyarrow can read: {_first(exc)}") from None
    with pf:
        meta = pf.metadata
        kv = {k.decode("utf-8", "replace"): v.decode("utf-8", "replace")
              for k, v in (pf.schema_arrow.metadata or {}).items() if not k.startswith(b"ARROW:")}
        names = list(pf.schema_arrow.names)
        table = kv.get("tankcd.table") or _table_by_columns(names)
        if table not in ("poses", "events"):
            raise InputError(path, "a Parquet file, but not tankcd's poses or events (no tankcd.table in its "
                                   "metadata, and not their columns)")
        facts = {"file": path, "kind": f"{table} (Parquet)", "table": table,
                 "rows": int(meta.num_rows), "row_groups": int(meta.num_row_groups),
                 "columns": names, "created_by": meta.created_by}
        facts.update(_metadata_facts(kv))
        try:
            facts.update(_poses_counts(pf) if table == "poses" else _events_counts(pf))
        except InputError:
            raise
        except Exception as exc:  # noqa: BLE001 - a damaged row group
            raise InputError(path, f"damaged Parquet file: {_first(exc)}") from None
    return {k: v for k, v in facts.items() if v is not None}


def _first(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:300] or type(exc).__name__


def _table_by_columns(names: list) -> str | None:
    """``poses`` or ``events`` for a file with their columns but no ``tankcd.table`` (an older tankcd's)."""
    from tankcd_cli.io.parquet import EVENT_SCHEMA, pose_schema

    if tuple(names) in (tuple(n for n, _ in pose_schema(False)), tuple(n for n, _ in pose_schema(True))):
        return "poses"
    if tuple(names) == tuple(n for n, _ in EVENT_SCHEMA):
        return "events"
    return None


def _json_or_text(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text


def _metadata_facts(kv: dict) -> dict:
    """tankcd's key-value metadata: version, CRS (its name; the WKT under ``crs_wkt``), units, the
    replay's options, the sources with their SHA-256, and any other ``tankcd.*`` key as it is
    (JSON read back), e.g. the time origin."""
    wkt = kv.get("tankcd.crs_wkt")
    crs = None
    if wkt is not None:
        match = _WKT_NAME.match(wkt)
        crs = (match.group(1) if match else "unnamed CRS") if wkt else "local grid (no CRS)"
    out = {"tankcd_version": kv.get("tankcd.version"), "crs": crs, "crs_wkt": wkt or None,
           "units": kv.get("tankcd.units"),
           "replay": _json_or_text(kv["tankcd.replay"]) if "tankcd.replay" in kv else None,
           "sources": _json_or_text(kv["tankcd.sources"]) if "tankcd.sources" in kv else None}
    for key, value in kv.items():
        if key.startswith("tankcd.") and key not in KNOWN_METADATA:
            out[key.removeprefix("tankcd.")] = _json_or_text(value)
    return out


def _column_span(pf, name: str):
    """[min, max] of a column from the row groups' statistics, or None where a row group has none."""
    if name not in pf.schema_arrow.names:
        return None
    k = pf.schema_arrow.names.index(name)
    lo, hi = math.inf, -math.inf
    meta = pf.metadata
    for g in range(meta.num_row_groups):
        group = meta.row_group(g)
        if group.num_rows == 0:
            continue
        stats = group.column(k).statistics
        if stats is None or not stats.has_min_max:
            if stats is not None and stats.null_count == group.num_rows:
                continue  # all null: nothing to span
            return None
        lo, hi = min(lo, stats.min), max(hi, stats.max)
    return None if lo > hi else [lo, hi]


def _span_facts(pf, names=("step", "t")) -> dict:
    """``step_first``/``step_last`` and ``t_first``/``t_last`` from the statistics, read from the
    columns where the statistics are missing."""
    out = {}
    for name in names:
        span = _column_span(pf, name)
        if span is None and name in pf.schema_arrow.names:
            span = _read_span(pf, name)
        lo, hi = span if span else (None, None)
        clean = _step if name == "step" else _time
        out[f"{name}_first"], out[f"{name}_last"] = clean(lo), clean(hi)
    return out


def _read_span(pf, name: str):
    import pyarrow.compute as pc

    lo, hi = math.inf, -math.inf
    for g in range(pf.metadata.num_row_groups):
        col = pf.read_row_group(g, columns=[name]).column(0)
        mm = pc.min_max(col)
        if mm["min"].is_valid:
            lo, hi = min(lo, mm["min"].as_py()), max(hi, mm["max"].as_py())
    return None if lo > hi else [lo, hi]


def _value_counts(column) -> Counter:
    """A (dictionary or string) column's counts, nulls left out."""
    import pyarrow.compute as pc

    out: Counter = Counter()
    if column.null_count == len(column):
        return out
    for item in pc.value_counts(column.combine_chunks() if hasattr(column, "combine_chunks") else column).to_pylist():
        if item["values"] is not None:
            out[str(item["values"])] += int(item["counts"])
    return out


def _poses_counts(pf) -> dict:
    """The poses' step and time span, rows per status and per entity (the text columns streamed)."""
    names = pf.schema_arrow.names
    wanted = [c for c in ("status", "entity") if c in names]
    status: Counter = Counter()
    entity: Counter = Counter()
    for g in range(pf.metadata.num_row_groups):
        group = pf.read_row_group(g, columns=wanted)
        if "status" in wanted:
            status += _value_counts(group.column("status"))
        if "entity" in wanted:
            entity += _value_counts(group.column("entity"))
    return {**_span_facts(pf), "status": dict(sorted(status.items())),
            "entities": dict(sorted(entity.items())) if "entity" in names else None}


def _events_counts(pf) -> dict:
    """The events' counts as for the JSON Lines (``EventTally``), row group by row group."""
    tally = EventTally()
    for g in range(pf.metadata.num_row_groups):
        tally_batch(tally, pf.read_row_group(g, columns=list(EVENT_COLUMNS)))
    return tally.facts()


# the events' fields the counts read (as Arrow types: a JSON Lines file is read with this schema)
EVENT_COLUMNS = {"step": "int64", "t": "float64", "kind": "string", "a": "string", "b": "string", "entity": "string",
                 "a_part": "string", "b_part": "string", "between": "bool"}


def tally_batch(tally: EventTally, batch) -> None:
    """Add a batch of events (a pyarrow table or record batch of ``EVENT_COLUMNS``) to ``tally``,
    counted as ``EventTally.add`` counts one event."""
    import pyarrow as pa
    import pyarrow.compute as pc

    def column(name):
        col = batch.column(name)
        col = col.combine_chunks() if isinstance(col, pa.ChunkedArray) else col
        return col.cast("string") if pa.types.is_dictionary(col.type) else col

    kind = column("kind")

    def where(col, *kinds):
        return _value_counts(pc.filter(col, pc.is_in(kind, value_set=pa.array(list(kinds), "string"))))

    tally.events += batch.num_rows
    tally.kinds += _value_counts(kind)
    tally.between += int(pc.sum(pc.fill_null(column("between"), False)).as_py() or 0)
    for name, span in (("step", tally.step), ("t", tally.t)):
        col = column(name)
        if name == "t":
            col = pc.if_else(pc.is_nan(col), pa.scalar(None, col.type), col) if len(col) else col
            tally.no_t += col.null_count
        mm = pc.min_max(col)
        if mm["min"].is_valid:
            span[0], span[1] = min(span[0], mm["min"].as_py()), max(span[1], mm["max"].as_py())
    tally.obstacles += where(column("b"), "obstacle")
    tally.parts += where(column("a"), *KINDS)
    tally.parts += where(column("a_part"), "vehicle") + where(column("b_part"), "vehicle")
    vehicle = pc.equal(kind, "vehicle")
    entity = pc.if_else(vehicle, pc.coalesce(column("entity"), column("a")), column("entity"))
    tally.entities += _value_counts(entity) + where(column("b"), "vehicle")


# --- summaries ------------------------------------------------------------------------------------

def describe_summary(path: str) -> dict:
    """A replay summary (``replay --summary FILE``): its fields as they are (docs/formats.md,
    "Replay summary (JSON)"), the warnings the replay raised among them."""
    summary = _load_json(path)
    facts = {"file": path, "kind": "replay summary"}
    facts.update(summary)
    facts.setdefault("warnings", [])
    return facts


def describe_fleet(path: str) -> dict:
    """A fleet's fleet.json: the totals, the world replayed against, the failures, and per
    trajectory its status, rows and contacts (the replay summary's other fields left to the file)."""
    fleet = _load_json(path)
    facts = {"file": path, "kind": "fleet summary (fleet.json)"}
    facts.update({k: v for k, v in fleet.items() if k != "results"})
    if "results" in fleet:
        facts["results"] = [_result(r) for r in fleet["results"] if isinstance(r, dict)]
    return facts


def _result(r: dict) -> dict:
    out = {"trajectory": r.get("trajectory"), "status": r.get("status")}
    for key in ("rows", "collisions", "between", "off_terrain", "vehicle_contacts", "entities", "parts",
                "time_origin", "error"):
        if r.get(key) is not None:
            out[key] = r[key]
    if r.get("warnings"):
        out["warnings"] = r["warnings"]
    out["poses"], out["events"] = r.get("poses"), r.get("events")
    return out
