"""What a replay's map needs, gathered chunk by chunk in bounded memory."""

from __future__ import annotations

import numpy as np

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
                       matcher=matcher if self.colour_by == "matcher" else None, counts=self.counts)


def footprint_outline(triangles: np.ndarray) -> np.ndarray:
    """The convex outline (k, 2) of triangles (m, 3, 3) seen from above, counter-clockwise
    (fewer than 3 distinct points, or all in a line: those points)."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.unique(triangles.reshape(-1, 3)[:, :2], axis=0)
    if len(pts) < 3:
        return pts
    try:
        return pts[ConvexHull(pts).vertices]
    except QhullError:
        return pts[[0, -1]]
