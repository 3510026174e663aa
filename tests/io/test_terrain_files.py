"""What kind of terrain file a path is (``io.terrain_files.file_terrain_kind``): by the format given,
else by the suffix and the file's first bytes, as ``terrain.open.terrain_kind`` and the scene ask."""

import numpy as np
import pytest

from tankcd_cli.io.terrain_files import file_terrain_kind
from tests.conftest import write_asc


def test_each_kind_by_its_suffix_its_bytes_or_the_format_given(tmp_path):
    write_asc(tmp_path / "g.asc", np.zeros((4, 4)))
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert file_terrain_kind(str(tmp_path / "g.asc")) == "esri_ascii"
    assert file_terrain_kind(str(tmp_path / "m.obj")) == "mesh"
    assert file_terrain_kind("-") == "mesh" and file_terrain_kind("-", "asc") == "esri_ascii"
    assert file_terrain_kind(str(tmp_path / "m.obj"), "tif") == "raster"  # the format given decides
    assert file_terrain_kind(str(tmp_path), "") == "raster"  # a folder of tiles


def test_a_geotiff_without_its_suffix_and_a_png_heightmap(tmp_path):
    rasterio = pytest.importorskip("rasterio")
    from rasterio.transform import from_origin

    with rasterio.open(tmp_path / "dem.data", "w", driver="GTiff", height=4, width=4, count=1, dtype="float32",
                       crs="EPSG:32633", transform=from_origin(500000, 4500000, 1, 1)) as dst:
        dst.write(np.zeros((4, 4), "float32"), 1)
    assert file_terrain_kind(str(tmp_path / "dem.data")) == "raster"  # its magic bytes
    import matplotlib.image

    matplotlib.image.imsave(tmp_path / "h.png", np.zeros((8, 8)), cmap="gray")
    assert file_terrain_kind(str(tmp_path / "h.png")) == "heightmap"
