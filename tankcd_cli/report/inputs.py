"""A replay's outputs read back for its review: the poses (CSV or Parquet) into one ``Track`` per
vehicle, the events (JSON Lines or Parquet), and the checks that the two come from one run
(docs/formats.md, "Outputs for review").

Memory: the tracks keep the columns a report draws (step, t, x, y, z, yaw, the quaternion and the
status: 85 bytes a row); the CSV is read in chunks of rows, its text columns as codes.
"""

from __future__ import annotations

import json
import math

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.report.review import STATUS, Review, Source, Track

NUMBERS = ("step", "t", "x", "y", "z", "yaw_deg", "qw", "qx", "qy", "qz")
_BLANK = ("t", "z", "qw", "qx", "qy", "qz")  # empty in a row without a pose (status off)
TIME_SLACK = 2e-6  # s: both outputs round t to 6 decimals


def is_parquet(path: str) -> bool:
    return str(path).lower().endswith(".parquet")


def read_review(poses: str, events: str, crs_wkt: str = "", sources: tuple = (),
                vehicle_length: float = 6.86, vehicle_width: float = 3.46, chunk_rows: int = 262144) -> Review:
    """The ``Review`` of the replay that wrote ``poses`` and ``events``, checked (``check_review``).

    crs_wkt : the terrain's CRS (WKT; '' without one); sources : more ``Source`` records to keep
    (the scene, the terrain) after the poses' and events' own.
    """
    from tankcd_cli.io.parquet import sha256_of

    meta_poses: dict = {}
    meta_events: dict = {}
    if is_parquet(poses):
        tracks, meta_poses = _parquet_tracks(poses)
    else:
        tracks = _csv_tracks(poses, chunk_rows)
    if is_parquet(events):
        event_list, meta_events = _parquet_events(events)
    else:
        event_list = _jsonl_events(events)
    _same_run(poses, events, meta_poses, meta_events)
    check_review(poses, events, tracks, event_list)
    recorded = [Source(s.get("role", ""), str(s.get("path", "")), str(s.get("sha256", s.get("source_sha256", ""))))
                for s in _json(meta_poses.get("tankcd.sources"), poses, "tankcd.sources") or []]
    own = [Source("poses", poses, sha256_of(poses)), Source("events", events, sha256_of(events))]
    settings = _json(meta_poses.get("tankcd.replay"), poses, "tankcd.replay") or {}
    return Review(tuple(tracks), event_list, crs_wkt, tuple(own + list(sources) + recorded), settings,
                  meta_poses.get("tankcd.version", ""), float(vehicle_length), float(vehicle_width))


def _json(text, path, key):
    if not text:
        return None
    try:
        return json.loads(text)
    except ValueError:
        raise InputError(path, f"its metadata {key} is not JSON") from None


def _tracks_of(codes: np.ndarray, names: list, cols: dict, status: np.ndarray) -> list:
    """One Track per entity code (in order of first appearance), each its rows in file order."""
    order = np.argsort(codes, kind="stable")
    bounds = np.searchsorted(codes[order], np.arange(len(names) + 1))
    tracks = []
    for k, name in enumerate(names):
        idx = order[bounds[k]:bounds[k + 1]]
        q = np.column_stack([cols[c][idx] for c in ("qw", "qx", "qy", "qz")])
        tracks.append(Track(name, cols["step"][idx].astype(np.int64), cols["t"][idx], cols["x"][idx],
                            cols["y"][idx], cols["z"][idx], cols["yaw_deg"][idx], q, status[idx]))
    return tracks


def _status_codes(texts, path: str, first_line: int) -> np.ndarray:
    lookup = {s: k for k, s in enumerate(STATUS)}
    try:
        return np.fromiter((lookup[s] for s in texts), dtype=np.uint8, count=len(texts))
    except KeyError:
        bad = next(k for k, s in enumerate(texts) if s not in lookup)
        raise InputError(path, f"status {texts[bad]!r} is none of {', '.join(STATUS)}",
                         where=f"line {first_line + bad}") from None


def _csv_tracks(path: str, chunk_rows: int) -> list:
    """The poses CSV's rows as tracks: the numbers through the project's column reader (every bad
    cell named by line), ``entity`` and ``status`` through a second pass over the text."""
    from tankcd_cli.io.csv_columns import numeric_chunks
    from tankcd_cli.io.files import open_input
    from tankcd_cli.io.poses_csv import _trajectory_hint

    name, fh = open_input(path, text=True)
    parts: dict = {c: [] for c in NUMBERS}
    try:
        for _, wanted, values in numeric_chunks(fh, name, NUMBERS, (), chunk_rows, _BLANK, hint=_trajectory_hint):
            for j, c in enumerate(wanted):
                parts[c].append(values[:, j])
    except UnicodeDecodeError:
        raise InputError(name, "not UTF-8 text (poses are a CSV file)") from None
    finally:
        fh.close()
    cols = {c: np.concatenate(v) if v else np.zeros(0) for c, v in parts.items()}
    n = len(cols["step"])
    if n == 0:
        raise InputError(name, "holds no pose rows")
    codes, names, status = _csv_text_columns(path, n, chunk_rows)
    _check_rows(path, cols, status, lambda i: f"line {i + 2}")
    return _tracks_of(codes, names, cols, status)


def _csv_text_columns(path: str, n: int, chunk_rows: int) -> tuple[np.ndarray, list, np.ndarray]:
    """(entity codes (n,) int32, entity names, status codes (n,) uint8) of the poses CSV."""
    import itertools

    with open(path, encoding="utf-8", newline="") as fh:
        header = [h.strip().strip('"') for h in fh.readline().rstrip("\r\n").split(",")]
        e = header.index("entity") if "entity" in header else None
        s = header.index("status") if "status" in header else None
        index: dict = {}
        codes = np.zeros(n, dtype=np.int32)
        status = np.zeros(n, dtype=np.uint8)
        at = 0
        while True:
            lines = [ln for ln in itertools.islice(fh, chunk_rows) if ln.strip()]
            if not lines:
                break
            cells = [ln.rstrip("\r\n").split(",") for ln in lines]
            k = len(cells)
            if e is not None:
                codes[at:at + k] = np.fromiter((index.setdefault(c[e], len(index)) for c in cells),
                                               dtype=np.int32, count=k)
            if s is not None:
                status[at:at + k] = _status_codes([c[s] for c in cells], path, at + 2)
            at += k
    names = list(index) if e is not None else [""]
    return codes, names, status


def _check_rows(path: str, cols: dict, status: np.ndarray, where) -> None:
    """Rows with a pose have finite numbers; steps are distinct per file."""
    placed = status != STATUS.index("off")
    for c in ("t", "z", "qw"):
        bad = np.flatnonzero(placed & ~np.isfinite(cols[c]))
        if c == "t" and np.isfinite(cols["t"]).sum() == 0:
            continue  # poses without times (collide's input, a trajectory without t)
        if len(bad):
            raise InputError(path, f"{c} is empty or not finite in a row with a pose", where=where(bad[0]))
    step = cols["step"]
    if len(step) > 1:
        srt = np.sort(step)
        dup = np.flatnonzero(srt[1:] == srt[:-1])
        if len(dup):
            first = int(np.flatnonzero(step == srt[dup[0]])[1])
            raise InputError(path, f"step {int(srt[dup[0]])} appears twice (one replay's poses have one row a step)",
                             where=where(first))


def _parquet_tracks(path: str) -> tuple[list, dict]:
    from tankcd_cli.io.parquet import file_metadata, pyarrow_modules

    pa, pq = pyarrow_modules()
    try:
        meta = file_metadata(path)
        if meta.get("tankcd.table", "poses") != "poses":
            raise InputError(path, f"holds tankcd {meta['tankcd.table']}, not poses")
        names = pq.read_schema(path).names
        missing = [c for c in NUMBERS + ("status",) if c not in names]
        if missing:
            raise InputError(path, f"not a poses file of tankcd replay: no {', '.join(missing)} column")
        wanted = list(NUMBERS) + ["status"] + (["entity"] if "entity" in names else [])
        table = pq.read_table(path, columns=wanted)
    except (OSError, pa.ArrowException) as exc:
        raise InputError(path, f"not a readable Parquet file ({exc})") from None
    if table.num_rows == 0:
        raise InputError(path, "holds no pose rows")
    cols = {c: table.column(c).to_numpy(zero_copy_only=False).astype(np.float64) for c in NUMBERS if c != "step"}
    cols["step"] = table.column("step").to_numpy(zero_copy_only=False).astype(np.int64)
    st = table.column("status").combine_chunks().dictionary_encode()
    lookup = {s: k for k, s in enumerate(STATUS)}
    dic = st.dictionary.to_pylist()
    if any(s not in lookup for s in dic):
        raise InputError(path, f"a status none of {', '.join(STATUS)}: {[s for s in dic if s not in lookup][0]!r}")
    status = np.array([lookup[s] for s in dic], dtype=np.uint8)[st.indices.to_numpy(zero_copy_only=False)]
    if "entity" in names:
        ent = table.column("entity").combine_chunks().dictionary_encode()
        raw = ent.indices.to_numpy(zero_copy_only=False).astype(np.int32)
        # codes in order of first appearance, as the CSV's
        _, first = np.unique(raw, return_index=True)
        appear = np.argsort(first, kind="stable")
        remap = np.empty(len(first), dtype=np.int32)
        remap[appear] = np.arange(len(first), dtype=np.int32)
        dict_names = ent.dictionary.to_pylist()
        used = np.unique(raw)
        codes = remap[np.searchsorted(used, raw)]
        entity_names = [dict_names[used[k]] for k in appear]
    else:
        codes, entity_names = np.zeros(table.num_rows, dtype=np.int32), [""]
    _check_rows(path, cols, status, lambda i: f"row {i}")
    return _tracks_of(codes, entity_names, cols, status), meta


def _jsonl_events(path: str) -> list:
    from tankcd_cli.io.files import open_input

    name, fh = open_input(path, text=True)
    out = []
    try:
        for lineno, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                e = json.loads(line)
            except ValueError as exc:
                raise InputError(name, f"not a JSON object ({exc.args[0].split(':')[0]})", where=f"line {lineno}") \
                    from None
            _check_event(e, name, f"line {lineno}")
            out.append(e)
    except UnicodeDecodeError:
        raise InputError(name, "not UTF-8 text (events are JSON Lines)") from None
    finally:
        fh.close()
    return out


def _check_event(e, name: str, where: str) -> None:
    if not isinstance(e, dict):
        raise InputError(name, "not a JSON object", where=where)
    missing = [k for k in ("step", "t", "kind", "a", "b") if k not in e]
    if missing:
        raise InputError(name, f"an event lacks {', '.join(missing)}", where=where)
    if not isinstance(e["step"], int) or isinstance(e["step"], bool):
        raise InputError(name, f"step {e['step']!r} is not an integer", where=where)
    if e["t"] is not None and not (isinstance(e["t"], (int, float)) and math.isfinite(e["t"])):
        raise InputError(name, f"t {e['t']!r} is not a finite number", where=where)
    p = e.get("point")
    if p is not None and not (isinstance(p, list) and len(p) == 3
                              and all(isinstance(v, (int, float)) and math.isfinite(v) for v in p)):
        raise InputError(name, f"point {p!r} is not three finite numbers", where=where)


def _parquet_events(path: str) -> tuple[list, dict]:
    from tankcd_cli.io.parquet import event_dicts, file_metadata, pyarrow_modules

    pa, pq = pyarrow_modules()
    try:
        meta = file_metadata(path)
        if meta.get("tankcd.table", "events") != "events":
            raise InputError(path, f"holds tankcd {meta['tankcd.table']}, not events")
        events = event_dicts(pq.read_table(path))
    except (OSError, KeyError, pa.ArrowException) as exc:
        raise InputError(path, f"not an events Parquet file of tankcd ({exc})") from None
    for k, e in enumerate(events):
        _check_event(e, path, f"row {k}")
    return events, meta


def _same_run(poses: str, events: str, meta_poses: dict, meta_events: dict) -> None:
    """Two Parquet outputs name what their replay read: the same inputs, or two runs."""
    if not (meta_poses and meta_events):
        return
    def inputs(meta, path):
        found = _json(meta.get("tankcd.sources"), path, "tankcd.sources") or []
        return sorted((s.get("role", ""), s.get("sha256", "")) for s in found if s.get("role") == "trajectory")
    a, b = inputs(meta_poses, poses), inputs(meta_events, events)
    if a and b and a != b:
        raise InputError(events, f"comes from another run than {poses}: their trajectories' SHA-256 differ "
                                 f"({(b[0][1] or '?')[:12]} against {(a[0][1] or '?')[:12]})")


def check_review(poses: str, events: str, tracks: list, event_list: list) -> None:
    """Every event belongs to the poses: its step is a pose row's, its entity (both, for a contact
    between vehicles) a vehicle of the poses, and an event at a row (no ``"between"``) has that
    row's time; an event between rows lies between its row's time and the vehicle's next row's.
    Anything else: the two files come from different runs (InputError naming the event's line)."""
    if not event_list:
        return
    step = np.concatenate([tr.step for tr in tracks])
    owner = np.concatenate([np.full(len(tr), k, dtype=np.int32) for k, tr in enumerate(tracks)])
    pos = np.concatenate([np.arange(len(tr)) for tr in tracks])
    order = np.argsort(step, kind="stable")
    step_sorted = step[order]
    names = {tr.entity: k for k, tr in enumerate(tracks)}
    named = not (len(tracks) == 1 and tracks[0].entity == "")
    ev_step = np.array([e["step"] for e in event_list], dtype=np.int64)
    at = np.minimum(np.searchsorted(step_sorted, ev_step), len(step_sorted) - 1)
    found = step_sorted[at] == ev_step
    where = lambda k: f"line {k + 1}" if not is_parquet(events) else f"row {k}"  # noqa: E731
    lost = np.flatnonzero(~found)
    if len(lost):
        k = int(lost[0])
        raise InputError(events, f"event at step {ev_step[k]} has no row in {poses} (the two files come from "
                                 "different runs)", where=where(k))
    row_owner, row_pos = owner[order[at]], pos[order[at]]
    for k, e in enumerate(event_list):
        parties = [e["a"], e["b"]] if e["kind"] == "vehicle" else [e.get("entity", "")] if named else [""]
        for p in parties:
            if p not in names:
                raise InputError(events, f"event names the vehicle {p!r}, which {poses} does not hold (the two "
                                         "files come from different runs)", where=where(k))
        if e["t"] is None or e["kind"] == "vehicle":
            continue  # a contact between vehicles is at the earlier row of either's interval
        tr = tracks[row_owner[k]]
        i = row_pos[k]
        t_row = tr.t[i]
        if not math.isfinite(t_row):
            continue
        if not e.get("between"):
            ok = abs(e["t"] - t_row) <= TIME_SLACK
            what = f"t {e['t']} differs from its row's t {t_row:.6f}"
        else:
            t_next = tr.t[i + 1] if i + 1 < len(tr) else t_row
            ok = t_row - TIME_SLACK <= e["t"] <= t_next + TIME_SLACK
            what = f"t {e['t']} lies outside its row's interval {t_row:.6f} to {t_next:.6f}"
        if not ok:
            raise InputError(events, f"event at step {e['step']}: {what} in {poses} (the two files come from "
                                     "different runs)", where=where(k))
