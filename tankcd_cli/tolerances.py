"""Every numerical tolerance of tankcd, in one documented place."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Tolerances:
    """Tolerances used across the pipeline.

    merge_distance : m
        Vertices closer than this are one vertex (duplicates from exporters,
        tiled DEMs). 1 um is far below any survey precision and far above the
        float64 spacing at UTM northings (about 1e-9 m at 4.5e6 m).
    degenerate_area_ratio : 1
        A face whose area is below this times its longest edge squared has no
        usable normal or angles (a zero-area or collinear face) and is dropped.
        Slivers above it are kept and handled by the curvature code.
    singular_ratio : 1
        A 3x3 sphere-fit system whose determinant is below this times the
        product of its row norms is treated as singular: the four points are
        coplanar and the normal curvature along that edge is zero.
    """

    merge_distance: float = 1e-6
    degenerate_area_ratio: float = 1e-12
    singular_ratio: float = 1e-12


DEFAULT = Tolerances()
