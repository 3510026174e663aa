"""Terrain: clean-up, mean curvature, region classes, point location, both store layouts, DEM
sources, the surfaces queries run on and the exact footprint pass over them."""
