"""A small exercise replayed for the report's tests: a rolling UTM terrain (a GeoTIFF in EPSG:32633),
three T-72s, two of which drive into each other, replayed to CSV and JSON Lines (and Parquet)."""

from __future__ import annotations

import numpy as np

X0, Y0 = 500_000.0, 4_500_000.0  # the terrain's north-west corner


def write_terrain(path, crs="EPSG:32633"):
    """A 160 m square GeoTIFF at 2 m posts, gently rolling (row 0 north)."""
    import rasterio
    from rasterio.transform import from_origin

    n = 81
    c = np.arange(n) * 2.0
    z = (100 + 1.5 * np.sin(c[None, :] / 23.0) * np.cos(c[:, None] / 19.0)).astype("float32")
    with rasterio.open(path, "w", driver="GTiff", width=n, height=n, count=1, dtype="float32", crs=crs,
                       transform=from_origin(X0 - 1.0, Y0 + 1.0, 2.0, 2.0)) as dst:
        dst.write(z, 1)
    return path


def write_exercise(path):
    """Rows of three vehicles in time order at 2 Hz for 20 s: A and B head for each other along
    y = Y0 - 60 and meet near x = X0 + 80; C drives north on its own. Returns the CSV's path."""
    t = np.arange(0, 20.01, 0.5)
    lines = ["t,entity,x,y,yaw_deg"]
    for k, tk in enumerate(t):
        lines.append(f"{tk:.3f},A,{X0 + 20 + 3.0 * tk:.3f},{Y0 - 60:.3f},0")
        lines.append(f"{tk + 0.1:.3f},B,{X0 + 140 - 3.0 * (tk + 0.1):.3f},{Y0 - 60:.3f},180")
        lines.append(f"{tk + 0.2:.3f},C,{X0 + 40:.3f},{Y0 - 140 + 2.0 * (tk + 0.2):.3f},90")
    path.write_text("\n".join(lines) + "\n")
    return path


def replay(folder, suffix_poses=".csv", suffix_events=".jsonl"):
    """(terrain, poses, events) of the exercise replayed into ``folder``."""
    from tankcd_cli import api

    terrain = folder / "utm.tif"
    if not terrain.exists():
        write_terrain(terrain)
    trajectory = folder / "exercise.csv"
    if not trajectory.exists():
        write_exercise(trajectory)
    poses, events = folder / f"poses{suffix_poses}", folder / f"events{suffix_events}"
    api.replay_to_files(str(trajectory), poses=str(poses), events=str(events), terrain=str(terrain))
    return terrain, poses, events
