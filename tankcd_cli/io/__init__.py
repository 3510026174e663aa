"""Readers and writers: the only place where tankcd touches files.

Terrain inputs by format family: ``terrain_readers`` (the dispatcher by suffix, ``RawTerrain``),
``obj``, ``gltf``, ``trimesh_formats``, ``meshio_formats``, ``esri_ascii`` (meshes and ASCII
grids) and ``rasters`` (DEM rasters through GDAL, by window); trajectories, poses and events
(``trajectory``, ``csv_columns``, ``poses_csv``, ``events``); HDF5 opening (``h5``); atomic
outputs (``atomic``)."""
