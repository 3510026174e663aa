"""What a replay's map is drawn from: every stride-th pose kept in bounded memory with its matcher,
events counted in full and marked where they happened, obstacles outlined from above."""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tankcd_cli.replay import drawing
from tankcd_cli.replay.drawing import ReplayDrawing, footprint_outline
from tankcd_cli.vehicle_mesh import box


class _Chunk(SimpleNamespace):
    """A trajectory chunk as the replay hands it over: steps, x, y and its length."""

    def __len__(self):
        return len(self.step)


def _chunk(first, n):
    step = np.arange(first, first + n)
    chunk = _Chunk(step=step, x=500_000.0 + step * 0.5, y=4_500_000.0 - step * 0.25)
    return chunk, SimpleNamespace(matcher=step % 7)


def _event(kind, step):
    return SimpleNamespace(kind=kind, step=step)


def _feed(d, sizes, events=lambda first, n: []):
    first = 0
    for n in sizes:
        chunk, poses = _chunk(first, n)
        d.observe(chunk, poses, events(first, n))
        first += n
    return first


def test_every_pose_is_kept_while_there_is_room():
    d = ReplayDrawing()
    seen = _feed(d, [5, 1, 9])
    xy, matcher = np.concatenate(d.xy), np.concatenate(d.matcher)
    np.testing.assert_array_equal(xy[:, 0], 500_000.0 + np.arange(seen) * 0.5)
    np.testing.assert_array_equal(xy[:, 1], 4_500_000.0 - np.arange(seen) * 0.25)
    np.testing.assert_array_equal(matcher, np.arange(seen) % 7)
    assert matcher.dtype == np.int8 and d.seen == seen == 15 and d.stride == 1


@pytest.mark.parametrize("sizes", [[7] * 20, [1] * 90, [33, 2, 50, 4]])
def test_a_long_path_is_thinned_to_every_stride_th_pose_whatever_the_chunks(monkeypatch, sizes):
    monkeypatch.setattr(drawing, "MAX_PATH_POINTS", 16)
    d = ReplayDrawing()
    seen = _feed(d, sizes)
    xy, matcher = np.concatenate(d.xy), np.concatenate(d.matcher)
    kept = np.arange(0, seen, d.stride)  # the rows a path drawn every stride-th pose has
    assert d.stride > 1 and len(xy) <= 16 + max(sizes)
    np.testing.assert_array_equal(xy[:, 0], 500_000.0 + kept * 0.5)
    np.testing.assert_array_equal(matcher, kept % 7)  # each kept pose keeps its own matcher


def test_events_are_counted_in_full_and_marked_where_they_happened(monkeypatch):
    monkeypatch.setattr(drawing, "MAX_MARKS", 5)
    d = ReplayDrawing()

    def events(first, n):
        return [_event("obstacle", s) for s in range(first, first + n, 3)] + [_event("terrain", first + n - 1)]
    _feed(d, [10, 10, 4], events)
    assert d.counts == {"obstacle": 4 + 4 + 2, "terrain": 3}
    assert len(d.marks) == 5  # the map marks so many; the legend counts them all
    steps = [0, 3, 6, 9, 9]  # in the order seen: the first chunk's obstacles, then its terrain event
    assert [k for k, _, _ in d.marks] == ["obstacle"] * 4 + ["terrain"]
    np.testing.assert_array_equal([x for _, x, _ in d.marks], 500_000.0 + np.array(steps) * 0.5)
    np.testing.assert_array_equal([y for _, _, y in d.marks], 4_500_000.0 - np.array(steps) * 0.25)


def test_save_hands_the_map_what_was_gathered(monkeypatch, tmp_path):
    import tankcd_cli.plots as plots

    calls = []
    monkeypatch.setattr(plots, "replay_map_png", lambda *a, **k: calls.append((a, k)))
    hut = SimpleNamespace(name="hut", tree=SimpleNamespace(triangles=box([0, 0, 0], [4, 2, 3]) + [10.0, 20.0, 0.0]))
    for colour_by in ("path", "matcher"):
        d = ReplayDrawing(colour_by=colour_by)
        _feed(d, [4, 4], lambda first, n: [_event("internal", first)])
        d.save(str(tmp_path / "m.png"), "store.h5", obstacles=[hut])
        (store, xy, marks, path), k = calls.pop()
        assert store == "store.h5" and path == str(tmp_path / "m.png") and len(xy) == 8
        assert marks == d.marks and k["counts"] == {"internal": 2}
        assert (k["matcher"] is None) == (colour_by == "path")
        (name, outline), = k["footprints"]
        assert name == "hut" and sorted(map(tuple, outline.tolist())) == [(10, 20), (10, 22), (14, 20), (14, 22)]
    ReplayDrawing().save(str(tmp_path / "e.png"), None)  # nothing observed: an empty path
    (_, xy, marks, _), k = calls.pop()
    assert xy.shape == (0, 2) and marks == [] and k["footprints"] == []


def test_save_writes_a_png(tmp_path):
    d = ReplayDrawing()
    _feed(d, [50], lambda first, n: [_event("obstacle", 20)])
    d.save(str(tmp_path / "map.png"), None)
    assert (tmp_path / "map.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _area(outline):
    x, y = outline[:, 0], outline[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_the_outline_of_a_turned_box_is_its_four_corners_counter_clockwise():
    R = Rotation.from_euler("z", 30, degrees=True).as_matrix()
    tris = box([-3, -1, 0], [3, 1, 2], 2) @ R.T + [7.0, -4.0, 1.0]
    outline = footprint_outline(tris)
    corners = (np.array([[-3, -1, 0], [3, -1, 0], [3, 1, 0], [-3, 1, 0]]) @ R.T)[:, :2] + [7.0, -4.0]
    assert outline.shape == (4, 2)
    assert sorted(map(tuple, np.round(outline, 9).tolist())) == sorted(map(tuple, np.round(corners, 9).tolist()))
    assert _area(outline) == pytest.approx(12.0)  # positive: counter-clockwise; 6 m x 2 m


def test_the_outline_holds_every_point_seen_from_above():
    rng = np.random.default_rng(3)
    tris = rng.normal(0, 5, (40, 3, 3))
    outline = footprint_outline(tris)
    pts = tris.reshape(-1, 3)[:, :2]
    assert _area(outline) > 0
    edges = np.roll(outline, -1, axis=0) - outline
    rel = pts[:, None, :] - outline[None]
    cross = edges[None, :, 0] * rel[..., 1] - edges[None, :, 1] * rel[..., 0]
    assert (cross >= -1e-9).all()  # every point left of (or on) every edge
    assert {tuple(p) for p in outline.tolist()} <= {tuple(p) for p in pts.tolist()}


def test_outlines_with_too_few_points_or_all_in_a_line():
    one = np.zeros((1, 3, 3))
    assert footprint_outline(one).tolist() == [[0.0, 0.0]]
    line = np.array([[[0, 0, 0], [1, 1, 5], [3, 3, 0]], [[2, 2, 1], [1, 1, 0], [0, 0, 2]]], float)  # a wall seen edge on
    assert footprint_outline(line).tolist() == [[0.0, 0.0], [3.0, 3.0]]


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 80), st.integers(0, 2**32 - 1), st.sampled_from([None, 0, 1]))
def test_the_outline_is_qhulls_on_random_clouds(n, seed, decimals):
    """Against scipy's Qhull: the same corners, on clouds of points in general position and on
    coarse integer grids (many duplicates and collinear points), at UTM-sized coordinates too."""
    from scipy.spatial import ConvexHull, QhullError

    rng = np.random.default_rng(seed)
    tris = rng.normal(0, 6, (n, 3, 3))
    if decimals is not None:
        tris = np.round(tris, decimals)
    if seed % 2:
        tris = tris + [500_000.0, 4_500_000.0, 0.0]
    pts = np.unique(tris.reshape(-1, 3)[:, :2], axis=0)
    outline = footprint_outline(tris)
    try:
        corners = pts[ConvexHull(pts).vertices]
    except (QhullError, ValueError):  # fewer than 3 points or all in a line
        assert len(outline) <= 2
        return
    assert sorted(map(tuple, outline.tolist())) == sorted(map(tuple, corners.tolist()))
    assert _area(outline - outline.mean(axis=0)) > 0
