"""Quantized copies of the corpus' terrains against the unquantized ground: do the classes follow the terraces?

Each terrain family of the corpus (``corpus.FAMILIES``, both amplitudes, as DEM grids over the
corpus' 60 m square) is sampled at a post spacing, rounded to a height step (levels at
0.3 q + k q, so that no level sits on the families' flat zero ground), and classified the way
``tankcd classify`` classifies a DEM: the step found on a sample, the filter its passes call for
(``terrain/grid/quantum.py``). Its classes are compared post by post with those of the same
ground unrounded, classified as it is (the ground's classes); "unfiltered", the rounded ground
classified as it is, is what tankcd gave before it looked for steps. Agreement: the share of
posts in the same class. Two families hang on relief at or below the coarser steps and are
reported apart as well: ``rough`` (its finest waves are 4 to 8 cm high) and ``steps``, itself a
staircase of 15 or 30 cm steps: terraces by construction, which classify finds (unrounded too)
and smooths like any other.

    python -m tankcd_cli.tradeoff.quantized      # prints the tables (benchmarks/bench_quantized.py saves them)
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

SPACINGS = (0.25, 0.5, 1.0, 2.0, 5.0)  # m
QUANTA = (0.01, 0.02, 0.05, 0.1, 0.2, 0.5)  # m
# families whose classes hang on relief at or below the coarser steps: ``rough``'s finest waves are
# 4 to 8 cm high, ``steps`` is itself a staircase of 15 to 30 cm steps (terraces by construction)
SUB_STEP_FAMILIES = ("rough", "steps")


@dataclass
class Cell:
    """One spacing and step: posts compared and agreeing, over every family or the smooth ones."""

    spacing: float
    step: float
    passes: int = 0
    posts: int = 0
    agree: int = 0
    agree_unfiltered: int = 0
    smooth_posts: int = 0
    smooth_agree: int = 0
    smooth_agree_unfiltered: int = 0
    by_family: dict | None = None

    @property
    def agreement(self) -> float:
        return self.agree / self.posts if self.posts else float("nan")

    @property
    def agreement_unfiltered(self) -> float:
        return self.agree_unfiltered / self.posts if self.posts else float("nan")

    @property
    def smooth_agreement(self) -> float:
        return self.smooth_agree / self.smooth_posts if self.smooth_posts else float("nan")

    @property
    def smooth_agreement_unfiltered(self) -> float:
        return self.smooth_agree_unfiltered / self.smooth_posts if self.smooth_posts else float("nan")


def ground(family: str, spacing: float, amplitude: float) -> np.ndarray:
    """A corpus family's heights on a DEM grid (row 0 north), 100 m above the datum."""
    from tankcd_cli.tradeoff.corpus import EXTENT, FAMILIES

    n = int(round(EXTENT / spacing)) + 1
    xs = np.arange(n) * spacing
    X, Y = np.meshgrid(xs, xs)
    return np.ascontiguousarray((100.0 + FAMILIES[family](X, Y, amplitude))[::-1])


def rounded(z: np.ndarray, step: float) -> np.ndarray:
    """Heights rounded to levels 0.3 step + k step."""
    offset = 0.3 * step
    return step * np.round((z - offset) / step) + offset


def classes_of(z: np.ndarray, spacing: float, vehicle, thresholds, detect: bool = True):
    """(classes, passes) of a DEM as classify makes them (``detect``: find the step and filter),
    or of the ground as it is."""
    from tankcd_cli.geometry.post_grid import PostGrid
    from tankcd_cli.io.dem_source import DemSourceInfo
    from tankcd_cli.terrain.grid.classify import quantized_heights
    from tankcd_cli.terrain.grid.sources import ArrayDem
    from tankcd_cli.terrain.grid.tiled_classify import classify_grid_tiles

    rows, cols = z.shape
    grid = PostGrid(rows, cols, dx=spacing, dy=spacing)
    dem = ArrayDem(z, grid, DemSourceInfo("<corpus>", "array"))
    passes, smoothing = 0, None
    if detect:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            quantum, passes = quantized_heights(dem.read, grid, dem.info, thresholds)
        smoothing = (quantum.step, passes) if passes else None
    out = np.zeros((rows, cols), np.uint8)

    def keep(t):
        h, w = t.classes.shape
        out[t.r0:t.r0 + h, t.c0:t.c0 + w] = t.classes

    classify_grid_tiles(dem.read, grid, "grid", vehicle.track_length, thresholds, tile=512, jobs=1, on_tile=keep,
                        smoothing=smoothing)
    return out, passes


def measure(spacings=SPACINGS, quanta=QUANTA, families=None, vehicle=None, progress=None) -> list[Cell]:
    """The agreement of every (spacing, step) cell (see the module doc)."""
    from tankcd_cli.terrain.grid.quantum import filter_passes
    from tankcd_cli.terrain.regions import default_thresholds
    from tankcd_cli.tradeoff.corpus import AMPLITUDES, FAMILIES
    from tankcd_cli.vehicle import vehicle_preset

    vehicle = vehicle or vehicle_preset("t72")
    thresholds = default_thresholds(vehicle)
    families = tuple(families or FAMILIES)
    cells = []
    for h in spacings:
        truth = {(f, a): classes_of(ground(f, h, a), h, vehicle, thresholds, detect=False)[0]
                 for f in families for a in AMPLITUDES}
        for q in quanta:
            cell = Cell(h, q, filter_passes(q, h, h, thresholds.flat), by_family={})
            for f in families:
                agree = posts = 0
                for a in AMPLITUDES:
                    zq = rounded(ground(f, h, a), q)
                    got, _ = classes_of(zq, h, vehicle, thresholds)
                    plain, _ = classes_of(zq, h, vehicle, thresholds, detect=False)
                    ref = truth[(f, a)]
                    n, k = ref.size, int((got == ref).sum())
                    cell.posts += n
                    cell.agree += k
                    unfiltered = int((plain == ref).sum())
                    cell.agree_unfiltered += unfiltered
                    if f not in SUB_STEP_FAMILIES:
                        cell.smooth_posts += n
                        cell.smooth_agree += k
                        cell.smooth_agree_unfiltered += unfiltered
                    agree, posts = agree + k, posts + n
                cell.by_family[f] = agree / posts
            cells.append(cell)
            if progress:
                progress(cell)
    return cells


def tables(cells: list[Cell]) -> str:
    """Markdown: agreement (every family, the smooth ones, unfiltered), passes, and by family."""
    spacings = sorted({c.spacing for c in cells})
    quanta = sorted({c.step for c in cells})
    at = {(c.spacing, c.step): c for c in cells}

    def grid(title, value, fmt="{:.1f}"):
        lines = [f"{title}", "", "| step \\ posts | " + " | ".join(f"{h:g} m" for h in spacings) + " |",
                 "| --- |" + " --- |" * len(spacings)]
        for q in quanta:
            row = []
            for h in spacings:
                c = at.get((h, q))
                text = "" if c is None else fmt.format(value(c))
                row.append(f"**{text}**" if c is not None and q <= h / 10 + 1e-12 else text)
            lines.append(f"| {q:g} m | " + " | ".join(row) + " |")
        return "\n".join(lines)

    out = [grid("Posts in the ground's class, %, the eight families without relief at or below the steps (all but "
                "`rough` and `steps`; bold: steps up to a tenth of the post spacing):",
                lambda c: 100 * c.smooth_agreement),
           grid("The same, unfiltered (the rounded heights classified as they are: tankcd before it looked for "
                "steps), %:", lambda c: 100 * c.smooth_agreement_unfiltered),
           grid("Every family (`rough` and `steps` too), %:", lambda c: 100 * c.agreement),
           grid("Every family, unfiltered, %:", lambda c: 100 * c.agreement_unfiltered),
           grid("Smoothing passes for the step (0: it cannot show at that spacing):", lambda c: c.passes, "{:d}")]
    families = list(cells[0].by_family) if cells else []
    lines = ["By family, %, at the steps of a tenth of the post spacing (or the nearest below):", "",
             "| family | " + " | ".join(f"{h:g} m, {_tenth(h, quanta):g} m" for h in spacings) + " |",
             "| --- |" + " --- |" * len(spacings)]
    for f in families:
        lines.append(f"| {f} | " + " | ".join(f"{100 * at[(h, _tenth(h, quanta))].by_family[f]:.1f}"
                                              for h in spacings) + " |")
    out.append("\n".join(lines))
    return "\n\n".join(out)


def _tenth(h: float, quanta) -> float:
    below = [q for q in quanta if q <= h / 10 + 1e-12]
    return max(below) if below else min(quanta)


def main() -> None:
    import sys

    cells = measure(progress=lambda c: print(f"{c.spacing:g} m posts, {c.step:g} m steps: {100 * c.agreement:.1f} %",
                                              file=sys.stderr, flush=True))
    print(tables(cells))


if __name__ == "__main__":
    main()
