"""The streaming replay pipeline: trajectory chunks in, pose chunks out."""

from __future__ import annotations

from typing import Callable, Iterator

import numpy as np

from tankcd_cli.matching.match import Poses, match
from tankcd_cli.vehicle import Vehicle


def load_terrain_surface(path: str, up: str = "z", fmt: str | None = None, vehicle: Vehicle | None = None,
                         progress: Callable[[str], None] | None = None):
    """A TerrainSurface from a store, or from any terrain input classified on the fly."""
    from tankcd_cli.terrain.classify import classify_terrain, load_terrain
    from tankcd_cli.terrain.store import is_store, read_store
    from tankcd_cli.terrain.surface import TerrainSurface

    say = progress or (lambda s: None)
    if path != "-" and is_store(path):
        say(f"reading terrain store {path}")
        store = read_store(path)
    else:
        say(f"classifying {path} on the fly")
        store = classify_terrain(load_terrain(path, up=up, fmt=fmt), vehicle=vehicle, progress=say)
    return TerrainSurface.from_store(store), store


def replay_poses(surface, vehicle: Vehicle, chunks, matcher: str = "auto", measure: bool = True
                 ) -> Iterator[tuple[object, Poses]]:
    """Match every trajectory chunk; yields (chunk, poses) in order."""
    for chunk in chunks:
        poses = match(surface, vehicle, chunk.x, chunk.y, np.radians(chunk.yaw_deg), matcher=matcher, measure=measure)
        yield chunk, poses
