"""Benchmark: quantized copies of the corpus' terrains against the unquantized ground's classes.

    python benchmarks/bench_quantized.py [--out benchmarks/results/quantized.md]
    python benchmarks/bench_quantized.py --figure docs/quantized.png   # the picture in docs/method.md

Every terrain family of the corpus (tankcd_cli/tradeoff/corpus.py, both amplitudes, DEM grids
over its 60 m square) at 0.25 to 5 m posts, rounded to steps of 1 cm to 0.5 m, classified as
``tankcd classify`` classifies a DEM (the step found on a sample and the filter its passes
call for, tankcd_cli/terrain/grid/quantum.py), against the same ground unrounded; the share of
posts in the same class, per step and spacing (tankcd_cli/tradeoff/quantized.py measures;
docs/method.md quotes the tables). Deterministic: the same numbers on any machine.

``--figure`` draws instead the classes of an 8-bit heightmap (40 m of relief in 255 steps of
0.157 m, 2 m posts, 400 m square): the ground's, the rounded heights' as they are, and
classify's (the step found, the heights smoothed within half a step).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))


def main() -> None:
    from tankcd_cli import __version__
    from tankcd_cli.tradeoff.quantized import measure, tables

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join(HERE, "results", "quantized.md"))
    parser.add_argument("--figure", default=None, help="draw the 8-bit heightmap's classes to this PNG instead")
    args = parser.parse_args()
    if args.figure:
        figure(args.figure)
        return
    started = time.perf_counter()
    cells = measure(progress=lambda c: print(f"{c.spacing:g} m posts, {c.step:g} m steps: "
                                             f"{100 * c.smooth_agreement:.1f} %", file=sys.stderr, flush=True))
    text = "\n".join([
        "# Quantized heights: the classes against the unquantized ground's",
        "",
        f"`python benchmarks/bench_quantized.py` (tankcd {__version__}, Python {platform.python_version()}, "
        f"{time.perf_counter() - started:.0f} s). The corpus' ten terrain families, both amplitudes, as DEM grids "
        "of 60 m x 60 m; heights rounded to 0.3 q + k q; the T-72's classes (flat below 0.0044 1/m, uneven from "
        "0.022 1/m).",
        "",
        tables(cells),
    ])
    save_report(text, args.out)


def eight_bit_ground(n: int = 201, spacing: float = 2.0):
    """A smooth landscape of 40 m relief (row 0 north), and its 8-bit heightmap's heights."""
    import numpy as np

    y, x = np.mgrid[0:n, 0:n] * spacing
    z = (24 * np.exp(-((x - 250) ** 2 + (y - 140) ** 2) / (2 * 70 ** 2)) + 7 * np.sin(x / 45) * np.cos(y / 60)
         + 4 * np.exp(-((x - 90) ** 2 + (y - 300) ** 2) / (2 * 35 ** 2)))
    z = (z - z.min()) / (z.max() - z.min()) * 40.0
    step = 40.0 / 255
    return z, np.round(z / step) * step


def figure(path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from tankcd_cli.names import CLASS_NAMES
    from tankcd_cli.terrain.regions import default_thresholds
    from tankcd_cli.tradeoff.quantized import classes_of
    from tankcd_cli.vehicle import vehicle_preset

    vehicle = vehicle_preset("t72")
    thresholds = default_thresholds(vehicle)
    spacing = 2.0
    z, rounded = eight_bit_ground(spacing=spacing)
    panels = [("the ground (unrounded)", z, False), ("8-bit heightmap, as it is", rounded, False),
              ("8-bit heightmap, classify (smoothed within half a step)", rounded, True)]
    cmap = ListedColormap(["#9ccc65", "#ffca28", "#e53935"])
    norm = BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3)
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.4), constrained_layout=True)
    extent = (0, (z.shape[1] - 1) * spacing, 0, (z.shape[0] - 1) * spacing)
    for ax, (title, heights, detect) in zip(axes, panels):
        classes, passes = classes_of(heights, spacing, vehicle, thresholds, detect=detect)
        shares = np.bincount(classes.ravel(), minlength=3)[:3] / classes.size
        im = ax.imshow(classes, cmap=cmap, norm=norm, extent=extent, interpolation="nearest")
        ax.set_title(f"{title}\n" + ", ".join(f"{n} {s:.0%}" for n, s in zip(CLASS_NAMES, shares))
                     + (f" ({passes} passes)" if detect else ""), fontsize=9)
        ax.set_xlabel("x, m")
    axes[0].set_ylabel("y, m")
    cb = fig.colorbar(im, ax=axes, ticks=[0, 1, 2], shrink=0.8)
    cb.ax.set_yticklabels(list(CLASS_NAMES))
    fig.suptitle("T-72 region classes of an 8-bit heightmap: 0.157 m steps at 2 m posts "
                 "(python benchmarks/bench_quantized.py --figure docs/quantized.png)", fontsize=10)
    fig.savefig(path, dpi=90, format="png")
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
