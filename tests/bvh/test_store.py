"""Trees on disk: what is written is read back array for array, with what it was built from; a
file that is not a tree, of another version, or damaged is refused with one line (exit 3)."""

import h5py
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tankcd_cli.bvh.build import build_tree
from tankcd_cli.bvh.query import collide
from tankcd_cli.bvh.store import FORMAT, FORMAT_VERSION, read_tree, write_tree
from tankcd_cli.errors import InputError
from tankcd_cli.vehicle import vehicle_preset
from tankcd_cli.vehicle_mesh import box, cylinder, vehicle_mesh

ARRAYS = ("triangles", "source_index", "lo", "hi", "left", "right", "start", "count", "depth", "centre", "half")


def test_saved_tree_answers_identically(tmp_path):
    A, parts = vehicle_mesh(vehicle_preset("t72"), 2)
    B = box([-3, -3, 0], [3, 3, 4], 4) + [2.0, 0.0, 0.0]
    ta, tb = build_tree(A, k=26, split="sah"), build_tree(B, k=26)
    write_tree(str(tmp_path / "a.h5"), ta, parts)
    loaded, loaded_parts = read_tree(str(tmp_path / "a.h5"))
    np.testing.assert_array_equal(loaded_parts, parts)
    rng = np.random.default_rng(0)
    R = Rotation.random(200, random_state=0).as_matrix()
    t = rng.uniform(-5, 5, (200, 3))
    x, y = collide(ta, tb, R, t, all_contacts=True), collide(loaded, tb, R, t, all_contacts=True)
    for name in ("found", "pairs", "node_tests", "tri_tests"):
        np.testing.assert_array_equal(getattr(x, name), getattr(y, name))





@pytest.mark.parametrize("k, split, levels, leaf", [(6, "median", 0, 1), (14, "sah", 2, 4), (26, "sah", 99, 8)])
def test_round_trip_is_equal_array_for_array(tmp_path, k, split, levels, leaf):
    tris = cylinder([0, 0, 0], 2, 1.0, 3.0, 10, 3)
    tree = build_tree(tris, k=k, split=split, aabb_levels=levels, leaf_size=leaf)
    tree.attrs.update({"source": "barrel.obj", "source_sha256": "ab" * 32, "placement": '{"yaw_deg": 10.0}'})
    path = str(tmp_path / "t.h5")
    write_tree(path, tree)
    back, part = read_tree(path)
    assert part is None
    for name in ARRAYS:
        a, b = getattr(tree, name), getattr(back, name)
        assert a.dtype == b.dtype, name
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert (back.k, back.aabb_levels, back.split, back.leaf_size) == (k, levels, split, leaf)
    assert {key: back.attrs[key] for key in ("source", "source_sha256", "placement")} == \
        {"source": "barrel.obj", "source_sha256": "ab" * 32, "placement": '{"yaw_deg": 10.0}'}
    assert back.attrs["format"] == FORMAT and back.attrs["format_version"] == FORMAT_VERSION
    assert isinstance(back.attrs["tankcd_version"], str)


def _written(tmp_path):
    path = tmp_path / "t.h5"
    tree = build_tree(box([0, 0, 0], [1, 1, 1], 2), k=18, leaf_size=2)
    write_tree(str(path), tree, np.zeros(len(tree.triangles), np.uint8))
    return path, tree


def _damage(path, name, change):
    with h5py.File(path, "r+") as h5:
        data = h5[name][()]
        del h5[name]
        h5[name] = change(data)


@pytest.mark.parametrize("name, change, message", [
    ("nodes/left", lambda a: np.where(a > 0, a + 1000, a), "child indices outside"),
    ("nodes/right", lambda a: np.where(a > 0, -5, a), "child indices outside"),
    ("source_index", lambda a: a - 10, "source indices outside"),
    ("nodes/start", lambda a: a + 1000, "inconsistent node or triangle arrays"),
    ("nodes/count", lambda a: -a - 1, "inconsistent node or triangle arrays"),
    ("nodes/hi", lambda a: a[:-1], "damaged tankcd tree: operands could not be broadcast"),
    ("triangles", lambda a: np.where(np.arange(a.size).reshape(a.shape) == 7, np.nan, a), "inconsistent node or triangle"),
    ("triangles", lambda a: a.reshape(-1, 9), "inconsistent node or triangle arrays"),
    ("source_index", lambda a: a[:-1], "inconsistent node or triangle arrays"),
    ("nodes/depth", lambda a: a + 1, "the nodes do not form a tree"),
    ("nodes/left", lambda a: np.where(a > 0, 0, a), "the nodes do not form a tree"),
])
def test_damaged_trees_are_refused(tmp_path, name, change, message):
    path, _ = _written(tmp_path)
    _damage(path, name, change)
    with pytest.raises(InputError, match=message) as err:
        read_tree(str(path))
    assert str(err.value).startswith(f"{path}: damaged tankcd tree: ") and "\n" not in str(err.value)


def test_missing_parts_foreign_files_and_other_versions_are_refused(tmp_path):
    path, _ = _written(tmp_path)
    with h5py.File(path, "r+") as h5:
        del h5["nodes/depth"]
    with pytest.raises(InputError, match="not a complete tankcd tree"):
        read_tree(str(path))
    path, _ = _written(tmp_path)
    with h5py.File(path, "r+") as h5:
        h5.attrs["format_version"] = FORMAT_VERSION + 1
    with pytest.raises(InputError, match=f"tankcd tree format version {FORMAT_VERSION + 1}.*build it again"):
        read_tree(str(path))
    with h5py.File(path, "r+") as h5:
        h5.attrs["format"] = "tankcd-terrain"
    with pytest.raises(InputError, match="not a tankcd tree"):
        read_tree(str(path))
    text = tmp_path / "x.h5"
    text.write_text("not HDF5 at all\n")
    with pytest.raises(InputError, match="cannot read as HDF5"):
        read_tree(str(text))
    with pytest.raises(InputError, match="no such file"):
        read_tree(str(tmp_path / "none.h5"))
    cut = tmp_path / "cut.h5"
    cut.write_bytes(path.read_bytes()[:2048])  # a truncated copy
    with pytest.raises(InputError):
        read_tree(str(cut))
