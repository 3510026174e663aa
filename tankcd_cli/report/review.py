"""What a report is made of: a replay's poses and events read back, by vehicle (``Review``).

Every writer of ``tankcd_cli.report`` (the page, GeoJSON, CZML, Collision PDUs) takes a ``Review``;
``report.inputs.read_review`` builds one from a replay's output files.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Track:
    """One vehicle's pose rows, in time order (R rows; metres, seconds, degrees, the poses CSV's).

    name : the entity's name ("" for a single vehicle without an entity column)
    step : (R,) int64 the rows' steps; t : (R,) s
    x, y, z : (R,) the vehicle-frame origin in the terrain's CRS, m (NaN: a row without a pose)
    roll_deg, pitch_deg, yaw_deg : (R,) attitude (REP 103; yaw from east, counter-clockwise)
    quaternion : (R, 4) (qw, qx, qy, qz)
    status : (R,) str ok, partly_off, off; matcher : (R,) str what placed the row
    piece : (R,) int64 the piece of motion each row belongs to (a new piece where the motion
        breaks: a row without a pose, or a gap the replay did not run the motion through)
    """

    name: str
    step: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    yaw_deg: np.ndarray
    quaternion: np.ndarray
    status: np.ndarray
    matcher: np.ndarray
    piece: np.ndarray

    def __len__(self) -> int:
        return len(self.t)


@dataclass
class ReviewEvent:
    """One event as the events file has it: step, t (s), kind, the two parties a and b, the entity
    it belongs to ("" for a single vehicle), ``between`` (it began between rows), ``point`` (3,)
    world m or None, and every other field of its line (``fields``, as read)."""

    step: int
    t: float
    kind: str
    a: str
    b: str
    entity: str = ""
    between: bool = False
    point: tuple | None = None
    fields: dict = field(default_factory=dict)


@dataclass
class Source:
    """A file the report read or the replay recorded: its role (poses, events, trajectory, scene,
    terrain, ...), its path as given and its SHA-256 (None where not known)."""

    role: str
    path: str
    sha256: str | None = None


@dataclass
class Review:
    """A replay read back for review.

    tracks : one ``Track`` per vehicle, in the order their names first appear in the poses
    events : every event, in the events file's order
    crs_wkt : the terrain's CRS (WKT) or None (a terrain without one: no GeoJSON, CZML)
    vehicles : each vehicle's kind by track name (preset or vehicle name, as the scene says), and
        its footprint (length, width) m, for drawing
    sources : what was read (the poses and events files with their SHA-256) and what the replay
        recorded of its own inputs (Parquet metadata), for the provenance
    settings : the replay's settings where the outputs record them (matcher, mode, ...), and
        tankcd's version that wrote the report
    """

    tracks: list
    events: list
    crs_wkt: str | None
    vehicles: dict
    sources: list
    settings: dict

    @property
    def time_span(self) -> tuple[float, float]:
        """(first, last) time of any pose row, s ((nan, nan) without rows)."""
        ts = [tr.t for tr in self.tracks if len(tr)]
        if not ts:
            return float("nan"), float("nan")
        return float(min(t[0] for t in ts)), float(max(t[-1] for t in ts))
