"""Real assets: what the program that wrote a file opens, the readers open.

OBJ files with stray two-index faces and line/point elements (pybullet's meshes),
glTF with external buffers and y-up axes (Blender exports), objects and nodes as
parts, meshio cells a surface cannot use; what is truly broken stays an InputError.
Every file is written here, in the test; trimesh's own loading is the independent truth.
"""

import base64
import io
import json
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.errors import InputError
from tankcd_cli.io.terrain_readers import known_formats, read_simple_obj, read_terrain


def triangles(vertices, faces):
    """The triangles as a sorted multiset of vertex rows, for order-free comparison."""
    return np.sort(np.asarray(vertices)[np.asarray(faces)].reshape(-1, 3), axis=0)


def trimesh_reference(path):
    import trimesh

    return trimesh.load(str(path), force="mesh", process=False)


GRID_V = "".join(f"v {x} {y} {0.1 * x * y}\n" for y in range(3) for x in range(3))  # 9 vertices, 1..9


# --- OBJ: skip and count what a surface cannot use ----------------------------

def test_obj_short_faces_lines_and_points_are_skipped_and_counted(tmp_path):
    body = (GRID_V
            + "f 1 2 5\nf 1 5 4\n"
            + "f 2 3\n"           # two indices: pybullet's samurai monastery has 201 of these
            + "f 2 3 6 5\n"       # a quad: two triangles
            + "l 1 2 3\n"
            + "f 5\n"             # one index
            + "l 4 5\n"
            + "p 9\n"
            + "f 4/1 5/2\n"       # two indices with texture coordinates
            + "f 4 5 8 7\n"
            + "l 7 8 9\n")
    path = tmp_path / "monastery.obj"
    path.write_text(body)
    raw = read_terrain(str(path), up="z")
    assert raw.skipped == {"faces with fewer than 3 vertices": 3, "line elements": 3, "point elements": 1}
    # exactly the file's valid faces: two triangles and two quads
    expected = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [3, 4, 7], [3, 7, 6]])
    np.testing.assert_array_equal(raw.faces, expected)
    assert raw.face_part is None and raw.part_names == ()
    ref = trimesh_reference(path)
    assert len(raw.faces) == len(ref.faces) == 6
    np.testing.assert_allclose(triangles(raw.vertices, raw.faces), triangles(ref.vertices, ref.faces))


def test_obj_fast_path_counts_lines_and_points(tmp_path):
    body = GRID_V + "f 1 2 5\nf 1 5 4\nl 1 2\nl 2 3\np 7\n"
    assert read_simple_obj(body.encode()) is not None  # still the fast reader
    path = tmp_path / "fast.obj"
    path.write_text(body)
    raw = read_terrain(str(path))
    assert raw.skipped == {"line elements": 2, "point elements": 1}
    np.testing.assert_array_equal(raw.faces, [[0, 1, 4], [0, 4, 3]])


def test_obj_with_nothing_to_skip_has_an_empty_skipped(tmp_path):
    path = tmp_path / "plain.obj"
    path.write_text(GRID_V + "f 1 2 5\nf 1 5 4\n")
    raw = read_terrain(str(path))
    assert raw.skipped == {} and raw.up == "z" and raw.face_part is None


def test_obj_short_faces_only_still_read_by_both_readers_like_trimesh(tmp_path):
    # the fast reader declines (two-index faces); the full reader gives what trimesh gives
    body = GRID_V + "".join(f"f {a} {b}\n" for a, b in [(1, 2), (2, 3), (4, 5)]) + "f 1 2 5\nf 5 6 9 8\n"
    assert read_simple_obj(body.encode()) is None
    path = tmp_path / "m.obj"
    path.write_text(body)
    raw = read_terrain(str(path))
    ref = trimesh_reference(path)
    assert raw.skipped == {"faces with fewer than 3 vertices": 3}
    assert len(raw.faces) == len(ref.faces) == 3
    np.testing.assert_allclose(triangles(raw.vertices, raw.faces), triangles(ref.vertices, ref.faces))


def test_obj_relative_indices_polygons_and_odd_spacing_go_to_the_full_reader(tmp_path):
    # (trimesh itself fails on this file: relative indices in a polygon)
    body = ("v\t0 0 0\nv 1 0 0\nv 1 1 0\nv 0.5 1.5 0\nv 0 1 0\n"
            "f -5 -4 -3 -2 -1\n"           # a pentagon: a fan of three
            "  f 1 2 3\n"                  # leading blanks
            "f 1/1/1 2/2/2 3/3/3\n")
    path = tmp_path / "m.obj"
    path.write_text(body)
    assert read_simple_obj(body.encode()) is None
    raw = read_terrain(str(path))
    np.testing.assert_array_equal(raw.faces, [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 1, 2], [0, 1, 2]])


@pytest.mark.parametrize("line,fragment", [
    ("f 1 x 3", "whole numbers"),
    ("f 0 1 2", "whole numbers"),
    ("f 1 2 99", "out of range"),
    ("f -50 1 2", "whole numbers"),
    ("f 1 2", None),  # not broken: skipped (checked below)
    ("f 1 2 99\nf 1 2", "out of range"),
    ("v 1 2", "three finite numbers"),
    ("v 1 2 inf", "non-finite coordinate"),  # the fast reader; the full one below
    ("v 1 2 inf\nl 1 2\nf 3 4", "three finite numbers"),
    ("v 1 two 3", "three finite numbers"),
])
def test_obj_truly_broken_lines_are_still_refused_where_they_are(tmp_path, line, fragment):
    path = tmp_path / "bad.obj"
    path.write_text(GRID_V + "f 1 2 5\n" + line + "\nf 1 5 4\n")
    if fragment is None:
        assert read_terrain(str(path)).skipped == {"faces with fewer than 3 vertices": 1}
        return
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    message = str(err.value)
    # the full reader names the line; the fast one the face or vertex (its message since before)
    assert fragment in message and str(path) in message
    assert any(where in message for where in ("line 11:", "face 2:", "vertex 10:"))
    assert "\n" not in message


def test_obj_of_only_lines_says_what_it_left_out(tmp_path):
    path = tmp_path / "wires.obj"
    path.write_text(GRID_V + "l 1 2 3\nl 4 5\nf 7 8\n")
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    message = str(err.value)
    assert "no triangle faces" in message and "2 line elements" in message
    assert "1 faces with fewer than 3 vertices" in message


# --- OBJ parts ------------------------------------------------------------------

def test_obj_objects_are_parts_per_face_in_file_order(tmp_path):
    body = (GRID_V
            + "o hull\ng ignored_when_objects_exist\nf 1 2 5\nf 1 5 4\n"
            + "o turret\nusemtl steel\nf 2 3 6 5\n"
            + "o hull\nf 4 5 8\n"            # the same object again: the same part
            + "o gun barrel\nl 7 8\nf 5 9 8\n")
    path = tmp_path / "tank.obj"
    path.write_text(body)
    raw = read_terrain(str(path))
    assert raw.part_names == ("hull", "turret", "gun barrel")
    assert raw.face_part.dtype == np.int32 and raw.face_part.shape == (len(raw.faces),)
    np.testing.assert_array_equal(raw.face_part, [0, 0, 1, 1, 0, 2])
    np.testing.assert_array_equal(raw.faces, [[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [3, 4, 7], [4, 8, 7]])
    assert raw.skipped == {"line elements": 1}
    ref = trimesh_reference(path)
    np.testing.assert_allclose(triangles(raw.vertices, raw.faces), triangles(ref.vertices, ref.faces))


def test_obj_groups_are_parts_when_there_are_no_objects(tmp_path):
    body = GRID_V + "f 1 2 5\ng left wheel\nf 1 5 4\nf 2 3 6\ng right\nf 4 5 8\ng\nf 5 9 8\n"
    path = tmp_path / "g.obj"
    path.write_text(body)
    raw = read_terrain(str(path))
    # the face before any group and the one after a bare "g" are the OBJ default group
    assert raw.part_names == ("default", "left wheel", "right")
    np.testing.assert_array_equal(raw.face_part, [0, 1, 1, 2, 0])


def test_obj_with_one_object_still_names_it(tmp_path):
    path = tmp_path / "one.obj"
    path.write_text("o Cube\n" + GRID_V + "f 1 2 5\nf 1 5 4\n")
    raw = read_terrain(str(path))
    assert raw.part_names == ("Cube",)
    np.testing.assert_array_equal(raw.face_part, [0, 0])


STATEMENT = st.one_of(
    st.tuples(st.just("f"), st.integers(1, 9), st.integers(1, 9), st.integers(1, 9)).map(lambda t: f"f {t[1]} {t[2]} {t[3]}"),
    st.sampled_from(["o hull", "o turret", "o", "g wheels", "g hull", "l 1 2", "p 3", "# comment", "usemtl a", ""]),
)


@settings(max_examples=60, deadline=None)
@given(st.lists(STATEMENT, max_size=30))
def test_the_fast_and_full_obj_readers_agree_on_faces_parts_and_skips(statements):
    from tankcd_cli.io.terrain_readers import _simple_obj, parse_obj

    data = (GRID_V + "\n".join(statements) + "\n").encode()
    fast = _simple_obj(data)
    if fast is None:  # no faces at all, or a bare "o": the full reader's business
        assert not any(t.startswith("f") for t in statements) or "o" in statements
        return
    full = parse_obj(data, "m.obj")
    np.testing.assert_array_equal(fast.faces, full.faces)
    assert fast.skipped == full.skipped and fast.part_names == full.part_names
    if full.face_part is None:
        assert fast.face_part is None
    else:
        np.testing.assert_array_equal(fast.face_part, full.face_part)


# --- glTF: external buffers, y up, nodes as parts --------------------------------

def two_part_scene():
    import trimesh

    hull = trimesh.creation.box(extents=[6, 3, 1.6])
    turret = trimesh.creation.box(extents=[3, 2, 0.8])
    scene = trimesh.Scene()
    scene.add_geometry(hull, node_name="hull", geom_name="hull_mesh")
    scene.add_geometry(turret, node_name="turret", geom_name="turret_mesh",
                       transform=trimesh.transformations.translation_matrix([0.5, 1.2, 0.0]))
    return scene, hull, turret


def write_gltf_files(directory, scene):
    import trimesh

    files = trimesh.exchange.gltf.export_gltf(scene)
    for fname, blob in files.items():
        (directory / fname).write_bytes(blob)
    header = json.loads(files["model.gltf"])
    return directory / "model.gltf", [b["uri"] for b in header["buffers"]]


def test_gltf_with_external_buffers_reads_like_the_glb_of_the_same_scene(tmp_path):
    import trimesh

    scene, hull, turret = two_part_scene()
    gltf, uris = write_gltf_files(tmp_path, scene)
    assert uris and all(u.endswith(".bin") for u in uris)  # really external
    glb = tmp_path / "model.glb"
    glb.write_bytes(trimesh.exchange.gltf.export_glb(scene))
    a = read_terrain(str(gltf), up="z")
    b = read_terrain(str(glb), up="z")
    np.testing.assert_allclose(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    assert a.part_names == b.part_names == ("hull", "turret")
    np.testing.assert_array_equal(a.face_part, [0] * len(hull.faces) + [1] * len(turret.faces))
    # the node transform is applied: the turret's triangles sit where the scene put them
    turret_tris = triangles(a.vertices, a.faces[a.face_part == 1])
    np.testing.assert_allclose(turret_tris, triangles(turret.vertices + [0.5, 1.2, 0.0], turret.faces), atol=1e-6)
    ref = trimesh_reference(gltf)
    assert len(a.faces) == len(ref.faces)
    np.testing.assert_allclose(triangles(a.vertices, a.faces), triangles(ref.vertices, ref.faces), atol=1e-6)


def test_gltf_missing_buffer_file_is_named(tmp_path):
    scene, _, _ = two_part_scene()
    gltf, uris = write_gltf_files(tmp_path, scene)
    os.unlink(tmp_path / uris[1])
    with pytest.raises(InputError) as err:
        read_terrain(str(gltf))
    message = str(err.value)
    assert uris[1] in message and "missing" in message and str(gltf) in message and "\n" not in message


def test_gltf_from_stdin_with_external_buffers_says_so_and_glb_from_stdin_reads(tmp_path, monkeypatch):
    import trimesh

    scene, _, _ = two_part_scene()
    gltf, uris = write_gltf_files(tmp_path, scene)
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(gltf.read_bytes())))
    with pytest.raises(InputError) as err:
        read_terrain("-", fmt="gltf")
    message = str(err.value)
    assert "standard input" in message and uris[0] in message and "\n" not in message
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(trimesh.exchange.gltf.export_glb(scene))))
    raw = read_terrain("-", fmt="glb", up="z")
    assert raw.source == "<stdin>" and raw.part_names == ("hull", "turret") and raw.up == "z"


def gltf_by_hand(meshes, nodes):
    """A .gltf (bytes) with one embedded (data: URI) buffer. meshes: [[(vertices, faces or
    None, mode)]] (mode 4 triangles, 1 lines, 0 points); nodes: glTF node dicts."""
    blob, views, accessors, out_meshes = b"", [], [], []
    for prims in meshes:
        out = []
        for V, F, mode in prims:
            V = np.asarray(V, dtype=np.float32)
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": V.nbytes})
            blob += V.tobytes()
            accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(V), "type": "VEC3",
                              "min": V.min(axis=0).tolist(), "max": V.max(axis=0).tolist()})
            prim = {"attributes": {"POSITION": len(accessors) - 1}, "mode": mode}
            if F is not None:
                index = np.asarray(F, dtype=np.uint32).ravel()
                views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": index.nbytes})
                blob += index.tobytes()
                accessors.append({"bufferView": len(views) - 1, "componentType": 5125, "count": len(index),
                                  "type": "SCALAR"})
                prim["indices"] = len(accessors) - 1
            out.append(prim)
        out_meshes.append({"primitives": out})
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}],
           "nodes": nodes, "meshes": out_meshes, "bufferViews": views, "accessors": accessors,
           "buffers": [{"byteLength": len(blob),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]}
    return json.dumps(doc).encode()


# a ground plane y = 0 in glTF's y-up coordinates: x right, -z forward
PLANE_V = [[0, 0, 0], [4, 0, 0], [4, 0, -2], [0, 0, -2]]
PLANE_F = [[0, 1, 2], [0, 2, 3]]  # counter-clockwise seen from +y (above)


def test_gltf_is_y_up_by_default_and_explicit_up_keeps_coordinates(tmp_path):
    path = tmp_path / "ground.gltf"
    path.write_bytes(gltf_by_hand([[(PLANE_V + [[1, 3, -1]], PLANE_F + [[0, 1, 4]], 4)]], [{"mesh": 0}]))
    raw = read_terrain(str(path))  # up=None: the format's convention
    assert raw.up == "y"
    np.testing.assert_allclose(raw.vertices[:4, 2], 0.0)  # horizontal: z = 0
    np.testing.assert_allclose(raw.vertices[4], [1, 1, 3])  # (x, y, z) -> (x, -z, y)
    np.testing.assert_allclose(raw.vertices[2], [4, 2, 0])
    normal = np.cross(*(raw.vertices[raw.faces[0, 1:]] - raw.vertices[raw.faces[0, 0]]))
    assert normal[2] > 0  # still facing up after the turn
    assert raw.face_part is None and raw.part_names == ()  # no node has a name
    kept = read_terrain(str(path), up="z")
    assert kept.up == "z"
    np.testing.assert_allclose(kept.vertices, PLANE_V + [[1, 3, -1]])
    explicit_y = read_terrain(str(path), up="y")
    np.testing.assert_allclose(explicit_y.vertices, raw.vertices)


def test_up_none_is_z_for_the_other_formats(tmp_path):
    import meshio

    obj = tmp_path / "m.obj"
    obj.write_text(GRID_V + "f 1 2 5\n")
    assert read_terrain(str(obj)).up == "z"
    np.testing.assert_allclose(read_terrain(str(obj)).vertices[8], [2, 2, 0.4])
    vtk = tmp_path / "m.vtk"
    meshio.write(str(vtk), meshio.Mesh(np.array(PLANE_V, dtype=float), [("triangle", np.array(PLANE_F))]))
    np.testing.assert_allclose(read_terrain(str(vtk)).vertices, PLANE_V)
    asc = tmp_path / "g.asc"
    asc.write_text("ncols 2\nnrows 2\nxllcenter 0\nyllcenter 0\ncellsize 1\n1 2\n3 4\n")
    assert read_terrain(str(asc)).up == "z"
    with pytest.raises(InputError, match="makes no sense for a DEM"):
        read_terrain(str(asc), up="y")


def test_gltf_line_and_point_primitives_are_counted_and_nodes_are_parts(tmp_path):
    tri = (PLANE_V, PLANE_F, 4)
    tri2 = ([[0, 1, 0], [1, 1, 0], [0, 1, -1]], [[0, 1, 2]], 4)
    line = ([[0, 0, 0], [1, 1, 1]], None, 1)
    point = ([[0, 0, 0], [2, 2, 2]], None, 0)
    nodes = [{"mesh": 0, "name": "deck"},                                   # two triangle primitives
             {"mesh": 1},                                                   # unnamed
             {"mesh": 2, "name": "antenna"},                                # lines only
             {"mesh": 3, "name": "lights"},                                 # points only
             {"mesh": 1, "name": "deck", "translation": [0, 5, 0]},         # the name again: the same part
             {"mesh": 1, "name": "mirror", "scale": [-1, 1, 1]}]            # mirrored: winding turned
    path = tmp_path / "ship.gltf"
    path.write_bytes(gltf_by_hand([[tri, tri2], [tri2], [line], [point]], nodes))
    raw = read_terrain(str(path), up="z")
    assert raw.skipped == {"line primitives": 1, "point primitives": 1}
    assert raw.part_names == ("deck", "node 1", "mirror")
    np.testing.assert_array_equal(raw.face_part, [0, 0, 0, 1, 0, 2])
    # node order, primitives in order within a node: the plane, then tri2, ...
    np.testing.assert_allclose(raw.vertices[raw.faces[0]], np.array(PLANE_V)[PLANE_F[0]])
    np.testing.assert_allclose(raw.vertices[raw.faces[4]], np.array(tri2[0]) + [0, 5, 0])
    mirrored = raw.vertices[raw.faces[5]]
    original = np.array(tri2[0], dtype=float) * [-1, 1, 1]
    np.testing.assert_allclose(mirrored, original[[2, 1, 0]])
    ref = trimesh_reference(path)
    assert len(ref.faces) == len(raw.faces)


def test_mm_scale_asset_just_reads(tmp_path):
    # a vehicle modelled in millimetres: coordinates in the thousands read as they are
    # (scaling is the scene's business, not the reader's)
    import trimesh

    box = trimesh.creation.box(extents=[6900.0, 3460.0, 2230.0])
    path = tmp_path / "t72_mm.glb"
    path.write_bytes(trimesh.exchange.gltf.export_glb(trimesh.Scene(box)))
    raw = read_terrain(str(path), up="z")
    np.testing.assert_allclose(raw.vertices.max(axis=0), [3450.0, 1730.0, 1115.0])
    obj = tmp_path / "t72_mm.obj"
    obj.write_text("".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in box.vertices)
                   + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in box.faces))
    np.testing.assert_allclose(read_terrain(str(obj)).vertices, box.vertices)


# --- Collada and images: one clear line ------------------------------------------

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


# --- meshio cells a surface cannot use ---------------------------------------------

def test_vtk_line_cells_beside_triangles_are_counted(tmp_path):
    import meshio

    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=float)
    cells = [("triangle", np.array([[0, 1, 2], [0, 2, 3]])),
             ("line", np.array([[0, 4], [1, 4], [2, 4]])),
             ("vertex", np.array([[4]]))]
    path = tmp_path / "mixed.vtk"
    meshio.write(str(path), meshio.Mesh(points, cells))
    raw = read_terrain(str(path))
    assert raw.skipped == {"line cells": 3, "vertex cells (points)": 1}
    np.testing.assert_array_equal(raw.faces, [[0, 1, 2], [0, 2, 3]])
    assert raw.face_part is None


def test_vtu_volume_cells_are_counted_and_a_volume_alone_is_refused(tmp_path):
    import meshio

    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    path = tmp_path / "solid.vtu"
    meshio.write(str(path), meshio.Mesh(points, [("triangle", np.array([[0, 1, 2]])), ("tetra", np.array([[0, 1, 2, 3]]))]))
    raw = read_terrain(str(path))
    assert raw.skipped == {"tetra cells (volume, not a surface)": 1} and len(raw.faces) == 1
    only = tmp_path / "only.vtu"
    meshio.write(str(only), meshio.Mesh(points, [("tetra", np.array([[0, 1, 2, 3]]))]))
    with pytest.raises(InputError, match="no triangle faces.*1 tetra cells"):
        read_terrain(str(only))
