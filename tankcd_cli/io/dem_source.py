"""What a DEM source serves beside its geometry: where its posts come from and how they are read.

Every DEM source (a raster through GDAL, an ESRI grid through tankcd's parser, the heights of
a grid store, an array) has ``grid``, a :class:`~tankcd_cli.geometry.post_grid.PostGrid` (the
metric grid it serves, after any reprojection), and ``info``, a :class:`DemSourceInfo`.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class DemSourceInfo:
    """A DEM source's provenance and reading details.

    source : the input's name as given ("<stdin>" for standard input)
    format : the format read (a GDAL driver name, "asc", "h5", ...)
    sha256 : the SHA-256 of the input's bytes ("" when unknown)
    source_crs_name : the source's own CRS, in words ("" when the grid keeps it)
    reprojected : whether the grid was warped from the source's CRS
    height_dtype : "float32" when every height is exactly a float32, else "float64"
    nodata, dtype, band, bands, block : a raster's NODATA value, band type, band read (from 1),
        band count and block shape (rows, cols); other sources keep the defaults
    heightmap : how a heightmap's values became posts (JSON text: format, bits, spacing, z_scale,
        z_offset, origin, crs, ...), "" for other sources
    notes : what was read in a way worth saying under -v (an alpha channel ignored, ...)
    source_crs_wkt : the source's own CRS as WKT ("" without one)
    source_point_scale : a projected source CRS's point scale at the centre (projected over ground
        length, ``io.rasters.PointScale.centre``); 0 when the source is not in a projected CRS
    source_point_scale_range : its least and greatest meridional or parallel scale over the extent
    """

    source: str
    format: str
    sha256: str = ""
    source_crs_name: str = ""
    reprojected: bool = False
    height_dtype: str = "float64"
    nodata: float | None = None
    dtype: str = "float64"
    band: int = 1
    bands: int = 1
    block: tuple[int, int] = (0, 0)
    heightmap: str = ""
    notes: tuple[str, ...] = ()
    source_crs_wkt: str = ""
    source_point_scale: float = 0.0
    source_point_scale_range: tuple[float, float] = (0.0, 0.0)
