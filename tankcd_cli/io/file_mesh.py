"""What every mesh reader returns (``FileMesh``), and the helpers they share: parts numbered in
order of their first triangle, and a loader's error cut to one line."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DEFAULT_PART = "default"  # the OBJ specification's name for faces outside any group


@dataclass
class FileMesh:
    """What a mesh reader returns: geometry in the file's own axes, what it left out, parts
    (see ``terrain_readers.RawTerrain`` for each field)."""

    vertices: np.ndarray
    faces: np.ndarray
    skipped: dict = field(default_factory=dict)
    face_part: np.ndarray | None = None
    part_names: tuple = ()


def compact_parts(labels: np.ndarray, names: list[str]) -> tuple[np.ndarray, tuple]:
    """Per-triangle labels (-1: outside any named part) renumbered to the parts that own
    triangles, in order of their first triangle; -1 becomes the part "default"."""
    names = names + [DEFAULT_PART]
    labels = np.where(labels < 0, len(names) - 1, labels)
    # one part per name: the unlabelled triangles join an explicit "default" if there is one
    canonical = {n: names.index(n) for n in names}
    labels = np.array([canonical[n] for n in names], dtype=np.int64)[labels]
    used, first = np.unique(labels, return_index=True)
    order = used[np.argsort(first)]
    remap = np.full(len(names), -1, dtype=np.int64)
    remap[order] = np.arange(len(order))
    return remap[labels].astype(np.int32), tuple(names[i] for i in order)


def short_message(exc: Exception) -> str:
    """The first line of a loader's error, at most 200 characters (for a one-line InputError)."""
    text = str(exc).strip().splitlines()
    msg = text[0] if text else type(exc).__name__
    return msg[:200]
