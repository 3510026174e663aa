"""Terrain: clean-up, mean curvature, region classes, point location, the store."""
