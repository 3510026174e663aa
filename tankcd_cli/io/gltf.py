"""glTF, GLB (and Collada, through the same trimesh scene): the scene's meshes with their node
transforms applied, one part per named node (a node without a name takes its mesh's).

A .gltf's external buffers must be found beside it (and cannot be from standard input): a
missing one is named before trimesh is asked. Line and point primitives are left out and
counted; a mirroring node turns its faces' winding back (glTF 2.0, 3.7.4). The y-up turn of
these formats is the dispatcher's (``terrain_readers.default_up``).
"""

from __future__ import annotations

import io
import json
import os
import struct
from urllib.parse import unquote

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.file_mesh import FileMesh, compact_parts, short_message

GLTF_SUFFIXES = ("gltf", "glb")


def _gltf_header(data: bytes, fmt: str) -> dict | None:
    """The JSON of a .gltf, or the JSON chunk of a .glb; None when it cannot be read (the
    loader then says what is wrong)."""
    try:
        if fmt == "glb":
            if data[:4] != b"glTF" or len(data) < 20:
                return None
            length, kind = struct.unpack_from("<I4s", data, 12)
            if kind != b"JSON":
                return None
            return json.loads(data[20:20 + length].decode("utf-8"))
        header = json.loads(data.decode("utf-8-sig"))
        return header if isinstance(header, dict) else None
    except (ValueError, UnicodeDecodeError, struct.error):
        return None


def _check_gltf_buffers(header: dict, path: str, name: str) -> None:
    """External buffers must be found: beside the file, and never from standard input."""
    buffers = header.get("buffers") or []
    for i, buf in enumerate(buffers if isinstance(buffers, list) else []):
        uri = buf.get("uri") if isinstance(buf, dict) else None
        if not isinstance(uri, str) or uri.startswith("data:"):
            continue
        if path == "-":
            raise InputError(name, f"the buffer file {uri!r} cannot be found from standard input: "
                                   "give the .gltf's path, or convert it to GLB", where=f"buffer {i}")
        target = os.path.join(os.path.dirname(path), unquote(uri))
        if not os.path.isfile(target):
            raise InputError(name, f"the buffer file {uri!r} is missing (looked for {target})", where=f"buffer {i}")


def read_scene(path: str, data: bytes, fmt: str, name: str) -> FileMesh:
    """glTF, GLB (and Collada): the scene's meshes with their node transforms applied, one
    part per named node; line and point primitives counted as skipped."""
    import trimesh

    header = None
    if fmt in GLTF_SUFFIXES:
        header = _gltf_header(data, fmt)
        if header is not None:
            _check_gltf_buffers(header, path, name)
    resolver = None if path == "-" else trimesh.resolvers.FilePathResolver(os.path.abspath(path))
    try:
        scene = trimesh.load_scene(io.BytesIO(data), file_type=fmt, resolver=resolver, process=False)
    except Exception as exc:  # trimesh raises many types on malformed input
        raise InputError(name, f"cannot read as {fmt.upper()}: {short_message(exc)}") from None
    if isinstance(scene, trimesh.Trimesh):
        return FileMesh(np.asarray(scene.vertices, dtype=np.float64), np.asarray(scene.faces, dtype=np.int64))
    part_of = _gltf_parts(header) if fmt in GLTF_SUFFIXES else _frame_parts
    parents = scene.graph.transforms.parents
    geometry_order = {g: i for i, g in enumerate(scene.geometry)}
    items = []
    for node in scene.graph.nodes_geometry:
        transform, geom_name = scene.graph[node]
        part, order = part_of(node, parents)
        items.append((order, geometry_order.get(geom_name, 0), str(node), part, transform, geom_name))
    items.sort(key=lambda item: item[:3])
    verts, faces, labels, skipped = [], [], [], {}
    part_index: dict[str, int] = {}
    offset = 0
    for _, _, _, part, transform, geom_name in items:
        geom = scene.geometry[geom_name]
        if not isinstance(geom, trimesh.Trimesh):
            kind = {"Path3D": "line primitives", "Path2D": "line primitives",
                    "PointCloud": "point primitives"}.get(type(geom).__name__, f"{type(geom).__name__} primitives")
            skipped[kind] = skipped.get(kind, 0) + 1
            continue
        v = np.asarray(geom.vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(geom.faces, dtype=np.int64).reshape(-1, 3)
        if len(f) == 0:
            continue
        T = np.asarray(transform, dtype=np.float64)
        v = v @ T[:3, :3].T + T[:3, 3]
        if np.linalg.det(T[:3, :3]) < 0:  # a mirroring node turns the winding (glTF 2.0, 3.7.4)
            f = f[:, ::-1]
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
        labels.append(np.full(len(f), part_index.setdefault(part, len(part_index)) if part is not None else -1))
    if not verts:
        return FileMesh(np.empty((0, 3)), np.empty((0, 3), dtype=np.int64), skipped)
    vertices, faces_all, labels_all = np.concatenate(verts), np.concatenate(faces), np.concatenate(labels)
    face_part, part_names = None, ()
    if part_index:
        face_part, part_names = compact_parts(labels_all, list(part_index))
    return FileMesh(vertices, faces_all, skipped, face_part, part_names)


def _gltf_parts(header: dict | None):
    """part_of(frame, parents) -> (part name or None, sort key) for a trimesh scene read from a
    glTF: the glTF node carrying the mesh (trimesh puts a mesh's extra primitives on child
    frames of its node) named as in the file, in the file's node order; a node without a name
    takes its mesh's (exporters that name meshes, not nodes), else it is "node <i>". None when
    neither a node nor a mesh a node carries has a name."""
    from trimesh.util import unique_name

    nodes = header.get("nodes") if header else None
    nodes = nodes if isinstance(nodes, list) else []
    meshes = header.get("meshes") if header else None
    meshes = meshes if isinstance(meshes, list) else []
    frames: dict[str, int] = {}
    counts: dict = {}
    for i, n in enumerate(nodes):  # trimesh's own naming of the node frames
        n = n if isinstance(n, dict) else {}
        frames[unique_name(n.get("name", str(i)), frames, counts=counts)] = i

    def own_name(n) -> str:
        """The node's name, else its mesh's, else ''."""
        n = n if isinstance(n, dict) else {}
        if isinstance(n.get("name"), str) and n["name"]:
            return n["name"]
        mesh = n.get("mesh")
        if isinstance(mesh, int) and not isinstance(mesh, bool) and 0 <= mesh < len(meshes) \
                and isinstance(meshes[mesh], dict) and isinstance(meshes[mesh].get("name"), str):
            return meshes[mesh]["name"]
        return ""

    names = [own_name(n) for n in nodes]
    named = any(names)

    def part_of(frame, parents):
        node, seen = frame, 0
        while node not in frames and node in parents and seen < 64:
            node, seen = parents[node], seen + 1
        if node not in frames:
            return (None, len(nodes))
        i = frames[node]
        if not named:
            return (None, i)
        return (names[i] or f"node {i}", i)

    return part_of


def _frame_parts(frame, parents):
    """Collada (and any other scene): the frame's own name."""
    return (str(frame), 0)
