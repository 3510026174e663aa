"""PLY, STL and OFF: one mesh each, through trimesh."""

from __future__ import annotations

import io

import numpy as np

from tankcd_cli.errors import InputError
from tankcd_cli.io.file_mesh import FileMesh, short_message

SUFFIXES = ("ply", "stl", "off")


def read_trimesh(data: bytes, fmt: str, name: str) -> FileMesh:
    """One mesh of a PLY, STL or OFF file, through trimesh (no processing: vertices as written)."""
    import trimesh

    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=fmt, process=False, force="mesh")
    except Exception as exc:  # trimesh raises many types on malformed input
        raise InputError(name, f"cannot read as {fmt.upper()}: {short_message(exc)}") from None
    vertices = np.asarray(getattr(loaded, "vertices", np.empty((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(loaded, "faces", np.empty((0, 3))), dtype=np.int64)
    return FileMesh(vertices.reshape(-1, 3), faces.reshape(-1, 3))
