"""Whether a DEM's posts can resolve the ground a vehicle's tracks feel.

A track of contact length L bridges what lies between its supports; the matchers sample the
ground at spans down to L/2 (the six-point matcher's), the classes average it over disks of
L/4 and L/2. Posts wider apart than L/2 leave every one of those spans with at most one post
across: the classes and the poses then cannot resolve the ground the tracks feel (an SRTM or
DTED level 1 tile, 92.6 m posts, against the T-72's 4.28 m tracks classifies nearly all flat).

At the other end, posts closer than L/100 (4.3 cm for a T-72: finer than a track link, a
tenth of its shoe's width) hold nothing a track feels that posts L/100 apart miss, and the
classes' disks, counted in posts, would grow as (L / spacing)^2: the classes then come from
every s-th post (``tiled_classify.class_stride``), with a warning (``tiled_classify.fine_posts``,
beside the stride it reports). Posts closer than a micrometre are bad input (a unit slip;
their squares underflow the differences).
"""

from __future__ import annotations

from tankcd_cli.errors import warn
from tankcd_cli.geometry.post_grid import PostGrid
from tankcd_cli.vehicle import Vehicle


def spacing_over_track(dx: float, dy: float, track_length: float) -> float:
    """The coarser post spacing over the track length."""
    return max(dx, dy) / track_length


def coarse_posts(grid: PostGrid, vehicle: Vehicle, source: str | None) -> bool:
    """A SetupWarning (``errors.warn``) when the posts of ``grid`` (a PostGrid) are wider apart
    than half the vehicle's track length; whether they are."""
    spacing = max(grid.dx, grid.dy)
    track = vehicle.track_length
    if spacing <= track / 2:
        return False

    warn(source, f"posts {spacing:g} m apart are wider than half the {vehicle.name}'s {track:g} m track length: "
                 f"the classes and the poses cannot resolve the ground the tracks feel (posts at most "
                 f"{track / 2:.3g} m apart would)")
    return True
