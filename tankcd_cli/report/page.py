"""The review page: one self-contained HTML file (docs/formats.md, "Outputs for review", .html).

The page holds its script and style (``page_assets/review.js``, ``review.css``, written by hand:
vanilla JavaScript on a 2D canvas, no library), the terrain picture as a PNG data URI and the
review's data as one compact JSON document; it fetches nothing. Tracks are simplified for drawing
and playback (``simplify_track``: a stated bound on position and heading at every time); every
event is kept with all its fields.

Data (the JSON in ``<script type="application/json" id="tankcd-data">``): coordinates relative to
``origin`` (the terrain picture's south-west corner, world m), as integer steps of 0.01 m; times
as integer steps of 1 ms (or rows' steps where the poses have no times: ``clock`` says which);
headings as 0.01 degree steps, unwrapped (no jump at +-180) so that they interpolate linearly.
Each vehicle's arrays are delta-encoded (the first value, then differences): small integers
keep an hour of 1,000 vehicles a few tens of MB. ``status``: [[vertex, status], ...] where its
status (``review.STATUS``: 0 ok, 1 partly_off, 2 off) changes, from 0; the rows on either side of
a change are kept, so that the status at any time is the status of the last kept vertex at or
before it, exactly the poses' own.
"""

from __future__ import annotations

import base64
import io
import json
import math
from importlib import resources

import numpy as np

from tankcd_cli.io.atomic import atomic_path

POSITION_TOLERANCE_M = 0.5  # a kept vertex where playback would otherwise stray further
HEADING_TOLERANCE_DEG = 1.0
# after this many passes a segment still out of tolerance is split at its middle, not at its worst
# row: the passes stay at most this plus log2(rows), whatever the track (the bound is the same)
_WORST_ROW_PASSES = 48


def simplify_track(t: np.ndarray, x: np.ndarray, y: np.ndarray, heading: np.ndarray,
                   tolerance_m: float = POSITION_TOLERANCE_M,
                   tolerance_deg: float = HEADING_TOLERANCE_DEG) -> np.ndarray:
    """The rows to keep of one track so that playback between kept rows stays within tolerance.

    t : (n,) float64 time (non-decreasing); x, y : (n,) float64 position, m; heading : (n,)
        float64 unwrapped heading, degrees. Returns (k,) int64 sorted indices, the first and last
        rows always among them.

    Playback shows, at a time T between the kept rows a < b (t_a <= T <= t_b), the position and
    heading interpolated linearly in time between a and b; the poses' own motion is the linear
    interpolation between consecutive rows. The rows are kept top-down (Douglas-Peucker with the
    synchronized distance): a segment a..b is split at a row i where
    ``e_i = |p_i - p_ab(t_i)| > tolerance_m`` or ``|h_i - h_ab(t_i)| > tolerance_deg``
    (``p_ab``, ``h_ab`` the interpolation between a and b), until no segment has one.

    Bound: at every time T in the track's span, the played position is within ``tolerance_m`` of
    the poses' (interpolated) position and the played heading within ``tolerance_deg`` of theirs.
    Proof: take T in [t_i, t_i+1] for consecutive rows i, i+1 inside one kept segment a..b. On
    that interval both the poses' position and the played one are affine functions of T (the
    first between rows i and i+1, the second between a and b), so their difference d(T) is
    affine, and |d(T)| is a convex function of T; its maximum over the interval is at an end,
    t_i or t_i+1, where it is e_i or e_i+1, each at most tolerance_m when the search stops (0 at
    a kept row). The heading's difference is affine in T too, and the same argument bounds it.
    Rows of equal times in a segment take the segment's value at that time (u = 0 where
    t_b = t_a). A footprint's corner, at distance r from its centre, is then within
    ``tolerance_m + r * radians(tolerance_deg)`` of the poses' (0.07 m for a T-72 at 1 degree).
    """
    n = len(t)
    if n <= 2:
        return np.arange(n, dtype=np.int64)
    keep = np.zeros(n, dtype=bool)
    keep[[0, n - 1]] = True
    active = np.arange(1, n - 1)  # rows of segments not yet within tolerance
    passes = 0
    while len(active):
        kept = np.flatnonzero(keep)
        seg = np.searchsorted(kept, active, side="right") - 1
        a, b = kept[seg], kept[seg + 1]
        dt = t[b] - t[a]
        u = np.divide(t[active] - t[a], dt, out=np.zeros(len(active)), where=dt > 0)
        err_m = np.hypot(x[a] + u * (x[b] - x[a]) - x[active], y[a] + u * (y[b] - y[a]) - y[active])
        err_deg = np.abs(heading[a] + u * (heading[b] - heading[a]) - heading[active])
        err = np.maximum(err_m / tolerance_m, err_deg / tolerance_deg)  # > 1: out of tolerance
        starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])  # active rows are in order
        worst = np.maximum.reduceat(err, starts)
        lengths = np.diff(np.r_[starts, len(active)])
        out = worst > 1.0
        if not out.any():
            break
        if passes < _WORST_ROW_PASSES:
            at_worst = (err == np.repeat(worst, lengths)) & np.repeat(out, lengths)
            split = active[at_worst & _first_true_per_segment(at_worst, seg)]
        else:
            split = (kept[seg[starts[out]]] + kept[seg[starts[out]] + 1]) // 2
        keep[split] = True
        still = np.repeat(out, lengths)
        active = active[still & ~keep[active]]
        passes += 1
    return np.flatnonzero(keep)


def _first_true_per_segment(mask: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """(m,) bool: True at the first True of ``mask`` within each run of equal ``seg``."""
    idx = np.flatnonzero(mask)
    first = np.zeros(len(mask), dtype=bool)
    if len(idx):
        s = seg[idx]
        first[idx[np.r_[True, s[1:] != s[:-1]]]] = True
    return first


def played_pose(t_kept: np.ndarray, x_kept: np.ndarray, y_kept: np.ndarray, h_kept: np.ndarray,
                at: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the page plays at times ``at`` (m,): x, y, heading interpolated linearly in time
    between the kept vertices (as review.js does; for tests of the bound)."""
    return np.interp(at, t_kept, x_kept), np.interp(at, t_kept, y_kept), np.interp(at, t_kept, h_kept)


def event_parties(event: dict, names: list) -> list:
    """The vehicles an event is about: both entities of a ``vehicle`` event, else its ``entity``
    (the only vehicle where the events name none)."""
    if event.get("kind") == "vehicle":
        return [event.get("a"), event.get("b")]
    if "entity" in event:
        return [event["entity"]]
    return names[:1]


def page_data(review, background, tolerance_m: float = POSITION_TOLERANCE_M,
              tolerance_deg: float = HEADING_TOLERANCE_DEG) -> dict:
    """The page's JSON document (see the module's docstring)."""
    from tankcd_cli.replay.effects import EVENT_KIND_TABLE

    origin = np.array([background.x0, background.y0])
    names = [tr.entity for tr in review.tracks]
    index = {name: k for k, name in enumerate(names)}
    by_time = all(len(tr) == 0 or np.isfinite(tr.t).all() for tr in review.tracks)
    events = review.events
    parties = [[index[p] for p in event_parties(ev, names) if p in index] for ev in events]
    ev_clock = np.array([_number(ev.get("t" if by_time else "step")) for ev in events], dtype=float)
    ev_at = np.full((len(events), 2), np.nan)
    of_vehicle: list = [[] for _ in names]  # each vehicle's events, by index
    for i, p in enumerate(parties):
        for k in set(p):
            of_vehicle[k].append(i)
    for k, ev in enumerate(events):
        point = ev.get("point")
        if point is not None and len(point) >= 2:
            ev_at[k] = point[0], point[1]
    vehicles, rows, vertices = [], 0, 0
    for k, tr in enumerate(review.tracks):
        clock = np.asarray(tr.t if by_time else tr.step, dtype=float)
        x, y, yaw = (np.asarray(a, dtype=float) for a in (tr.x, tr.y, tr.yaw_deg))
        status = np.asarray(tr.status, dtype=np.int64)
        # a row without a position or heading cannot be drawn: playback goes from the row before to the one after
        ok = np.isfinite(clock) & np.isfinite(x) & np.isfinite(y) & np.isfinite(yaw)
        if not ok.all():
            clock, x, y, yaw, status = clock[ok], x[ok], y[ok], yaw[ok], status[ok]
        scale = 1000.0 if by_time else 1.0
        tq = np.round(clock * scale).astype(np.int64)
        xq = np.round((x - origin[0]) * 100).astype(np.int64)
        yq = np.round((y - origin[1]) * 100).astype(np.int64)
        hq = np.round(np.degrees(np.unwrap(np.radians(yaw))) * 100).astype(np.int64)
        # simplified on the rounded values: the bound holds for what the page has
        kept = simplify_track(tq / scale, xq / 100.0, yq / 100.0, hq / 100.0, tolerance_m, tolerance_deg)
        # a change of status kept exactly: the row where it changes and the one before it
        change = np.flatnonzero(np.diff(status)) + 1
        if len(change):
            kept = np.union1d(kept, np.r_[change - 1, change])
        runs = np.flatnonzero(np.r_[status[kept][:1] != 0, np.diff(status[kept]) != 0]) if len(kept) else kept
        mine = of_vehicle[k]
        # events without a point are marked where their vehicle is at their time
        no_point = [i for i in mine if not np.isfinite(ev_at[i, 0]) and np.isfinite(ev_clock[i])]
        if no_point and len(clock):
            ev_at[no_point, 0] = np.interp(ev_clock[no_point], clock, x)
            ev_at[no_point, 1] = np.interp(ev_clock[no_point], clock, y)
        vehicles.append({"name": tr.entity, "rows": len(tr), "t": _deltas(tq[kept]), "x": _deltas(xq[kept]),
                         "y": _deltas(yq[kept]), "h": _deltas(hq[kept]),
                         "status": [[int(i), int(status[kept][i])] for i in runs],
                         "stats": _plain(vehicle_stats(x, y, clock, events, mine, ev_clock))})
        rows += len(tr)
        vertices += len(kept)
    at = np.round((ev_at - origin) * 100)
    kinds = [{"name": kd.name, "colour": kd.colour, "label": kd.label} for kd in EVENT_KIND_TABLE]
    return {
        "format": "tankcd-review-page", "version": 1,
        "origin": [float(origin[0]), float(origin[1])],
        "clock": "t" if by_time else "step",
        "tolerance": {"position_m": tolerance_m, "heading_deg": tolerance_deg, "rows": rows, "vertices": vertices},
        "vehicle": {"length": review.vehicle_length, "width": review.vehicle_width},
        "background": {"png": png_data_uri(background.rgb), "kind": background.kind,
                       "legend": [list(item) for item in background.legend],
                       "extent": [0.0, background.x1 - background.x0, 0.0, background.y1 - background.y0]},
        "kinds": kinds,
        "vehicles": vehicles,
        "events": [_plain(ev) for ev in events],
        "event_parties": parties,
        "event_at": [None if not np.isfinite(p[0]) else [int(p[0]), int(p[1])] for p in at],
        "provenance": {"tankcd_version": review.tankcd_version,
                       "sources": [{"role": s.role, "path": s.path, "sha256": s.sha256} for s in review.sources],
                       "settings": _plain(review.settings), "crs_wkt": review.crs_wkt},
    }


def vehicle_stats(x: np.ndarray, y: np.ndarray, clock: np.ndarray, events: list, mine: list,
                  ev_clock: np.ndarray) -> dict:
    """One vehicle's row of the page's table: its time span (first, last clock value), the distance
    its footprint centre travels along its rows, m, its contacts by kind, its first contact (the
    index of the event, in the events' order, of least time) and the closing speeds, m/s, of its
    contacts with other vehicles. x, y, clock : (n,) its drawable rows; ``mine``: the indices of
    its events."""
    step = np.hypot(np.diff(x), np.diff(y))
    by_kind: dict = {}
    for i in mine:
        by_kind[events[i].get("kind")] = by_kind.get(events[i].get("kind"), 0) + 1
    timed = [i for i in mine if np.isfinite(ev_clock[i])]
    first = min(timed, key=lambda i: (ev_clock[i], i)) if timed else None
    closing = [float(events[i]["closing_speed"]) for i in mine if events[i].get("closing_speed") is not None]
    finite = clock[np.isfinite(clock)]
    return {"from": float(finite.min()) if len(finite) else None, "to": float(finite.max()) if len(finite) else None,
            "distance": round(float(np.nansum(step)), 2), "contacts": by_kind, "first": first,
            "closing": closing}


def png_data_uri(rgb: np.ndarray) -> str:
    """(h, w, 3) uint8 as a PNG data URI (matplotlib's writer)."""
    import matplotlib.image

    buf = io.BytesIO()
    matplotlib.image.imsave(buf, np.ascontiguousarray(rgb, dtype=np.uint8), format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def page_html(review, background, tolerance_m: float = POSITION_TOLERANCE_M,
              tolerance_deg: float = HEADING_TOLERANCE_DEG) -> str:
    """The whole page as text."""
    data = json.dumps(page_data(review, background, tolerance_m, tolerance_deg), separators=(",", ":"),
                      allow_nan=False)
    # inside <script> only "</script" and "<!--" could end or confuse it: no "<" left at all
    data = data.replace("<", "\\u003c")
    assets = resources.files("tankcd_cli.report") / "page_assets"
    script = (assets / "review.js").read_text(encoding="utf-8")
    style = (assets / "review.css").read_text(encoding="utf-8")
    title = _html_text(f"tankcd review: {len(review.tracks)} vehicle{'s' if len(review.tracks) != 1 else ''}, "
                       f"{len(review.events)} event{'s' if len(review.events) != 1 else ''}")
    return (f"<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            f"<meta name=\"generator\" content=\"tankcd {_html_text(review.tankcd_version)}\">\n"
            f"<title>{title}</title>\n<style>\n{style}</style>\n</head>\n<body>\n"
            f"<noscript>This page needs JavaScript to draw the review.</noscript>\n"
            f"<script type=\"application/json\" id=\"tankcd-data\">{data}</script>\n"
            f"<script>\n{script}</script>\n</body>\n</html>\n")


def write_page(review, background, path: str, tolerance_m: float = POSITION_TOLERANCE_M,
               tolerance_deg: float = HEADING_TOLERANCE_DEG) -> None:
    """Write the review page of ``review`` (``report.review.Review``) over ``background``
    (``report.background.Background``) to ``path``, under a temporary name until complete."""
    html = page_html(review, background, tolerance_m, tolerance_deg)
    with atomic_path(path, ".html") as tmp, open(tmp, "w", encoding="utf-8") as fh:
        fh.write(html)


def _deltas(values: np.ndarray) -> list:
    """(n,) int64 as [first, differences...] (a list of Python ints, for JSON)."""
    return np.diff(values, prepend=0).tolist() if len(values) else []


def _number(value) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan


def _plain(value):
    """JSON-ready: numpy scalars and arrays as Python's, non-finite floats as None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _html_text(text: str) -> str:
    return str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
