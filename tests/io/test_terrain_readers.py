"""Terrain readers: every format, up-axis conversion, and bad input named precisely."""

import io
import os

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.terrain_readers import grid_faces, read_terrain
from tests.conftest import write_asc, write_obj


def square_mesh():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0.25]], dtype=float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    return V, F


def test_asc_posts_rows_and_corner_convention(tmp_path):
    z = [[7, 8, 9], [4, 5, 6], [1, 2, 3]]  # north row first
    path = write_asc(tmp_path / "g.asc", z, cellsize=2.0, xll=100.0, yll=200.0, corner=True)
    raw = read_terrain(str(path))
    grid = raw.grid
    np.testing.assert_allclose(grid.origin, [101.0, 201.0])  # corner + half a cell
    # row 0 of the grid is the south row: heights 1 2 3
    south = raw.vertices[grid.vertex[0]]
    np.testing.assert_allclose(south, [[101, 201, 1], [103, 201, 2], [105, 201, 3]])
    assert len(raw.faces) == 8
    # triangles are counter-clockwise seen from above
    p = raw.vertices[raw.faces]
    cross_z = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
    assert (cross_z > 0).all()


def test_asc_nodata_posts_are_left_out(tmp_path):
    z = np.arange(16, dtype=float).reshape(4, 4)
    z[0, 0] = -9999
    z[2, 2] = -9999
    raw = read_terrain(str(write_asc(tmp_path / "g.asc", z, nodata=-9999)))
    assert len(raw.vertices) == 14
    assert (raw.grid.vertex == -1).sum() == 2
    assert not np.isin(-9999.0, raw.vertices[:, 2])
    # every quad with three valid posts keeps one triangle: 9 quads, 4 touch a hole (one twice)
    assert len(raw.faces) == len(grid_faces(raw.grid.vertex))


def test_asc_utm_coordinates_keep_their_digits(tmp_path):
    z = np.ones((3, 3))
    raw = read_terrain(str(write_asc(tmp_path / "g.asc", z, cellsize=0.5, xll=500000.25, yll=4500000.75)))
    assert raw.vertices[:, 0].min() == 500000.25
    assert raw.vertices[:, 1].max() == 4500000.75 + 1.0


@pytest.mark.parametrize("text,fragment", [
    ("", "empty"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2 3\n", "expected 2 x 2 = 4 values"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 x\n", "line 7 value 2"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 nan\n3 4\n", "non-finite height"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize -1\n1 2\n3 4\n", "cellsize must be positive"),
    ("ncols two\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 4\n", "ncols must be a whole number"),
    ("nrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 4\n", "lacks ncols"),
    ("ncols 2\nnrows 1\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n", "no cells to triangulate"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\nNODATA_value 0\n0 0\n0 0\n", "every post is NODATA"),
    ("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\nNODATA_value 0\n0 1\n1 0\n", "no cell has three valid posts"),
])
def test_asc_malformed(tmp_path, text, fragment):
    path = tmp_path / "bad.asc"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    assert fragment in str(err.value)
    assert str(path) in str(err.value)
    assert "\n" not in str(err.value)


def test_asc_bom_and_crlf(tmp_path):
    path = tmp_path / "g.asc"
    path.write_bytes("\ufeffncols 2\r\nnrows 2\r\nxllcenter 0\r\nyllcenter 0\r\ncellsize 1\r\n1 2\r\n3 4\r\n".encode("utf-8"))
    raw = read_terrain(str(path))
    assert len(raw.vertices) == 4


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


@pytest.mark.parametrize("content,fragment", [
    (b"", "empty"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no triangle faces"),
    (b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "non-finite coordinate"),
    (b"\x00\x01\x02garbage\xff\xfe" * 50, "OBJ"),
])
def test_obj_malformed(tmp_path, content, fragment):
    path = tmp_path / "bad.obj"
    path.write_bytes(content)
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    assert fragment in str(err.value) or "no vertices" in str(err.value) or "no triangle" in str(err.value)


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


@pytest.mark.parametrize("body", [
    "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nf 1 2 3\nf 2 4 3\n",
    "# comment\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nvt 0 0\nvn 0 0 1\ns off\nf 1/1/1 2/1/1 3/1/1\nf 2//1 4//1 3//1\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nf 1 2 4 3\n",  # a quad: the full reader
    "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nf -4 -3 -2\nf -3 -1 -2\n",  # relative indices: the full reader
])
def test_simple_obj_reader_agrees_with_trimesh(tmp_path, body):
    import trimesh

    from tankcd_cli.io.terrain_readers import read_simple_obj

    path = tmp_path / "m.obj"
    path.write_text(body)
    raw = read_terrain(str(path))
    ref = trimesh.load(str(path), force="mesh", process=False)
    ours = np.sort(raw.vertices[raw.faces].reshape(-1, 3), axis=0)
    theirs = np.sort(np.asarray(ref.vertices)[np.asarray(ref.faces)].reshape(-1, 3), axis=0)
    np.testing.assert_allclose(ours, theirs)
    simple = read_simple_obj(body.encode())
    assert (simple is None) == ("f 1 2 4 3" in body or "f -4" in body)
