"""The pictures: PNGs of the stated size whose axes hold what was asked for: the path and events at
their places relative to the stated origin, classes and curvature over the posts' cells, the
gun's limit and the drums' bite."""

import struct

import numpy as np
import pytest

from tankcd_cli.plots import _metres, _overview_extent, class_map_png, envelope_png, grid_map_png, replay_map_png
from tankcd_cli.replay.effects import EVENT_KIND_TABLE
from tankcd_cli.vehicle import vehicle_preset
from tests.conftest import write_asc, write_obj

X0, Y0 = 500_000.0, 4_500_000.0


@pytest.fixture
def figures(monkeypatch):
    """The figures the functions save (closed afterwards, their artists still there to read)."""
    from matplotlib.figure import Figure

    saved = []
    original = Figure.savefig

    def savefig(self, *args, **kwargs):
        saved.append(self)
        return original(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved


def png_size(path):
    data = open(path, "rb").read(24)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def legend_labels(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    from tankcd_cli.api import classify

    out = tmp_path_factory.mktemp("plots")
    y, x = np.mgrid[0:21, 0:31]
    dem = write_asc(out / "g.asc", 50 + 0.5 * np.sin(x / 2.0) * np.cos(y / 3.0), cellsize=2.0, xll=X0, yll=Y0)
    grid = classify(str(dem), str(out / "g.h5"))
    V = np.array([[i, j, 0.3 * np.sin(i / 2.0) + 0.2 * np.cos(j / 3.0)] for j in range(15) for i in range(20)], float)
    idx = np.arange(len(V)).reshape(15, 20)
    F = np.concatenate([np.column_stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()]),
                        np.column_stack([idx[:-1, :-1].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()])])
    mesh = classify(str(write_obj(out / "m.obj", V, F)), str(out / "m.h5"))
    return grid.output, mesh.mesh_store


def test_metres_drop_trailing_zeros_and_group_thousands():
    assert [_metres(v) for v in (500000.0, 4500077.5, 0.125, 1.0004, -3.0)] == \
        ["500,000", "4,500,077.5", "0.125", "1", "-3"]


def test_the_replay_map_draws_the_path_and_events_from_the_stated_origin(tmp_path, figures):
    s = np.linspace(0, 1, 50)
    path = np.column_stack([X0 + 10 + 30 * s, Y0 + 5 + 20 * s ** 2])
    marks = [("obstacle", X0 + 25.0, Y0 + 10.0), ("terrain", X0 + 12.0, Y0 + 6.0), ("obstacle", X0 + 30.0, Y0 + 15.0)]
    hut = np.array([[X0 + 20, Y0 + 20], [X0 + 24, Y0 + 20], [X0 + 24, Y0 + 22], [X0 + 20, Y0 + 22]])
    out = tmp_path / "r.png"
    replay_map_png(None, path, marks, str(out), footprints=[("hut", hut)], counts={"obstacle": 7, "terrain": 1},
                   kinds=EVENT_KIND_TABLE)
    assert png_size(out) == (1100, 770)  # 10 x 7 in at 110 dpi
    ax, = figures[0].axes
    origin = path.min(axis=0)  # no terrain: the path's south-west corner
    np.testing.assert_allclose(ax.lines[0].get_xydata(), path - origin)
    assert "origin: x = 500,010 m, y = 4,500,005 m" in ax.get_xlabel()
    labels = legend_labels(ax)
    assert labels == ["path", "obstacles", "hit an obstacle (7)", "hull bottom on the ground (1)"]
    hit, ground = ax.collections[-2:]
    np.testing.assert_allclose(hit.get_offsets(), [[25 - 10, 10 - 5], [30 - 10, 15 - 5]])
    np.testing.assert_allclose(ground.get_offsets(), [[2, 1]])
    assert [t.get_text() for t in ax.texts] == ["hut"]
    np.testing.assert_allclose(ax.texts[0].get_position(), (12.0, 16.0))  # the outline's centre


def test_the_replay_map_colours_the_path_by_matcher(tmp_path, figures):
    from tankcd_cli.matching.match import PLACED_BY

    path = np.column_stack([X0 + np.arange(30.0), Y0 + np.zeros(30)])
    matcher = np.array([0] * 10 + [4] * 15 + [5] * 5)
    replay_map_png(None, path, [], str(tmp_path / "m.png"), matcher=matcher)
    ax, = figures[0].axes
    assert legend_labels(ax) == [f"{PLACED_BY[0]} (10)", f"{PLACED_BY[4]} (15)", f"{PLACED_BY[5]} (5)"]
    assert [len(c.get_offsets()) for c in ax.collections] == [10, 15, 5]
    assert not ax.lines


def test_a_grid_store_is_drawn_over_its_posts_cells_from_its_south_west_post(tmp_path, figures, stores):
    from tankcd_cli.terrain.grid.store import read_overview

    grid_store, _ = stores
    ov = read_overview(grid_store)
    assert ov["step"] == 1 and ov["classes"].shape == (21, 31)  # a small grid: every post
    origin, extent = _overview_extent(ov)
    np.testing.assert_array_equal(origin, [X0, Y0])
    assert extent == (-1.0, 61.0, -1.0, 41.0)  # each post's 2 m cell, about the post
    replay_map_png(grid_store, np.array([[X0 + 4, Y0 + 6], [X0 + 8, Y0 + 6]]), [], str(tmp_path / "g.png"))
    ax, = figures[0].axes
    assert ax.images[0].get_extent() == [-1.0, 61.0, -1.0, 41.0]
    np.testing.assert_allclose(ax.lines[0].get_xydata(), [[4, 6], [8, 6]])
    figures.clear()
    grid_map_png(grid_store, str(tmp_path / "c.png"), title="the ground")
    left, right = figures[0].axes[:2]
    assert figures[0].get_suptitle() == "the ground"
    np.testing.assert_array_equal(np.ma.getdata(left.images[0].get_array()), ov["classes"])
    assert left.images[0].get_extent() == right.images[0].get_extent() == [-1.0, 61.0, -1.0, 41.0]
    assert png_size(tmp_path / "c.png") == (1430, 616)


def test_a_mesh_store_colours_each_face_by_its_worst_vertex(tmp_path, figures, stores):
    _, store = stores
    class_map_png(store, str(tmp_path / "k.png"))
    assert png_size(tmp_path / "k.png") == (1430, 616)
    classes, curvature = figures[0].axes[:2]  # the two panels (the colour bars come after)
    np.testing.assert_array_equal(classes.collections[0].get_array(), store.vertex_class[store.faces].max(axis=1))
    a = store.attrs
    assert f"|H| < {a['threshold_flat']:.4f} flat" in classes.get_title()
    assert a["curvature_method"] in curvature.get_title()
    assert "origin: x = 0 m, y = 0 m" in classes.get_xlabel()


def _envelope(vehicle):
    az = np.arange(0.0, 360.0, 1.0)
    lim = np.full(az.shape, vehicle.gun_min_deg)
    if vehicle.fuel_drums:
        lim[(az > 150) & (az < 210)] = 1.0  # the drums bite over the rear
    return {"azimuth": az, "min_elevation": lim}


@pytest.mark.parametrize("name", ["t72", "m1"])
def test_the_envelope_shows_the_gun_limit_and_the_drums_only_when_fitted(tmp_path, figures, name):
    v = vehicle_preset(name)
    env = _envelope(v)
    envelope_png(v, env, str(tmp_path / "e.png"))
    assert png_size(tmp_path / "e.png") == (704, 704)
    ax, = figures[0].axes
    labels = legend_labels(ax)
    assert f"gun limit {v.gun_min_deg:g} deg" in labels and "lowest safe elevation" in labels
    assert ("barrel meets a drum" in labels) == v.fuel_drums
    assert ("no fuel drums" in ax.get_title()) == (not v.fuel_drums) and ax.get_title().startswith(v.name)
    safe = ax.lines[0].get_xydata()
    order = np.argsort(np.radians(env["azimuth"]))
    np.testing.assert_allclose(safe[:-1, 1], env["min_elevation"][order])  # closed round the circle
    assert safe[-1, 1] == safe[0, 1] and safe[-1, 0] == pytest.approx(safe[0, 0] + 2 * np.pi)
    assert ax.get_ylim()[0] == pytest.approx(v.gun_min_deg - 1)
