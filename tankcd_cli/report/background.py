"""The picture of the terrain a review page draws its tracks on: the region classes, at most a
given number of pixels on a side, in the colours of the replay map (``plots.replay_map_png``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.names import CLASS_NAMES

# the replay map's pale class colours (plots.replay_map_png): tracks and events stay readable on them
CLASS_COLOURS = ("#dcedc8", "#fff3c4", "#ffcdd2")
NO_TERRAIN_COLOUR = "#f0f0f0"
NO_CLASS = 255


@dataclass(frozen=True)
class Background:
    """A terrain picture placed in the world.

    rgb : (h, w, 3) uint8, row 0 the north edge, column 0 the west edge
    x0, x1, y0, y1 : the picture's world extent (its outer pixel edges), m: west, east, south, north
    kind : ``classes`` (the region classes) or ``relief`` (a shaded relief)
    legend : ((label, '#rrggbb'), ...) the colours the picture uses
    """

    rgb: np.ndarray
    x0: float
    x1: float
    y0: float
    y1: float
    kind: str = "classes"
    legend: tuple = ()


def terrain_background(world, max_pixels: int = 1024) -> Background:
    """The class map of ``world``'s terrain (``replay.world.World``), at most ``max_pixels`` on a
    side: a grid store's overview (the worst class of each block of posts), a mesh store's class
    raster (the classes per raster cell that replay itself looks up); blocks of cells merged by
    their worst class where the raster is larger."""
    opened = world.terrain
    if opened.layout == "grid":
        from tankcd_cli.terrain.grid.store import read_overview

        ov = read_overview(opened.store_path)
        g = ov["grid"]
        dx, dy = g.dx * ov["step"], g.dy * ov["step"]
        classes = ov["classes"]  # row 0 north: the grid's first row
        west, north = g.origin_x - g.dx / 2, g.origin_y + g.dy / 2
    else:
        store = opened.mesh_store
        dx = dy = float(store.raster_cell)
        classes = np.asarray(store.class_raster)[::-1]  # the raster's rows grow northwards
        ox, oy = (float(v) for v in store.raster_origin)  # the centre of cell (0, 0)
        west, north = ox - dx / 2, oy + (classes.shape[0] - 0.5) * dy
    classes, k = worst_class_blocks(classes, max_pixels)
    h, w = classes.shape
    return class_picture(classes, west, west + w * k * dx, north - h * k * dy, north)


def worst_class_blocks(classes: np.ndarray, max_pixels: int) -> tuple[np.ndarray, int]:
    """(h, w) uint8 classes (255: none) merged in blocks of k x k by their worst class (255 only
    where a block has none), k the least that brings both sides to ``max_pixels`` or fewer; the
    last blocks padded with none. Returns the merged raster and k."""
    h, w = classes.shape
    k = max(1, -(-max(h, w) // max(int(max_pixels), 1)))
    if k == 1:
        return classes, 1
    hb, wb = -(-h // k), -(-w // k)
    padded = np.full((hb * k, wb * k), -1, dtype=np.int16)
    padded[:h, :w] = np.where(classes == NO_CLASS, -1, classes.astype(np.int16))
    worst = padded.reshape(hb, k, wb, k).max(axis=(1, 3))
    return np.where(worst < 0, NO_CLASS, worst).astype(np.uint8), k


def class_picture(classes: np.ndarray, x0: float, x1: float, y0: float, y1: float) -> Background:
    """A Background of (h, w) classes (row 0 north; 255: no terrain) over the given extent."""
    palette = np.array([_rgb(c) for c in CLASS_COLOURS] + [_rgb(NO_TERRAIN_COLOUR)], dtype=np.uint8)
    index = np.where(classes == NO_CLASS, len(CLASS_COLOURS), np.minimum(classes, len(CLASS_COLOURS) - 1))
    legend = tuple(zip(CLASS_NAMES, CLASS_COLOURS))
    if (classes == NO_CLASS).any():
        legend += (("no terrain", NO_TERRAIN_COLOUR),)
    return Background(palette[index], float(x0), float(x1), float(y0), float(y1), "classes", legend)


def _rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(colour[i:i + 2], 16) for i in (1, 3, 5))
