"""Region classes (flat, general, uneven) from footprint-averaged mean curvature: the thresholds
and the classes of averaged values, shared by both layouts (each averages in its own way:
``mesh/footprint_average.py``, ``grid/tiled_classify.py``).

Why these thresholds (the derivation behind ``default_thresholds``):

A track of ground-contact length L rests on its end points when a matcher
supports it there (the two-point matcher's front and rear points, the
four-point matcher's patch corners). Where the ground along the track has
normal curvature k, it bulges by k L^2 / 8 from that chord halfway along the
track: a penetration on a crest, a gap in a dip. The normal curvature along a
track is at most 2 |H| wherever the surface is not a saddle (equality on a
cylinder across the track), so the chord error is at most

    delta = |H| L^2 / 4,        i.e.  H = 4 delta / L^2.

``flat``    the two-point match errs by at most ``flat_error`` (default 2 cm,
            the order of a good DEM's vertical precision and invisible against
            a 2.2 m tank): H_flat = 4 * 0.02 / L^2 = 0.0044 1/m for the T-72.
``uneven``  the four-point match errs by more than ``uneven_error`` (default
            10 cm, a fifth of the T-72's 0.49 m ground clearance); the
            six-point match, supported at mid-track too, halves the span and
            quarters that error: H_uneven = 4 * 0.10 / L^2 = 0.022 1/m.
``general`` in between.

The averaged curvature (the paper classifies by "average curvature") is the
area-weighted mean of |H| over a disk of radius L/2 around the vertex, the
ground one footprint can touch at any heading, after H itself is averaged over
a disk of radius L/4. That first, signed average removes what no matcher here
can represent (the finest spacing any of them samples along a track is the
six-point's L/2): DEM noise, terraces from quantized heights, bumps a track
bridges. Averaging |H| rather than H over the footprint keeps a crater rim and
its bowl from cancelling. With 1 cm height quantization at 1 m spacing the
residual noise is about 0.002 1/m, below the flat threshold.
Saddles have H = 0 whatever their normal
curvatures: mean-curvature classes cannot see them (the paper's limitation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tankcd_cli.vehicle import Vehicle

from tankcd_cli.names import CLASS_NAMES, FLAT, GENERAL, NO_CLASS, UNEVEN  # noqa: F401 (shared names)


@dataclass(frozen=True)
class Thresholds:
    """|H| class boundaries, 1/m: flat below ``flat``, uneven at or above ``uneven``."""

    flat: float
    uneven: float
    derivation: str = "user"

    def __post_init__(self):
        if not (np.isfinite(self.flat) and np.isfinite(self.uneven) and 0 <= self.flat <= self.uneven):
            raise ValueError(f"thresholds need 0 <= FLAT <= UNEVEN, got {self.flat} and {self.uneven}")


def default_thresholds(vehicle: Vehicle, flat_error: float = 0.02, uneven_error: float = 0.10) -> Thresholds:
    """Thresholds from the chord error of a track of the vehicle's contact length (see module doc)."""
    L2 = vehicle.track_length ** 2
    return Thresholds(4 * flat_error / L2, 4 * uneven_error / L2,
                      derivation=f"H = 4 delta / L^2 with L = {vehicle.track_length} m ({vehicle.name}), "
                                 f"delta = {flat_error} m (flat) and {uneven_error} m (uneven)")


def classify_values(mean_abs_h: np.ndarray, thresholds: Thresholds) -> np.ndarray:
    """Class codes (uint8) of averaged |H| values."""
    out = np.full(mean_abs_h.shape, GENERAL, dtype=np.uint8)
    out[mean_abs_h < thresholds.flat] = FLAT
    out[mean_abs_h >= thresholds.uneven] = UNEVEN
    return out
