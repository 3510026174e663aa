"""Every numerical tolerance of tankcd, in one documented place (the compiled kernels carry
copies of three, which a test holds equal to these)."""

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


# --- the rest, one constant each ---------------------------------------------------------------

EPS_XY = 1e-9
"""m. Horizontal distances below this are zero in the support-plane walk and the patch
clipping (far below any post spacing, far above float64 rounding at UTM coordinates)."""

BARY_EPS = 1e-9
"""Barycentric units. A point this close to a triangle's edge counts as inside it (point
location on meshes and grids), so a point on a shared edge is never lost between two
triangles. Compiled into ``terrain/grid/_post_queries.pyx`` and ``terrain/mesh/_point_queries.pyx``
(a test holds them to this value)."""

TRIANGLE_REL_EPS = 1e-12
"""Relative to the coordinates' magnitude. Triangle-triangle tests treat signed distances
this small as zero: touching and coplanar contact count as contact. Compiled into
``geometry/_triangles.pyx`` (a test holds it to this value)."""

HULL_CONTACT = 0.01
"""m. Ground this far above the hull's bottom face is a terrain-contact event (a centimetre:
below it, survey noise on a flat bottom would report contacts nobody can act on)."""

ESCALATION_ATTITUDE_DEG = 1.0
"""deg. The attitude error a key-point pose may have and pass the reference's certificate
(``matching.match.escalation_tolerance`` turns it into a height at the footprint's corners)."""

ATTITUDE_TOLERANCE_DEG = 0.5
"""deg. The attitude a key-point pose may differ by from each of the certificate's planes and
pass it (``matching.match.certify``), beside the height tolerance at the footprint's corners."""
