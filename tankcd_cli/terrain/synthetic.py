"""Analytic height fields with known mean curvature, and meshes sampled from them.

Used by the tests, the benchmarks and the accuracy-versus-time report as an
independent truth: H comes from the closed-form derivatives, never from a mesh.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from tankcd_cli.geometry.post_grid import PostGrid, PostVertices, grid_faces
from tankcd_cli.io.terrain_readers import RawTerrain
from tankcd_cli.terrain.mesh.classify import classify_mesh
from tankcd_cli.terrain.mesh.surface import MeshSurface
from tankcd_cli.vehicle import Vehicle

Array = np.ndarray


@dataclass(frozen=True)
class HeightField:
    """z = f(x, y) with its first and second derivatives (all vectorized, metres)."""

    name: str
    f: Callable[[Array, Array], Array]
    grad: Callable[[Array, Array], tuple[Array, Array]]
    hess: Callable[[Array, Array], tuple[Array, Array, Array]]

    def mean_curvature(self, x: Array, y: Array) -> Array:
        """Signed H (1/m), the formula of docs/formats.md: hilltops positive."""
        fx, fy = self.grad(x, y)
        fxx, fxy, fyy = self.hess(x, y)
        return -((1 + fy**2) * fxx - 2 * fx * fy * fxy + (1 + fx**2) * fyy) / (2 * (1 + fx**2 + fy**2) ** 1.5)

    def normal(self, x: Array, y: Array) -> Array:
        fx, fy = self.grad(x, y)
        nrm = np.stack([-fx, -fy, np.ones_like(fx)], axis=-1)
        return nrm / np.linalg.norm(nrm, axis=-1, keepdims=True)


def _zero(x):
    return np.zeros_like(np.asarray(x, dtype=float))


def plane(a: float = 0.0, b: float = 0.0, c: float = 0.0) -> HeightField:
    return HeightField("plane" if a == b == 0 else "tilted_plane",
                       lambda x, y: a * x + b * y + c + _zero(x),
                       lambda x, y: (a + _zero(x), b + _zero(x)),
                       lambda x, y: (_zero(x), _zero(x), _zero(x)))


def sphere_cap(radius: float) -> HeightField:
    """Upper hemisphere of the given radius centred at the origin: H = +1/R."""
    def f(x, y):
        return np.sqrt(radius**2 - x**2 - y**2)

    def grad(x, y):
        z = f(x, y)
        return -x / z, -y / z

    def hess(x, y):
        z = f(x, y)
        return -(radius**2 - y**2) / z**3, -x * y / z**3, -(radius**2 - x**2) / z**3
    return HeightField("sphere_cap", f, grad, hess)


def cylinder_crest(radius: float) -> HeightField:
    """A ridge along y: z = sqrt(R^2 - x^2), H = +1/(2R)."""
    def f(x, y):
        return np.sqrt(radius**2 - x**2) + _zero(y)

    def grad(x, y):
        return -x / f(x, y), _zero(x) + _zero(y)

    def hess(x, y):
        return -radius**2 / f(x, y) ** 3, _zero(x) + _zero(y), _zero(x) + _zero(y)
    return HeightField("cylinder_crest", f, grad, hess)


def saddle(a: float, b: float) -> HeightField:
    """z = a x^2 - b y^2 (a, b > 0: a saddle; a != b gives nonzero H)."""
    return HeightField("saddle", lambda x, y: a * x**2 - b * y**2,
                       lambda x, y: (2 * a * x, -2 * b * y),
                       lambda x, y: (2 * a + _zero(x), _zero(x), -2 * b + _zero(x)))


def gaussian_hill(height: float, sigma: float) -> HeightField:
    """z = h exp(-(x^2 + y^2) / (2 s^2)): positive H on top, negative on the skirt."""
    def f(x, y):
        return height * np.exp(-(x**2 + y**2) / (2 * sigma**2))

    def grad(x, y):
        z = f(x, y)
        return -x / sigma**2 * z, -y / sigma**2 * z

    def hess(x, y):
        z = f(x, y)
        s2 = sigma**2
        return (x**2 / s2 - 1) / s2 * z, x * y / s2**2 * z, (y**2 / s2 - 1) / s2 * z
    return HeightField("gaussian_hill", f, grad, hess)


def sinusoid(amplitude: float, wavelength_x: float, wavelength_y: float) -> HeightField:
    """z = A sin(kx x) cos(ky y): rolling ground."""
    kx, ky = 2 * np.pi / wavelength_x, 2 * np.pi / wavelength_y

    def f(x, y):
        return amplitude * np.sin(kx * x) * np.cos(ky * y)

    def grad(x, y):
        return (amplitude * kx * np.cos(kx * x) * np.cos(ky * y),
                -amplitude * ky * np.sin(kx * x) * np.sin(ky * y))

    def hess(x, y):
        return (-amplitude * kx**2 * np.sin(kx * x) * np.cos(ky * y),
                -amplitude * kx * ky * np.cos(kx * x) * np.sin(ky * y),
                -amplitude * ky**2 * np.sin(kx * x) * np.cos(ky * y))
    return HeightField("sinusoid", f, grad, hess)


def grid_mesh(field: HeightField, half_extent: float, spacing: float,
              offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> tuple[Array, Array, Array]:
    """Regular grid over [-e, e]^2 triangulated like a DEM.

    Returns vertices (n, 3) float64 m (shifted by ``offset``), faces (m, 3) int64,
    and the local x, y (n, 2) at which the field was sampled.
    """
    count = int(round(2 * half_extent / spacing)) + 1
    xs = -half_extent + spacing * np.arange(count)
    X, Y = np.meshgrid(xs, xs)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    faces = grid_faces(np.arange(count * count).reshape(count, count)[::-1])  # vertex rows run south to north
    return _lift(field, xy, offset), faces, xy


def jittered_mesh(field: HeightField, half_extent: float, spacing: float, jitter: float = 1 / 3,
                  seed: int = 0, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> tuple[Array, Array, Array]:
    """Grid points moved by up to ``jitter`` x spacing in x and y, Delaunay-triangulated."""
    from scipy.spatial import Delaunay

    count = int(round(2 * half_extent / spacing)) + 1
    xs = -half_extent + spacing * np.arange(count)
    X, Y = np.meshgrid(xs, xs)
    rng = np.random.default_rng(seed)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    xy = xy + rng.uniform(-jitter, jitter, xy.shape) * spacing
    faces = Delaunay(xy).simplices.astype(np.int64)
    # counter-clockwise seen from above
    a, b, c = xy[faces[:, 0]], xy[faces[:, 1]], xy[faces[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    faces[cw] = faces[cw][:, [0, 2, 1]]
    return _lift(field, xy, offset), faces, xy


def _lift(field: HeightField, xy: Array, offset) -> Array:
    z = field.f(xy[:, 0], xy[:, 1])
    return np.column_stack([xy[:, 0] + offset[0], xy[:, 1] + offset[1], z + offset[2]])


def dem_terrain(heights: Array, origin=(0.0, 0.0), spacing: float = 1.0, name: str = "dem") -> RawTerrain:
    """A RawTerrain with DEM grid structure from a (rows, cols) height array (row 0 south, as a
    mesh numbers its vertices; NaN = NODATA) whose south-west post is at ``origin``."""
    heights = np.asarray(heights, dtype=float)
    valid = np.isfinite(heights)
    vertex = np.full(heights.shape, -1, dtype=np.int64)
    vertex[valid] = np.arange(int(valid.sum()))
    rr, cc = np.nonzero(valid)
    vertices = np.column_stack([origin[0] + cc * spacing, origin[1] + rr * spacing, heights[valid]])
    north = np.ascontiguousarray(vertex[::-1])
    grid = PostVertices(PostGrid.from_south_west(*heights.shape, origin[0], origin[1], spacing, spacing), north)
    return RawTerrain(vertices, grid_faces(north), grid, name, "0" * 64, "asc")


def mesh_terrain(vertices: Array, faces: Array, name: str = "mesh") -> RawTerrain:
    """A RawTerrain without grid structure (an irregular mesh)."""
    return RawTerrain(np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64), None, name, "0" * 64, "obj")


def surface_of(raw: RawTerrain, vehicle: Vehicle | None = None) -> MeshSurface:
    """Classify a RawTerrain and build its MeshSurface (for tests and benchmarks)."""
    return MeshSurface.from_store(classify_mesh(raw, vehicle=vehicle))


def obstacle_course(spacing: float = 0.5, seed: int = 0) -> Array:
    """Heights (rows, cols) of a 120 m x 80 m test ground (row 0 south, ``spacing`` m posts).

    West to east: rolling ground; three knife-edge crests (triangular ridges
    0.6 to 1.2 m high, sharp at the top) at different angles; an anti-tank
    ditch 3 m wide at the top and 1.5 m deep with steep walls; a 0.3 m
    vertical-looking step (one post spacing); shell craters with rims.
    Survey noise of 2 mm. Matching is judged here where it is hardest.
    """
    rng = np.random.default_rng(seed)
    xs = np.arange(0.0, 120.0 + spacing / 2, spacing)
    ys = np.arange(0.0, 80.0 + spacing / 2, spacing)
    x, y = np.meshgrid(xs, ys)
    z = 0.4 * np.sin(2 * np.pi * x / 37) * np.cos(2 * np.pi * y / 29)
    for x0, angle, height, half_base in ((20, 0.0, 0.6, 2.0), (30, 0.4, 1.0, 3.0), (42, -0.3, 1.2, 2.5)):
        d = np.abs((x - x0) * np.cos(angle) + (y - 40) * np.sin(angle))
        z += np.maximum(0.0, height * (1 - d / half_base))
    d = np.abs(x - 60)
    z -= 1.5 * np.clip((1.5 - d) / 0.5, 0.0, 1.0)  # flat bottom 2 m wide, walls 0.5 m across
    z += np.where(x > 75, 0.3, 0.0)
    for cx, cy, radius, depth in ((90, 20, 4.0, 1.2), (100, 55, 6.0, 1.8), (110, 30, 3.0, 0.9)):
        r = np.hypot(x - cx, y - cy)
        z += np.where(r < radius, -depth * (1 - (r / radius) ** 2) ** 2, 0.0) + 0.4 * np.exp(-(((r - radius) / 1.2) ** 2))
    return z + rng.normal(0.0, 0.002, z.shape)
