"""Generate the bundled sample battlefield (deterministic: seeded, no inputs).

    python sample_data/make_sample_data.py [OUT_DIR]

A 240 m x 160 m terrain at 1 m post spacing, heights in mm:

- west third (x < 80 m): a flat plain with a 0.5 % regional slope;
- middle third: rolling ground (hills about 1.5 m high, 55 to 70 m across);
- east third: uneven ground: three shell craters with rims, an anti-tank
  ditch running north-south, and an earth berm running east-west.

Writes ``battlefield.asc`` (ESRI ASCII grid placed at UTM-like coordinates,
x = 500 000, y = 4 500 000, to exercise far-from-origin arithmetic),
``battlefield.obj`` (the same surface as a z-up triangle mesh in local
coordinates, triangulated as DEM exports are) and ``patrol.csv`` (a
trajectory in the ASC's coordinates: across the plain, over the rolling
ground, past a crater, over the berm and along the ditch, at 10 rows per
second, the turret sweeping round and the gun dipping on the way back).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

SEED = 20261122
WIDTH, DEPTH, SPACING = 240.0, 160.0, 1.0
UTM_ORIGIN = (500_000.0, 4_500_000.0)


def smoothstep(t):
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3 - 2 * t)


def battlefield_height(x: np.ndarray, y: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    z = 100.0 + 0.005 * x
    rolling = smoothstep((x - 70) / 20) * (1 - smoothstep((x - 150) / 20))
    z += rolling * 1.5 * np.sin(2 * np.pi * x / 70) * np.cos(2 * np.pi * y / 55)
    uneven = smoothstep((x - 155) / 15)
    z += uneven * 0.6 * np.sin(2 * np.pi * x / 45 + 1.0) * np.sin(2 * np.pi * y / 38)
    # craters: C1 bowl and a Gaussian rim
    for cx, cy, radius, depth in ((185, 40, 6.0, 1.8), (215, 70, 4.5, 1.4), (200, 135, 7.0, 2.0)):
        r = np.hypot(x - cx, y - cy)
        bowl = np.where(r < radius, -depth * (1 - (r / radius) ** 2) ** 2, 0.0)
        rim = 0.5 * np.exp(-(((r - radius) / 1.5) ** 2))
        z += bowl + rim
    # anti-tank ditch, 5 m wide at the top, 1.5 m at the bottom, 1.8 m deep, running north-south
    d = np.abs(x - (228 - 0.05 * y))
    z -= 1.8 * smoothstep((2.5 - d) / 1.75) * smoothstep((y - 10) / 5) * (1 - smoothstep((y - 150) / 5))
    # earth berm, 1.5 m high, 6 m base, running east-west
    d = np.abs(y - 100)
    along = smoothstep((x - 165) / 4) * (1 - smoothstep((x - 215) / 4))
    z += along * 1.5 * np.where(d < 3, np.cos(np.pi * d / 6) ** 2, 0.0)
    z += rng.normal(0.0, 0.002, z.shape)  # survey noise
    return np.round(z, 3)


def main(out_dir: str | None = None) -> None:
    out = Path(out_dir) if out_dir else Path(__file__).resolve().parent
    rng = np.random.default_rng(SEED)
    ncols, nrows = int(WIDTH / SPACING) + 1, int(DEPTH / SPACING) + 1
    xs = np.arange(ncols) * SPACING
    ys = np.arange(nrows) * SPACING
    X, Y = np.meshgrid(xs, ys)  # row 0 = south
    Z = battlefield_height(X, Y, rng)

    with open(out / "battlefield.asc", "w", newline="\n") as fh:
        fh.write(f"ncols {ncols}\nnrows {nrows}\n")
        fh.write(f"xllcenter {UTM_ORIGIN[0]:.1f}\nyllcenter {UTM_ORIGIN[1]:.1f}\n")
        fh.write(f"cellsize {SPACING}\nNODATA_value -9999\n")
        for row in Z[::-1]:  # ESRI grids list the north row first
            fh.write(" ".join(f"{v:.3f}" for v in row) + "\n")

    index = np.arange(nrows * ncols).reshape(nrows, ncols) + 1  # OBJ counts from 1
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, 1:], index[1:, :-1]
    faces = np.concatenate([np.column_stack([a.ravel(), b.ravel(), c.ravel()]),
                            np.column_stack([a.ravel(), c.ravel(), d.ravel()])])
    with open(out / "battlefield.obj", "w", newline="\n") as fh:
        fh.write("# tankcd sample battlefield, z-up, metres, local coordinates (see make_sample_data.py)\n")
        fh.write("\n".join(f"v {x:g} {y:g} {z:.3f}" for x, y, z in zip(X.ravel(), Y.ravel(), Z.ravel())))
        fh.write("\n")
        fh.write("\n".join(f"f {p} {q} {r}" for p, q, r in faces))
        fh.write("\n")
    patrol(out)


def patrol(out: Path) -> None:
    """A patrol path through every zone, as a trajectory CSV (UTM-like coordinates)."""
    # way points (local metres) joined by straight legs at 5 m/s, headings from the legs
    way = np.array([[10, 80], [70, 60], [130, 95], [170, 60], [190, 52], [195, 90],
                    [200, 115], [212, 140], [222, 120], [220, 30], [150, 25], [60, 30]], dtype=float)
    legs = np.diff(way, axis=0)
    length = np.hypot(legs[:, 0], legs[:, 1])
    s = np.arange(0.0, length.sum(), 0.5)  # 0.5 m per row at 5 m/s: 10 rows per second
    cum = np.concatenate([[0.0], np.cumsum(length)])
    leg = np.minimum(np.searchsorted(cum, s, side="right") - 1, len(legs) - 1)
    frac = (s - cum[leg]) / length[leg]
    xy = way[leg] + frac[:, None] * legs[leg]
    yaw = np.degrees(np.arctan2(legs[leg, 1], legs[leg, 0]))
    t = s / 5.0
    turret = (t * 12.0) % 360.0 - 180.0  # a slow sweep, 12 degrees a second
    gun = np.where(t > t.max() * 0.6, -6.0 * np.clip((t - t.max() * 0.6) / 10.0, 0, 1), 2.0)
    with open(out / "patrol.csv", "w", newline="\n") as fh:
        fh.write("t,x,y,yaw_deg,turret_deg,gun_deg\n")
        for row in zip(t, xy[:, 0] + UTM_ORIGIN[0], xy[:, 1] + UTM_ORIGIN[1], yaw, turret, gun):
            fh.write("%.2f,%.3f,%.3f,%.3f,%.2f,%.2f\n" % row)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else None)
