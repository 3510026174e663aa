"""The terrain readers' dispatcher: every format by its suffix, the up-axis conventions and
conversion, standard input, and files it refuses (missing, unknown, images, Collada without
its loader) named in one line."""

import io
import os

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.terrain_readers import known_formats, read_terrain
from tests.conftest import write_obj


def square_mesh():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0.25]], dtype=float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    return V, F


@pytest.mark.parametrize("fmt", ["obj", "ply", "stl", "off", "glb", "vtk", "vtu"])
def test_mesh_formats_round_trip(tmp_path, fmt):
    V, F = square_mesh()
    V = V + [500000.0, 4500000.0, 100.0]
    path = tmp_path / f"t.{fmt}"
    if fmt in ("vtk", "vtu"):
        import meshio

        meshio.write(str(path), meshio.Mesh(V, [("triangle", F)]))
    else:
        import trimesh

        trimesh.Trimesh(V, F, process=False).export(str(path))
    # trimesh writes the vertices as given: a z-up glTF here (the format's own default is y-up)
    raw = read_terrain(str(path), up="z" if fmt == "glb" else None)
    # STL stores float32 and repeats vertices per face; compare as sets of triangles
    tri_in = np.sort(V[F].reshape(-1, 3), axis=0)
    tri_out = np.sort(raw.vertices[raw.faces].reshape(-1, 3), axis=0)
    tol = 0.1 if fmt == "stl" else 1e-9  # float32 at UTM northings keeps about 0.25 m
    np.testing.assert_allclose(tri_out, tri_in, atol=tol)


def test_y_up_mesh_is_turned_to_z_up(tmp_path):
    V = np.array([[0, 5, 0], [1, 5, 0], [0, 6, -1]], dtype=float)  # y-up: height 5..6, north is -z
    path = write_obj(tmp_path / "y.obj", V, [[0, 1, 2]])
    raw = read_terrain(str(path), up="y")
    np.testing.assert_allclose(raw.vertices, [[0, 0, 5], [1, 0, 5], [0, 1, 6]])


def test_stdin_needs_format_and_reads(monkeypatch, tmp_path):
    with pytest.raises(InputError, match="needs --format"):
        read_terrain("-")
    (tmp_path / "x").write_text("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 4\n")
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO((tmp_path / "x").read_bytes())))
    raw = read_terrain("-", fmt="asc")
    assert raw.source == "<stdin>" and len(raw.vertices) == 4


def test_missing_directory_unknown_suffix(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_terrain(str(tmp_path / "nope.obj"))
    with pytest.raises(InputError, match="is a directory"):
        os.mkdir(tmp_path / "d.obj")
        read_terrain(str(tmp_path / "d.obj"))
    (tmp_path / "t.xyz").write_text("1 2 3")
    with pytest.raises(InputError, match="unknown terrain format"):
        read_terrain(str(tmp_path / "t.xyz"))


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files whatever their permissions")
def test_no_permission(tmp_path):
    path = tmp_path / "g.obj"
    path.write_text("v 0 0 0\n")
    path.chmod(0)
    with pytest.raises(InputError, match="permission denied"):
        read_terrain(str(path))


def collada_missing():
    import importlib.util

    return importlib.util.find_spec("collada") is None


@pytest.mark.skipif(not collada_missing(), reason="pycollada is installed: Collada is read")
def test_collada_without_pycollada_is_one_clear_line(tmp_path, monkeypatch):
    path = tmp_path / "house.dae"
    path.write_text("<?xml version='1.0'?><COLLADA><asset><up_axis>Z_UP</up_axis></asset></COLLADA>\n")
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    assert str(err.value) == f"{path}: Collada is not supported here: convert it to GLB or OBJ (e.g. in Blender)"
    assert "dae" not in known_formats()
    with pytest.raises(InputError, match="Collada is not supported"):
        read_terrain("-", fmt="dae")


def test_collada_up_axis_convention():
    from tankcd_cli.io.terrain_readers import default_up

    assert default_up("dae", b"<COLLADA><asset><up_axis>Z_UP</up_axis></asset></COLLADA>") == "z"
    assert default_up("dae", b"<COLLADA><asset><up_axis> Y_UP </up_axis></asset></COLLADA>") == "y"
    assert default_up("dae", b"<COLLADA><asset></asset></COLLADA>") == "y"  # the specification's default
    assert default_up("glb") == default_up("gltf") == "y"
    assert default_up("obj") == default_up("vtk") == default_up("asc") == "z"


@pytest.mark.parametrize("fname", ["height.png", "photo.JPG", "tex.jpeg", "old.bmp"])
def test_an_image_given_as_a_mesh_is_one_clear_line(tmp_path, fname):
    path = tmp_path / fname
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 64)
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    message = str(err.value)
    assert message.startswith(f"{path}: an image, not a mesh") and "classify" in message and "\n" not in message
    assert fname.rsplit(".", 1)[1].lower() not in known_formats()
