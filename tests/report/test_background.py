"""The terrain picture against the terrain's own class look-up, and the block merge against brute force."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tankcd_cli import api
from tankcd_cli.report.background import CLASS_COLOURS, NO_CLASS, _rgb, terrain_background, worst_class_blocks

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"


def _classes_of(bg) -> np.ndarray:
    palette = np.array([_rgb(c) for c in CLASS_COLOURS])
    match = (bg.rgb[:, :, None, :] == palette[None, None]).all(axis=-1)
    return np.where(match.any(axis=-1), match.argmax(axis=-1), NO_CLASS)


@pytest.mark.parametrize("max_pixels", [40, 23, 12, 5, 1])
def test_worst_class_blocks_against_brute_force(max_pixels):
    rng = np.random.default_rng(max_pixels)
    classes = rng.choice(np.array([0, 1, 2, NO_CLASS], dtype=np.uint8), size=(23, 17), p=[0.5, 0.3, 0.1, 0.1])
    merged, k = worst_class_blocks(classes, max_pixels)
    assert k == -(-23 // max_pixels) and max(merged.shape) <= max_pixels
    for r in range(merged.shape[0]):
        for c in range(merged.shape[1]):
            block = classes[r * k:(r + 1) * k, c * k:(c + 1) * k]
            known = block[block != NO_CLASS]
            assert merged[r, c] == (known.max() if len(known) else NO_CLASS)


@pytest.mark.parametrize("world", [dict(scene=str(SAMPLE / "scene.toml")), dict(terrain=str(SAMPLE / "battlefield.obj"))],
                         ids=["grid", "mesh"])
def test_the_picture_shows_the_class_the_terrain_looks_up(world):
    w = api.load_world(**world)
    bg = terrain_background(w)
    lo, hi = w.surface.bounds()
    # the picture's edges within a cell of the terrain's (a mesh's raster: cell centres from its corner)
    assert abs(bg.x0 - lo[0]) < 1 and abs(bg.x1 - hi[0]) < 1 and abs(bg.y0 - lo[1]) < 1 and abs(bg.y1 - hi[1]) < 1
    cls = _classes_of(bg)
    h, wd = cls.shape
    rng = np.random.default_rng(0)
    x, y = rng.uniform(lo[0] + 1, hi[0] - 1, 2000), rng.uniform(lo[1] + 1, hi[1] - 1, 2000)
    col = ((x - bg.x0) / (bg.x1 - bg.x0) * wd).astype(int)
    row = ((bg.y1 - y) / (bg.y1 - bg.y0) * h).astype(int)  # row 0 north
    want = w.surface.region_under(x, y, np.zeros(len(x)), 0.01, 0.01)
    assert np.mean(cls[row, col] == want) > 0.99  # a few points on class edges
    assert np.mean(cls[::-1][row, col] == want) < 0.9  # a picture upside down would not pass
    small = terrain_background(w, max_pixels=40)
    assert max(small.rgb.shape[:2]) <= 40 and small.x0 == bg.x0 and small.y1 == bg.y1
