"""The sample battlefield: written byte for byte as the repository ships it, the same every time, and
the ground, the path and the scene what the module's docstring says they are."""

from pathlib import Path

import numpy as np
import pytest

from tankcd_cli import sample
from tankcd_cli.sample import SEED, UTM_ORIGIN, battlefield_height, smoothstep, write_sample

SHIPPED = Path(__file__).resolve().parents[1] / "sample_data"
FILES = ("battlefield.asc", "battlefield.obj", "patrol.csv", "depot.obj", "wall.obj", "scene.toml")


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("sample")
    write_sample(str(out / "nested" / "dir"))  # made if missing
    return out / "nested" / "dir"


def test_what_is_written_is_what_the_repository_ships(written):
    assert sorted(p.name for p in written.iterdir()) == sorted(FILES)
    for name in FILES:
        assert (written / name).read_bytes() == (SHIPPED / name).read_bytes(), name


def test_writing_again_gives_the_same_bytes(written, tmp_path):
    sample.main(str(tmp_path))
    for name in FILES:
        assert (tmp_path / name).read_bytes() == (written / name).read_bytes(), name


def _asc(path):
    lines = path.read_text().splitlines()
    header = dict(line.split() for line in lines[:6])
    return header, np.array([[float(v) for v in row.split()] for row in lines[6:]])


def test_the_grid_is_240_by_160_m_at_utm_like_coordinates_in_millimetres(written):
    header, z = _asc(written / "battlefield.asc")
    assert header == {"ncols": "241", "nrows": "161", "xllcenter": "500000.0", "yllcenter": "4500000.0",
                      "cellsize": "1.0", "NODATA_value": "-9999"}
    assert z.shape == (161, 241)
    np.testing.assert_array_equal(np.round(z, 3), z)
    south = z[::-1]  # the file lists the north row first
    x = np.arange(241.0)
    # the west plain: 100 m rising 0.5 % eastward, within the survey noise (sigma 2 mm)
    plain = south[:, :60] - (100.0 + 0.005 * x[None, :60])
    assert np.abs(plain).max() < 0.012 and abs(plain.mean()) < 5e-4 and 0.0015 < plain.std() < 0.0025
    # a crater at (185, 40), 1.8 m deep, and the ditch, 1.8 m deep, along x = 228 - 0.05 y
    assert south[40, 185] < 100.0 + 0.005 * 185 - 1.2
    for y in range(30, 140, 10):
        c = int(round(228 - 0.05 * y))
        banks = 0.5 * (south[y, c - 6] + south[y, c + 6])  # beyond its 5 m top width on either side
        assert south[y, c] < banks - 1.2, y
    # the berm along y = 100, 1.5 m high, between x = 170 and 210
    assert (south[100, 175:205] - south[110, 175:205]).min() > 0.5


def test_the_height_field_is_seeded_and_its_pieces_are_closed_forms():
    x, y = np.meshgrid(np.arange(0.0, 240.0, 7.0), np.arange(0.0, 160.0, 9.0))
    a = battlefield_height(x, y, np.random.default_rng(SEED))
    b = battlefield_height(x, y, np.random.default_rng(SEED))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, battlefield_height(x, y, np.random.default_rng(SEED + 1)))
    t = np.linspace(-1, 2, 31)
    s = smoothstep(t)
    np.testing.assert_allclose(s, np.where(t <= 0, 0, np.where(t >= 1, 1, 3 * t ** 2 - 2 * t ** 3)))


def test_the_mesh_is_the_same_surface_in_local_coordinates(written):
    _, z = _asc(written / "battlefield.asc")
    v, f = [], []
    for line in (written / "battlefield.obj").read_text().splitlines():
        if line.startswith("v "):
            v.append([float(c) for c in line.split()[1:]])
        elif line.startswith("f "):
            f.append([int(c) - 1 for c in line.split()[1:]])
    v, f = np.array(v), np.array(f)
    assert v.shape == (161 * 241, 3) and f.shape == (2 * 160 * 240, 3)
    grid = v.reshape(161, 241, 3)  # row 0 the south
    np.testing.assert_array_equal(grid[..., 2], z[::-1])
    np.testing.assert_array_equal(grid[0, :, 0], np.arange(241.0))
    np.testing.assert_array_equal(grid[:, 0, 1], np.arange(161.0))
    e1, e2 = v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]
    up = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    assert (up > 0).all()  # every face counter-clockwise seen from above


def test_the_patrol_runs_at_5_m_s_and_10_rows_a_second_over_the_terrain(written):
    data = np.genfromtxt(written / "patrol.csv", delimiter=",", names=True)
    assert data.dtype.names == ("t", "x", "y", "yaw_deg", "turret_deg", "gun_deg")
    np.testing.assert_allclose(np.diff(data["t"]), 0.1, atol=0.006)  # t printed to 0.01 s
    step = np.hypot(np.diff(data["x"]), np.diff(data["y"]))
    assert np.median(step) == pytest.approx(0.5, abs=2e-3) and step.max() <= 0.5 + 2e-3  # x, y to the mm
    lx, ly = data["x"] - UTM_ORIGIN[0], data["y"] - UTM_ORIGIN[1]
    assert lx.min() > 5 and lx.max() < 235 and ly.min() > 5 and ly.max() < 155
    straight = np.diff(data["yaw_deg"]) == 0  # along a leg the heading is the direction of travel
    heading = np.degrees(np.arctan2(np.diff(data["y"]), np.diff(data["x"])))
    off = (heading - data["yaw_deg"][:-1] + 180) % 360 - 180
    assert straight.mean() > 0.95 and np.abs(off[straight]).max() < 0.5
    assert data["turret_deg"].min() >= -180 and data["turret_deg"].max() < 180
    assert set(np.unique(data["gun_deg"][data["t"] < 0.5 * data["t"].max()])) == {2.0}


def _obj_vertices(path):
    return np.array([[float(c) for c in line.split()[1:]] for line in path.read_text().splitlines()
                     if line.startswith("v ")])


def test_the_wall_is_the_z_up_box_exported_y_up_and_the_scene_places_both(written):
    from tankcd_cli.scene import load_scene

    depot = _obj_vertices(written / "depot.obj")
    np.testing.assert_array_equal(depot.min(axis=0), [-6, -4, 0])
    np.testing.assert_array_equal(depot.max(axis=0), [6, 4, 6])
    wall = _obj_vertices(written / "wall.obj")
    z_up = np.column_stack([wall[:, 0], -wall[:, 2], wall[:, 1]])  # y-up back to z-up
    np.testing.assert_allclose(z_up.min(axis=0), [-7, -0.3, 0], atol=1e-12)
    np.testing.assert_allclose(z_up.max(axis=0), [7, 0.3, 3], atol=1e-12)
    sc = load_scene(str(written / "scene.toml"))
    assert Path(sc.terrain_path).name == "battlefield.asc"
    assert sc.vehicle.name == "t72" and sc.vehicle.fuel_drums
    by_name = {ob.name: ob for ob in sc.obstacles}
    assert sorted(by_name) == ["depot", "wall"] and by_name["wall"].up == "y" and by_name["depot"].up is None
    np.testing.assert_allclose(by_name["depot"].position, [UTM_ORIGIN[0] + 112, UTM_ORIGIN[1] + 12, 99.5])
