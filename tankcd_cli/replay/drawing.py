"""What a replay's map needs, gathered chunk by chunk in bounded memory."""

from __future__ import annotations

import numpy as np

from tankcd_cli.replay.effects import EVENT_KIND_TABLE

MAX_PATH_POINTS = 200_000  # a map cannot show more; longer paths are thinned evenly
MAX_MARKS = 50_000  # events drawn; the legend still counts them all


class ReplayDrawing:
    """The path (thinned to at most MAX_PATH_POINTS), the matcher of each drawn pose and the
    events' places, fed by ``observe`` and drawn by ``save``."""

    def __init__(self, colour_by: str = "path"):
        self.colour_by = colour_by
        self.stride = 1
        self.seen = 0
        self.xy: list[np.ndarray] = []
        self.matcher: list[np.ndarray] = []
        self.marks: list[tuple[str, float, float]] = []
        self.counts: dict[str, int] = {}

    def observe(self, chunk, poses, events) -> None:
        if chunk is None:  # the vehicles' last contacts, after the last chunk: marked at their points
            for e in events:
                self.counts[e.kind] = self.counts.get(e.kind, 0) + 1
                point = e.extra.get("point")
                if point is not None and len(self.marks) < MAX_MARKS:
                    self.marks.append((e.kind, float(point[0]), float(point[1])))
            return
        keep = (np.arange(self.seen, self.seen + len(chunk)) % self.stride) == 0
        self.seen += len(chunk)
        self.xy.append(np.column_stack([chunk.x[keep], chunk.y[keep]]))
        self.matcher.append(np.asarray(poses.matcher)[keep].astype(np.int8))
        if sum(len(p) for p in self.xy) > MAX_PATH_POINTS:  # thin what is kept, and what comes
            self.xy = [np.concatenate(self.xy)[::2]]
            self.matcher = [np.concatenate(self.matcher)[::2]]
            self.stride *= 2
        if events:
            rows = np.searchsorted(chunk.step, [e.step for e in events])
            rows = np.clip(rows, 0, len(chunk) - 1)
            for e, r in zip(events, rows):
                self.counts[e.kind] = self.counts.get(e.kind, 0) + 1
                if len(self.marks) < MAX_MARKS:
                    self.marks.append((e.kind, float(chunk.x[r]), float(chunk.y[r])))

    def save(self, path: str, store, obstacles=()) -> None:
        """Draw to ``path`` (PNG) over ``store`` (a grid store's path or a mesh-layout store)."""
        from tankcd_cli.plots import replay_map_png

        xy = np.concatenate(self.xy) if self.xy else np.zeros((0, 2))
        matcher = np.concatenate(self.matcher) if self.matcher else np.zeros(0, np.int8)
        footprints = [(ob.name, footprint_outline(ob.tree.triangles)) for ob in obstacles]
        replay_map_png(store, xy, self.marks, path, footprints=footprints,
                       matcher=matcher if self.colour_by == "matcher" else None, counts=self.counts,
                       kinds=EVENT_KIND_TABLE)


def footprint_outline(triangles: np.ndarray) -> np.ndarray:
    """The convex outline (k, 2) of triangles (m, 3, 3) seen from above, counter-clockwise
    (fewer than 3 distinct points: those; all in a line: the two ends).

    Andrew's monotone chain over the points left once those strictly inside the octagon of
    the extreme points (in x, y, x + y and x - y) are dropped, none of which can be a corner of
    the hull; no scipy (its import alone costs a small replay's ``--png`` a third of a second).
    """
    pts = triangles.reshape(-1, 3)[:, :2]
    if len(pts) >= 3:
        pts = pts[~_inside_extremes(pts)]  # before the sort: most points of a big mesh go here
    pts = np.unique(pts, axis=0)  # sorted by x, then y
    if len(pts) < 3:
        return pts
    extent = float(np.ptp(pts, axis=0).max())
    # a turn this slight is round-off, the point on the edge: the coordinates' own rounding (a few
    # ulp of the largest, at UTM offsets 1e-9 m) times the extent bounds the cross product's error
    size = float(np.abs(pts).max())
    tol = 16 * np.finfo(float).eps * size * extent + 1e-12 * extent * extent
    lower = _half_hull(pts, tol)
    upper = _half_hull(pts[::-1], tol)
    hull = np.array(lower[:-1] + upper[:-1])
    return hull if len(hull) >= 3 else pts[[0, -1]]


def _inside_extremes(pts: np.ndarray) -> np.ndarray:
    """(n,) bool: strictly inside the convex polygon through the points extreme in eight
    directions (counter-clockwise; a point extreme in neighbouring directions once), none of
    which can be a corner of the hull."""
    x, y = pts[:, 0], pts[:, 1]
    order = [np.argmax(x), np.argmax(x + y), np.argmax(y), np.argmax(y - x),
             np.argmin(x), np.argmin(x + y), np.argmin(y), np.argmin(y - x)]
    ring = pts[np.array([int(i) for i in order])]
    # the same point extreme in neighbouring directions (maybe as two equal points): once
    ring = ring[np.any(ring != np.roll(ring, 1, axis=0), axis=1)]
    if len(ring) < 3:
        return np.zeros(len(pts), dtype=bool)
    inside = np.ones(len(pts), dtype=bool)
    for (ax, ay), (bx, by) in zip(ring, np.roll(ring, -1, axis=0)):  # at most 8 edges: O(n) memory
        inside &= (bx - ax) * (y - ay) - (by - ay) * (x - ax) > 0
    return inside


def _half_hull(pts: np.ndarray, tol: float) -> list:
    """One chain of the monotone-chain hull over points sorted along it (points within ``tol``
    of collinear, a cross product in m², dropped)."""
    chain: list = []
    for p in pts:
        while len(chain) >= 2:
            (ax, ay), (bx, by) = chain[-2], chain[-1]
            if (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) > tol:
                break
            chain.pop()
        chain.append((float(p[0]), float(p[1])))
    return chain
