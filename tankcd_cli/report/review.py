"""The review of a replay: its tracks, its events and where they came from, read once and
written by every output of ``tankcd report`` (docs/formats.md, "Outputs for review")."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Track:
    """One vehicle's pose rows, in time order (the order the replay wrote them).

    entity : the vehicle's name ('' for a replay of one unnamed vehicle)
    step : (n,) int64, the rows' steps (the trajectory rows, as in the poses)
    t : (n,) float64, time, s (NaN where the poses had none)
    x, y : (n,) float64, footprint centre in the terrain's world frame (its CRS), m
    z : (n,) float64, world height of the vehicle-frame origin, m (NaN: a row with status off)
    yaw_deg : (n,) float64, heading, degrees counter-clockwise from east (grid east)
    quaternion : (n, 4) float64, qw, qx, qy, qz, the attitude in the world frame (NaN rows: off)
    status : (n,) uint8, 0 ok, 1 partly_off, 2 off (``STATUS``)
    """

    entity: str
    step: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    yaw_deg: np.ndarray
    quaternion: np.ndarray
    status: np.ndarray

    def __len__(self) -> int:
        return len(self.step)


STATUS = ("ok", "partly_off", "off")


@dataclass(frozen=True)
class Source:
    """One input of the review or of the replay it reviews.

    role : ``poses``, ``events``, ``capture``, ``scene``, ``terrain``, or a role the replay's own
        Parquet metadata names (``trajectory``, ``obstacle``, ...)
    path : as given
    sha256 : the file's SHA-256 ('' where it was not hashed: standard input, a store's own record)
    """

    role: str
    path: str
    sha256: str = ""


@dataclass(frozen=True)
class Review:
    """A replay's outputs, read and checked against each other.

    tracks : one ``Track`` per vehicle, by name (entity order: first appearance in the poses)
    events : the events as the JSON Lines' dicts (``point`` a list [x, y, z] when present), in
        the file's order
    crs_wkt : the terrain's CRS as WKT ('' for a local grid or mesh without one)
    sources : what was read (the poses, the events, the terrain or scene, and what the poses'
        own metadata says the replay read)
    settings : the replay's settings where its outputs record them (Parquet ``tankcd.replay``),
        else an empty dict; ``tankcd_version``: the version that wrote the poses, when known
    vehicle_length, vehicle_width : the hull footprint, m (from the scene's vehicle or preset),
        for drawing footprints
    """

    tracks: tuple
    events: list
    crs_wkt: str = ""
    sources: tuple = ()
    settings: dict = field(default_factory=dict)
    tankcd_version: str = ""
    vehicle_length: float = 6.86
    vehicle_width: float = 3.46

    def track(self, entity: str) -> Track:
        for tr in self.tracks:
            if tr.entity == entity:
                return tr
        raise KeyError(entity)

    @property
    def time_span(self) -> tuple[float, float]:
        """(first, last) time over every track, s (NaN, NaN without times)."""
        lo = [np.nanmin(tr.t) for tr in self.tracks if len(tr) and np.isfinite(tr.t).any()]
        hi = [np.nanmax(tr.t) for tr in self.tracks if len(tr) and np.isfinite(tr.t).any()]
        return (min(lo), max(hi)) if lo else (float("nan"), float("nan"))
