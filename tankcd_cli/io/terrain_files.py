"""What kind of terrain file a path is, told without reading it as a terrain: an ESRI ASCII grid, a
heightmap, a raster GDAL reads, or a mesh. The store (HDF5) is told apart before, by its signature
(``io.h5.is_hdf5``), where the terrain layer can read its layout."""

from __future__ import annotations

import os

from tankcd_cli.io.esri_ascii import SUFFIXES as ASC_SUFFIXES
from tankcd_cli.io.heightmap import HEIGHTMAP_SUFFIXES, is_heightmap
from tankcd_cli.io.rasters import RASTER_SUFFIXES, is_raster


def file_terrain_kind(path: str, fmt: str = "") -> str:
    """What a terrain file that is not a store is: "esri_ascii", "heightmap", "raster" (one GDAL
    reads, or a folder of tiles) or "mesh" (anything else, for the mesh readers to judge); by the
    format given (a suffix, lower case), else by the suffix and the file's magic bytes. Standard
    input ("-") is a mesh unless ``fmt`` names a DEM. ``terrain.open.terrain_kind`` asks this
    after it has told a store by its HDF5 signature."""
    if fmt in ASC_SUFFIXES:
        return "esri_ascii"
    if fmt in HEIGHTMAP_SUFFIXES:
        return "heightmap"
    if fmt:
        return "raster" if fmt in RASTER_SUFFIXES else "mesh"
    if path == "-":
        return "mesh"
    if os.path.splitext(path)[1].lower().lstrip(".") in ASC_SUFFIXES:
        return "esri_ascii"
    if is_heightmap(path):
        return "heightmap"
    if os.path.isdir(path) or is_raster(path):
        return "raster"
    return "mesh"
