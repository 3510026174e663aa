"""Terrain: everything between a terrain input and the queries a matcher asks of it.

At the top, what both layouts share: ``open`` (the one place that opens or classifies any
terrain and decides mesh or DEM), ``surface`` (the ``Surface`` protocol), ``patches`` (the
footprint queries both surfaces answer), ``footprint`` (the exact footprint pass),
``regions`` (thresholds and classes), ``store`` (the store's format and layout attribute) and
``synthetic`` (terrains of known curvature). Below, three rooms: ``mesh/`` (an irregular
terrain as vertices and faces), ``grid/`` (a DEM as a raster of posts, read by window) and
``curvature/`` (the mean-curvature estimators both use).
"""
