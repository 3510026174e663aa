"""glTF and GLB as Blender and trimesh export them: external buffers found beside the file (and
named when missing), y up by the specification, nodes as parts, line and point primitives
counted; trimesh's own loading is the independent truth."""

import base64
import io
import json
import os

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io.terrain_readers import read_terrain


def triangles(vertices, faces):
    """The triangles as a sorted multiset of vertex rows, for order-free comparison."""
    return np.sort(np.asarray(vertices)[np.asarray(faces)].reshape(-1, 3), axis=0)


def trimesh_reference(path):
    import trimesh

    return trimesh.load(str(path), force="mesh", process=False)


GRID_V = "".join(f"v {x} {y} {0.1 * x * y}\n" for y in range(3) for x in range(3))  # 9 vertices, 1..9


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


def gltf_by_hand(meshes, nodes, mesh_names=None):
    """A .gltf (bytes) with one embedded (data: URI) buffer. meshes: [[(vertices, faces or
    None, mode)]] (mode 4 triangles, 1 lines, 0 points); nodes: glTF node dicts; mesh_names:
    each mesh's name (None: unnamed)."""
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
        if mesh_names and mesh_names[len(out_meshes) - 1] is not None:
            out_meshes[-1]["name"] = mesh_names[len(out_meshes) - 1]
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


def test_gltf_nodes_without_names_take_their_meshes_names(tmp_path):
    """Exporters that name meshes, not nodes: the parts are the meshes' names (a node's own name
    wins; a node with neither is node <i>); a repeated mesh is one part."""
    tri = (PLANE_V, PLANE_F, 4)
    tri2 = ([[0, 1, 0], [1, 1, 0], [0, 1, -1]], [[0, 1, 2]], 4)
    nodes = [{"mesh": 0}, {"mesh": 1, "translation": [0, 3, 0]}, {"mesh": 1, "name": "gun"},
             {"mesh": 2}, {"mesh": 0, "translation": [0, 0, 9]}]
    path = tmp_path / "tank.gltf"
    path.write_bytes(gltf_by_hand([[tri], [tri2], [tri2]], nodes, mesh_names=["hull", "turret", None]))
    raw = read_terrain(str(path), up="z")
    assert raw.part_names == ("hull", "turret", "gun", "node 3")
    np.testing.assert_array_equal(raw.face_part, [0, 0, 1, 2, 3, 0, 0])
    # none named anywhere: no parts, as before
    path.write_bytes(gltf_by_hand([[tri], [tri2]], [{"mesh": 0}, {"mesh": 1}]))
    raw = read_terrain(str(path), up="z")
    assert raw.face_part is None and raw.part_names == ()


def test_a_trimesh_export_without_node_names_keeps_the_geometry_names(tmp_path):
    """trimesh writes its geometry names as the glTF meshes' names; with the node names stripped
    (as some exporters leave them), those name the parts."""
    scene, hull, turret = two_part_scene()
    gltf, _ = write_gltf_files(tmp_path, scene)
    header = json.loads(gltf.read_bytes())
    for node in header["nodes"]:
        node.pop("name", None)
    gltf.write_text(json.dumps(header))
    raw = read_terrain(str(gltf), up="z")
    assert raw.part_names == ("hull_mesh", "turret_mesh")
    assert np.bincount(raw.face_part).tolist() == [len(hull.faces), len(turret.faces)]
