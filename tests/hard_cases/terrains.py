"""Hard terrains, generated (no large files): each writes a file and says what the tool must do.

``expect`` is "ok" (classified: every vertex's curvature finite, every class
flat/general/uneven, replay gives a pose row for every trajectory row) or
"rejected" (exit 3, one line naming the file and what is wrong).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from tests.conftest import write_asc, write_obj

UTM = (500_000.0, 4_500_000.0)


@dataclass(frozen=True)
class Case:
    name: str
    write: Callable[[Path], Path]
    expect: str  # "ok" or "rejected"
    why: str


def _grid(n=40, spacing=1.0, z=None):
    ys, xs = np.mgrid[0:n, 0:n] * spacing
    V = np.column_stack([xs.ravel(), ys.ravel(), (z(xs, ys) if z else 0.1 * np.sin(xs / 5) * np.cos(ys / 7)).ravel()])
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    F = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return V, F


def slivers(p):
    V, F = _grid()
    # split every tenth face with a vertex 1e-7 m off its longest edge: needle and sliver triangles
    extra, faces = [], [f for f in F]
    for k in range(0, len(F), 10):
        a, b, c = F[k]
        m = 0.5 * (V[a] + V[c]) + np.array([1e-7, 0, 0])
        extra.append(m)
        i = len(V) + len(extra) - 1
        faces[k] = [a, b, i]
        faces.append([i, b, c])
    return write_obj(p / "slivers.obj", np.vstack([V, extra]), np.array(faces))


def zero_area(p):
    V, F = _grid()
    F = np.vstack([F, [[0, 1, 2]], [[5, 5, 6]]])  # a collinear triangle and one with a repeated vertex
    return write_obj(p / "zero_area.obj", V, F)


def duplicates(p):
    V, F = _grid()
    # every vertex twice (exactly, and 1e-9 m off), faces spread over the copies
    V2 = np.vstack([V, V + 1e-9])
    F2 = F.copy()
    F2[::2] += len(V)
    return write_obj(p / "duplicates.obj", V2, F2)


def non_manifold(p):
    V, F = _grid(20)
    # a fin: a triangle standing on an interior edge (three faces share it)
    a, b = F[100][0], F[100][1]
    V = np.vstack([V, 0.5 * (V[a] + V[b]) + [0, 0.0, 2.0]])
    return write_obj(p / "non_manifold.obj", V, np.vstack([F, [[a, b, len(V) - 1]]]))


def holes(p):
    V, F = _grid()
    centre = V[F].mean(axis=1)
    keep = np.hypot(centre[:, 0] - 20, centre[:, 1] - 20) > 5  # a round hole in the middle
    keep &= np.abs(centre[:, 0] - 8) + np.abs(centre[:, 1] - 30) > 2
    return write_obj(p / "holes.obj", V, F[keep])


def flipped(p):
    V, F = _grid()
    F = F.copy()
    F[::3] = F[::3][:, ::-1]  # every third face wound the other way
    return write_obj(p / "flipped.obj", V, F)


def y_up(p):
    V, F = _grid()
    Vy = V[:, [0, 2, 1]] * [1, 1, -1]  # z-up turned to y-up as OBJ exporters write it
    path = write_obj(p / "y_up.obj", Vy, F)
    return path


def cliff(p):
    # a vertical step: the posts on both sides of x = 20 repeated at the same x, y
    V, F = _grid(z=lambda x, y: np.where(x >= 20, 3.0, 0.0) + 0.0 * y)
    lo = (np.abs(V[:, 0] - 20) < 1e-9)
    top = V[lo].copy()
    bottom = top.copy()
    bottom[:, 2] = 0.0
    V2 = np.vstack([V, bottom])
    # faces west of the cliff use the bottom copies of the cliff posts
    remap = np.arange(len(V))
    remap[np.flatnonzero(lo)] = len(V) + np.arange(lo.sum())
    west = V[F].mean(axis=1)[:, 0] < 20
    F2 = F.copy()
    F2[west] = remap[F[west]]
    return write_obj(p / "cliff.obj", V2, F2)


def float32_utm(p):
    # UTM coordinates rounded through float32 (what a careless exporter writes): 0.25-0.5 m steps
    V, F = _grid(30, 2.0)
    V = (V + [UTM[0], UTM[1], 250.0]).astype(np.float32).astype(np.float64)
    return write_obj(p / "float32_utm.obj", V, F)


def quantized(p):
    ys, xs = np.mgrid[0:60, 0:60] * 1.0
    z = 20 * np.sin(xs / 15) * np.cos(ys / 20)
    z8 = np.round((z - z.min()) / (z.max() - z.min()) * 255) * (z.max() - z.min()) / 255  # 8-bit terraces
    return write_asc(p / "quantized.asc", z8, xll=UTM[0], yll=UTM[1])


def nodata_islands(p):
    rng = np.random.default_rng(1)
    z = rng.normal(0, 0.05, (50, 50)) + 100
    z[10:14, 10:14] = -9999  # a lake of NODATA
    z[30, 30] = -9999  # a single missing post
    z[40:, :5] = -9999
    z[45, 2] = 101.0  # an island of one post inside the NODATA
    return write_asc(p / "nodata.asc", z, nodata=-9999, xll=UTM[0], yll=UTM[1])


def single_row_of_cells(p):
    return write_asc(p / "one_row.asc", np.array([[1.0, 2.0, 3.0, 2.0, 1.0] * 4, [1.5, 2.5, 3.5, 2.5, 1.5] * 4]))


def single_row_of_posts(p):
    return write_asc(p / "one_post_row.asc", np.array([[1.0, 2.0, 3.0, 4.0]]))


def all_nodata(p):
    return write_asc(p / "all_nodata.asc", np.full((5, 5), -9999.0), nodata=-9999)


def nan_vertex(p):
    V, F = _grid(10)
    text = "".join("v %r %r %r\n" % tuple(v) for v in V).replace("v 3.0 0.0", "v nan 0.0", 1)
    text += "".join("f %d %d %d\n" % tuple(f + 1) for f in F)
    (p / "nan.obj").write_text(text)
    return p / "nan.obj"


def exactly_flat(p):
    return write_asc(p / "flat.asc", np.full((30, 30), 123.0), xll=UTM[0], yll=UTM[1])


def knife_edge(p):
    ys, xs = np.mgrid[0:40, 0:40] * 1.0
    return write_asc(p / "knife.asc", np.maximum(0.0, 2.0 - np.abs(xs - 20) * 0.8))


CASES = [
    Case("slivers", slivers, "ok", "needle and sliver triangles keep finite curvature"),
    Case("zero_area", zero_area, "ok", "zero-area triangles are dropped and counted"),
    Case("duplicates", duplicates, "ok", "exact and near duplicate vertices are merged"),
    Case("non_manifold", non_manifold, "ok", "a non-manifold edge gets one-sided fits"),
    Case("holes", holes, "ok", "vertices on a hole's rim are boundary vertices"),
    Case("flipped", flipped, "ok", "face winding does not change the sign of H"),
    Case("y_up", y_up, "ok", "--up y turns the mesh"),
    Case("cliff", cliff, "ok", "two vertices with the same x, y (a vertical face) hold no height"),
    Case("float32_utm", float32_utm, "ok", "float32-rounded UTM coordinates"),
    Case("quantized", quantized, "ok", "8-bit terraces"),
    Case("nodata_islands", nodata_islands, "ok", "NODATA lakes, holes and a one-post island"),
    Case("single_row_of_cells", single_row_of_cells, "ok", "a DEM one cell high"),
    Case("single_row_of_posts", single_row_of_posts, "rejected", "no cell: nothing to place a tank on"),
    Case("all_nodata", all_nodata, "rejected", "every post NODATA"),
    Case("nan_vertex", nan_vertex, "rejected", "a NaN coordinate"),
    Case("exactly_flat", exactly_flat, "ok", "H exactly 0, class flat"),
    Case("knife_edge", knife_edge, "ok", "a ridge sharp at one post row"),
]
