"""What ``info`` says of each kind of file, as plain facts: a grid store, a mesh store, a tree and a
scene (its terrain a DEM, a mesh or a store), each fact against what made the file."""

import json

import numpy as np
import pytest

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.store import write_tree
from tankcd_cli.describe import describe_scene, describe_store
from tankcd_cli.errors import InputError
from tankcd_cli.vehicle_mesh import box
from tests.conftest import write_asc, write_obj

X0, Y0 = 500_000.0, 4_500_000.0


def _heights():
    rows, cols = 31, 41  # z[0] is the north row, as in the file
    y, x = np.mgrid[0:rows, 0:cols]
    return 100.0 + 0.4 * np.sin(x / 3.0) * np.cos(y / 4.0) + 0.01 * x


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from tankcd_cli.api import classify

    out = tmp_path_factory.mktemp("describe")
    dem = write_asc(out / "ground.asc", _heights(), cellsize=2.0, xll=X0, yll=Y0)
    classify(str(dem), str(out / "grid.h5"))
    V = np.array([[x, y, 0.05 * x + 0.3 * np.sin(y)] for y in np.arange(0, 21.0) for x in np.arange(0, 31.0)])
    idx = np.arange(len(V)).reshape(21, 31)
    F = np.concatenate([np.column_stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()]),
                        np.column_stack([idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()])])
    mesh = write_obj(out / "ground.obj", V, F)
    classify(str(mesh), str(out / "mesh.h5"))
    hut = box([-2, -1, 0], [2, 1, 3], 1)
    write_obj(out / "hut.obj", hut.reshape(-1, 3), np.arange(3 * len(hut)).reshape(-1, 3))
    tree = build_tree(hut + [10.0, 20.0, 0.0], k=14, split="median", leaf_size=2)
    tree.attrs.update({"source": "hut.obj", "placement": json.dumps({"yaw_deg": 0.0, "position": [10, 20, 0]})})
    write_tree(str(out / "hut.bvh.h5"), tree)
    return out


def test_a_grid_store_says_its_grid_extent_and_classes(files):
    import h5py

    facts = describe_store(str(files / "grid.h5"))
    assert facts["file"] == str(files / "grid.h5") and facts["kind"] == "terrain store" and facts["layout"] == "grid"
    assert facts["grid_posts"] == {"rows": 31, "columns": 41} and facts["posts"] == 31 * 41
    assert facts["post_spacing"] == [2.0, 2.0]
    assert facts["north_west_post"] == [X0, Y0 + 60.0]  # the ASC's lower-left centre, 30 rows of 2 m below
    assert facts["extent_x"] == [X0, X0 + 80.0] and facts["extent_y"] == [Y0, Y0 + 60.0]
    z = _heights()
    assert facts["extent_z"] == pytest.approx([z.min(), z.max()], abs=1e-3)
    assert facts["size_km"] == [0.08, 0.06]
    assert facts["source_format"] and facts["source"].endswith("ground.asc") and len(facts["source_sha256"]) == 64
    with h5py.File(files / "grid.h5") as h5:
        attrs = dict(h5.attrs)
    shares = [facts[f"area_fraction_{c}"] for c in ("flat", "general", "uneven")]
    assert shares == [float(attrs["share_flat"]), float(attrs["share_general"]), float(attrs["share_uneven"])]
    assert sum(shares) == pytest.approx(1.0) and all(isinstance(s, float) for s in shares)
    assert facts["vehicle"] == "t72" and facts["threshold_flat"] < facts["threshold_uneven"]
    assert None not in facts.values()  # facts a grid store does not have are left out
    assert json.loads(json.dumps(facts)) == facts  # plain values: info --json prints them as they are


def test_a_mesh_store_says_its_mesh_and_classes(files):
    facts = describe_store(str(files / "mesh.h5"))
    assert facts["kind"] == "terrain store" and facts["layout"] == "mesh"
    assert facts["vertices"] == 21 * 31 and facts["faces"] == 2 * 20 * 30
    assert facts["extent_x"] == [0.0, 30.0] and facts["extent_y"] == [0.0, 20.0]
    wave = 0.3 * np.sin(np.arange(21.0))  # z = 0.05 x + 0.3 sin y over x 0..30, y 0..20
    assert facts["extent_z"] == pytest.approx([wave.min(), 1.5 + wave.max()], abs=1e-6)
    assert facts["dem_grid_posts"] is None  # an irregular mesh's file: no post grid
    assert set(facts["clean_up"]) == {"merged_vertices", "unreferenced_vertices", "degenerate_faces", "repeated_faces"}
    assert facts["clean_up"]["degenerate_faces"] == 0 and facts["clean_up"]["repeated_faces"] == 0
    rows, cols = facts["class_raster_cells"]["rows"], facts["class_raster_cells"]["columns"]
    assert rows > 0 and cols > 0
    assert sum(facts[f"area_fraction_{c}"] for c in ("flat", "general", "uneven")) == pytest.approx(1.0)


def test_a_tree_says_how_it_was_built_and_its_bounds(files):
    facts = describe_store(str(files / "hut.bvh.h5"))
    assert facts["kind"] == "bounding-volume tree" and facts["source"] == "hut.obj"
    assert facts["placement"] == {"yaw_deg": 0.0, "position": [10, 20, 0]}  # the JSON text as an object
    assert facts["bounds"] == {"min": [8.0, 19.0, 0.0], "max": [12.0, 21.0, 3.0]}
    assert facts["triangles"] == 12 and facts["k"] == 14 and facts["split"] == "median" and facts["leaf_size"] == 2
    assert facts["leaves"] == (facts["nodes"] + 1) // 2 and facts["leaf_triangles_max"] <= 2


def _scene(path, terrain=None, obstacles=(), vehicle_mesh=None, drums=True):
    lines = []
    if terrain is not None:
        lines += ["[terrain]", f'path = "{terrain}"', ""]
    lines += ["[vehicle]", 'preset = "t72"', f"fuel_drums = {str(drums).lower()}"]
    if vehicle_mesh is not None:
        lines += [f'mesh = "{vehicle_mesh}"']
    for name, position, yaw in obstacles:
        lines += ["", "[[obstacle]]", f'name = "{name}"', 'path = "hut.obj"', f"position = {list(position)}",
                  f"yaw_deg = {yaw}"]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_a_scene_on_a_dem_places_each_obstacle_and_says_whether_it_is_on_the_terrain(files):
    path = _scene(files / "dem.toml", "ground.asc", [("in", (X0 + 40, Y0 + 30, 100.0), 90.0),
                                                     ("out", (X0 - 500, Y0, 100.0), 0.0)])
    facts = describe_scene(path)
    assert facts["kind"] == "scene" and facts["file"] == path
    t = facts["terrain"]
    assert t["kind"] == "DEM (asc, 31 rows x 41 columns of posts, classified on the fly)"
    assert t["extent_x"] == [X0, X0 + 80.0] and t["extent_y"] == [Y0, Y0 + 60.0]
    inside, outside = facts["obstacles"]
    assert inside["triangles"] == 12 and inside["on_terrain"] is True and outside["on_terrain"] is False
    # a 4 x 2 m hut turned a quarter turn: 2 m along x, 4 m along y, about its origin at the position
    np.testing.assert_allclose(inside["bounds"]["min"], [X0 + 39, Y0 + 28, 100.0], atol=1e-9)
    np.testing.assert_allclose(inside["bounds"]["max"], [X0 + 41, Y0 + 32, 103.0], atol=1e-9)
    assert inside["up_applied"] == "z"
    assert facts["vehicle"]["mesh"] is None and facts["vehicle"]["fuel_drums"] is True
    assert facts["effects"]["turret_still"] == {"terrain_contact": True, "obstacles": True, "internal": False}
    assert facts["effects"]["turret_moving"]["internal"] is True


def test_a_scene_on_a_mesh_or_a_store_or_on_nothing(files):
    mesh = describe_scene(_scene(files / "mesh.toml", "ground.obj"))["terrain"]
    assert mesh["kind"] == "mesh (obj, 1,200 triangles, classified on the fly)" and mesh["up_applied"] == "z"
    assert mesh["extent_x"] == [0.0, 30.0] and mesh["extent_y"] == [0.0, 20.0]
    store = describe_scene(_scene(files / "store.toml", "grid.h5"))["terrain"]
    assert store["kind"] == "terrain store (grid layout)" and store["extent_x"] == [X0, X0 + 80.0]
    nothing = describe_scene(_scene(files / "none.toml", None, [("hut", (0, 0, 0), 0.0)], drums=False))
    assert nothing["terrain"] == {"path": None, "up": None} and nothing["obstacles"][0]["on_terrain"] is None
    assert nothing["effects"]["turret_moving"] == {"terrain_contact": True, "obstacles": True, "internal": False}


def test_a_scene_with_a_vehicle_mesh_counts_its_triangles_and_parts(files):
    lines = ["o hull"] + [f"v {x} {y} {z}" for x, y, z in box([-3, -1.5, 0.4], [3, 1.5, 1.4]).reshape(-1, 3)]
    lines += [f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}" for i in range(12)]
    lines += ["o turret"] + [f"v {x} {y} {z}" for x, y, z in box([-1, -1, 1.4], [1, 1, 2.2]).reshape(-1, 3)]
    lines += [f"f {36 + 3 * i + 1} {36 + 3 * i + 2} {36 + 3 * i + 3}" for i in range(12)]
    (files / "tank.obj").write_text("\n".join(lines) + "\n")
    mesh = describe_scene(_scene(files / "tank.toml", "ground.asc", vehicle_mesh="tank.obj"))["vehicle"]["mesh"]
    assert mesh["triangles"] == 24 and mesh["parts"] == {"hull": 12, "turret": 12}
    assert mesh["bounds"] == {"min": [-3.0, -1.5, 0.4], "max": [3.0, 1.5, 2.2]}


def test_what_is_not_a_store_a_tree_or_a_scene_is_refused(files, tmp_path):
    with pytest.raises(InputError, match="no such file"):
        describe_store(str(tmp_path / "none.h5"))
    assert describe_store(str(files / "ground.asc"))["kind"] == "DEM raster"  # a raw terrain, described
    (tmp_path / "junk.bin").write_bytes(b"\x00\x01junk")
    with pytest.raises(InputError, match="junk.bin: not a file tankcd reads or writes: not a terrain store"):
        describe_store(str(tmp_path / "junk.bin"))
    with pytest.raises(InputError, match="is a bounding-volume tree, not a terrain"):
        describe_scene(_scene(tmp_path / "tree.toml", files / "hut.bvh.h5"))
    assert describe_store(_scene(files / "via_store.toml", "ground.asc"))["kind"] == "scene"  # a .toml: a scene
