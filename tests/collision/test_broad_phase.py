"""The broad phase: every method's SET of pairs against brute force (and brute force against a plain
double loop), sorted and unique, over random, clustered, all-overlapping and touching segments,
convoys and columns, time spans that touch or nest, one owner's many segments, UTM coordinates,
bad input and no input."""

import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.collision.broad_phase import (
    BRUTE_FORCE_BELOW,
    METHODS,
    brute_force,
    candidate_pairs,
    chosen_method,
    grid_cell_size,
    projected_overlaps,
    sort_and_sweep,
    uniform_grid,
)

# every method and variant, each a function of (lo, hi, t0, t1, owner)
VARIANTS = {
    "sweep": sort_and_sweep,
    "sweep x": lambda *a: sort_and_sweep(*a, axis="x"),
    "sweep y": lambda *a: sort_and_sweep(*a, axis=1),
    "sweep z": lambda *a: sort_and_sweep(*a, axis="z"),
    "sweep t": lambda *a: sort_and_sweep(*a, axis="t"),
    "sweep, blocks of 97": lambda *a: sort_and_sweep(*a, block=97),
    "grid": uniform_grid,
    "grid over x, y alone": lambda *a: uniform_grid(*a, time_cell=np.inf),
    "grid, blocks of 61": lambda *a: uniform_grid(*a, block=61),
    "grid, slabs of 40 entries": lambda *a: uniform_grid(*a, slab=40),
    "grid, fine cells": lambda *a: uniform_grid(*a, cell=0.37, time_cell=0.05),
    "grid, few cells per segment": lambda *a: uniform_grid(*a, max_cells=3, block=101),
    "grid, every segment swept": lambda *a: uniform_grid(*a, max_cells=0),
    "auto": candidate_pairs,
    "auto, blocks of 31": lambda *a: candidate_pairs(*a, block=31),
    **{f"candidate_pairs {m}": (lambda m: lambda *a: candidate_pairs(*a, method=m))(m) for m in METHODS},
    "brute force, blocks of 53": lambda *a: brute_force(*a, block=53),
}


def double_loop(lo, hi, t0, t1, owner):
    """The definition, one pair at a time: closed boxes and spans overlapping, owners different."""
    out = []
    for i in range(len(lo)):
        for j in range(i + 1, len(lo)):
            if owner[i] != owner[j] and t0[i] <= t1[j] and t0[j] <= t1[i] and \
                    all(lo[i][a] <= hi[j][a] and lo[j][a] <= hi[i][a] for a in range(3)):
                out.append((i, j))
    return out


def assert_pairs(got, expected):
    """``got`` is (P, 2) int64, i < j, sorted lexicographically and unique, and as a set equals
    ``expected`` (an iterable of pairs)."""
    assert got.dtype == np.int64 and got.ndim == 2 and got.shape[1] == 2
    assert (got[:, 0] < got[:, 1]).all()
    if len(got) > 1:
        a, b = got[:-1], got[1:]
        assert ((a[:, 0] < b[:, 0]) | ((a[:, 0] == b[:, 0]) & (a[:, 1] < b[:, 1]))).all(), "not sorted or not unique"
    expected = {(int(i), int(j)) for i, j in expected}
    got_set = set(map(tuple, got.tolist()))
    missing, extra = expected - got_set, got_set - expected
    assert not missing and not extra, \
        f"missing {sorted(missing)[:10]} ({len(missing)}), extra {sorted(extra)[:10]} ({len(extra)})"


def assert_every_method_agrees(lo, hi, t0, t1, owner, expected=None):
    truth = brute_force(lo, hi, t0, t1, owner)
    if expected is not None:
        assert_pairs(truth, expected)
    assert_pairs(truth, truth.tolist())
    for name, fn in VARIANTS.items():
        try:
            assert_pairs(fn(lo, hi, t0, t1, owner), truth.tolist())
        except AssertionError as e:
            raise AssertionError(f"{name}: {e}") from None
    return truth


def random_segments(rng, m, side=30.0, size=4.0, duration=2.0, owners=None, snap=None):
    centre = rng.uniform(0, side, (m, 3))
    half = rng.uniform(0, size, (m, 3))
    t0 = rng.uniform(0, 10, m)
    span = rng.uniform(0, duration, m)
    if snap:  # coordinates on a coarse lattice: many shared faces, edges and equal ends
        centre, half, t0, span = (np.round(a / snap) * snap for a in (centre, half, t0, span))
    owner = rng.integers(0, owners or max(1, m // 4), m)
    return centre - half, centre + half, t0, t0 + span, owner


def exercise(n, segments, rng, spread=200.0, platoon=5, rate=10.0):
    """n vehicles (7 m x 3.5 m x 2.2 m) driving in platoons for ``segments`` rows at ``rate`` Hz:
    per segment the box at its middle, turned with the heading, grown by half its travel."""
    platoons = -(-n // platoon)
    centre = rng.uniform(0, spread, (platoons, 2))
    heading = rng.uniform(-np.pi, np.pi, platoons)
    speed = rng.uniform(3, 12, platoons)
    p = np.arange(n) // platoon
    along = 12.0 * (np.arange(n) % platoon)
    start = centre[p] - along[:, None] * np.column_stack([np.cos(heading[p]), np.sin(heading[p])])
    times = np.arange(segments + 1) / rate
    mid = 0.5 * (times[1:] + times[:-1])
    direction = np.column_stack([np.cos(heading[p]), np.sin(heading[p])])
    xy = start[:, None, :] + (speed[p][:, None] * mid[None, :])[..., None] * direction[:, None, :]
    c, s = np.abs(np.cos(heading[p])), np.abs(np.sin(heading[p]))
    grow = 0.5 * speed[p] / rate
    half = np.column_stack([c * 3.5 + s * 1.75 + grow, s * 3.5 + c * 1.75 + grow, 1.1 + grow])
    z = np.zeros(xy.shape[:2] + (1,)) + 1.1
    centre3 = np.concatenate([xy, z], axis=-1).reshape(-1, 3)
    half3 = np.repeat(half, segments, axis=0)
    t0 = np.tile(times[:-1], n)
    t1 = np.tile(times[1:], n)
    return centre3 - half3, centre3 + half3, t0, t1, np.repeat(np.arange(n), segments)


# --- the oracle itself --------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(8))
def test_brute_force_is_the_definition(seed):
    rng = np.random.default_rng(seed)
    seg = random_segments(rng, 40, side=10.0, snap=0.5 if seed % 2 else None)
    assert_pairs(brute_force(*seg), double_loop(*seg))
    assert_pairs(brute_force(*seg, block=1), double_loop(*seg))


@pytest.mark.parametrize("seed", range(4))
def test_blocks_of_one_candidate(seed):
    # a range split at every candidate, rows longer than a block and blocks across rows
    rng = np.random.default_rng(seed)
    seg = random_segments(rng, 60, side=8.0, snap=1.0 if seed % 2 else None)
    truth = brute_force(*seg)
    assert len(truth) > 20
    assert_pairs(brute_force(*seg, block=1), truth.tolist())
    for fn in (sort_and_sweep, uniform_grid, candidate_pairs):
        for block in (1, 2, 5):
            assert_pairs(fn(*seg, block=block), truth.tolist())
    assert_pairs(uniform_grid(*seg, block=1, max_cells=2), truth.tolist())
    assert_pairs(uniform_grid(*seg, block=3, slab=1), truth.tolist())


# --- random and clustered -----------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("snap", [None, 1.0])
def test_random_segments(seed, snap):
    rng = np.random.default_rng(seed)
    seg = random_segments(rng, int(rng.integers(50, 400)), side=float(rng.uniform(10, 80)), snap=snap)
    truth = assert_every_method_agrees(*seg)
    assert len(truth) > 0


@pytest.mark.parametrize("seed", range(4))
def test_clustered_exercise_of_platoons(seed):
    rng = np.random.default_rng(seed)
    seg = exercise(12, 25, rng, spread=60.0)
    truth = assert_every_method_agrees(*seg)
    assert len(truth) > 0


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 120), st.sampled_from([None, 0.5, 1.0]),
       st.floats(2.0, 60.0), st.integers(1, 12))
def test_every_method_equals_brute_force(seed, m, snap, side, owners):
    rng = np.random.default_rng(seed)
    seg = random_segments(rng, m, side=side, snap=snap, owners=owners)
    assert_every_method_agrees(*seg)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 300))
def test_the_pairs_never_depend_on_the_input_order(seed, m):
    # fcl#368: results that reorder; here a permutation of the input permutes the indices alone
    rng = np.random.default_rng(seed)
    seg = random_segments(rng, m, side=25.0, snap=1.0)
    perm = rng.permutation(m)
    shuffled = tuple(a[perm] for a in seg)
    for name in ("sweep", "grid", "auto"):
        got = VARIANTS[name](*shuffled)
        back = np.sort(perm[got], axis=1)
        assert_pairs(got, got.tolist())
        assert_pairs(VARIANTS[name](*seg), back.tolist())


# --- all overlapping and touching ---------------------------------------------------------------

def test_all_overlapping():
    rng = np.random.default_rng(3)
    m = 200
    half = rng.uniform(0.5, 3, (m, 3))
    owner = rng.integers(0, 40, m)
    seg = (-half, half, np.zeros(m), np.ones(m), owner)
    expected = [(i, j) for i in range(m) for j in range(i + 1, m) if owner[i] != owner[j]]
    assert_every_method_agrees(*seg, expected=expected)


def _cubes(corners, size=1.0):
    corners = np.asarray(corners, dtype=float)
    return corners, corners + size


def test_shared_faces_edges_and_corners_touch():
    # a 3 x 3 x 3 lattice of unit cubes: every two that share a face, an edge or a corner pair
    idx = np.array([(x, y, z) for x in range(3) for y in range(3) for z in range(3)], dtype=float)
    lo, hi = _cubes(idx)
    m = len(lo)
    expected = [(i, j) for i in range(m) for j in range(i + 1, m) if np.abs(idx[i] - idx[j]).max() <= 1]
    assert_every_method_agrees(lo, hi, np.zeros(m), np.ones(m), np.arange(m), expected=expected)


def test_a_gap_of_one_ulp_does_not_touch():
    lo = np.array([[0.0, 0, 0], [1.0, 0, 0], [np.nextafter(2.0, 3.0), 0, 0]])
    hi = np.array([[1.0, 1, 1], [2.0, 1, 1], [3.0, 1, 1]])
    assert_every_method_agrees(lo, hi, np.zeros(3), np.ones(3), np.arange(3), expected=[(0, 1)])


def test_equal_boxes_and_zero_size_boxes():
    # two equal boxes, a point on a face of one, a point at its corner, a flat box on its top
    # face, a point inside, a point just outside, and two equal points
    lo = np.array([[0, 0, 0], [0, 0, 0], [1, 0.5, 0.5], [1, 1, 1], [0, 0, 1], [0.5, 0.5, 0.5],
                   [1.5, 0.5, 0.5], [7, 7, 7], [7, 7, 7]], dtype=float)
    hi = lo.copy()
    hi[0] = hi[1] = [1, 1, 1]
    hi[4] = [1, 1, 1]
    m = len(lo)
    seg = (lo, hi, np.zeros(m), np.zeros(m), np.arange(m))  # instants, all at t = 0
    # the two boxes hold each of the others; the corner point lies on the flat box's face; the
    # points and the flat box meet nothing else
    expected = [(0, 1)] + [(b, k) for b in (0, 1) for k in (2, 3, 4, 5)] + [(3, 4), (7, 8)]
    assert_every_method_agrees(*seg, expected=expected)


# --- convoys and columns (vehicles of 7 m x 3.5 m x 2.2 m) --------------------------------------

LENGTH, WIDTH, HEIGHT = 7.0, 3.5, 2.2


def _column(n, segments, pitch, along_x, grow):
    """n vehicles in a line (nose to tail along x when ``along_x``, else side by side along y), all
    driving +x at 10 m/s for ``segments`` rows at 10 Hz: the segment box at its middle grown by
    ``grow`` (half the 1 m travel: 0.5; 0 for the vehicles' own boxes)."""
    v, k = np.divmod(np.arange(n * segments), segments)
    x = (k + 0.5) * (1.0 if grow else 0.0) - (pitch * v if along_x else 0.0)
    y = 0.0 if along_x else pitch * v
    centre = np.column_stack([x, np.zeros_like(x) + y, np.full(len(x), HEIGHT / 2)])
    half = np.array([LENGTH / 2, WIDTH / 2, HEIGHT / 2]) + grow
    times = np.arange(segments + 1) / 10.0
    return centre - half, centre + half, times[k], times[k + 1], v


def test_a_convoy_nose_to_tail_with_1_m_gaps():
    # standing: the vehicles' boxes 1 m apart, no pair
    assert_every_method_agrees(*_column(6, 20, LENGTH + 1.0, True, 0.0), expected=[])
    # driving 1 m per segment: each box grown by 0.5 m, so neighbours' boxes touch exactly (the
    # follower's segment at the same row) or overlap (its next), and spans touch or coincide
    n, s = 6, 20
    seg = _column(n, s, LENGTH + 1.0, True, 0.5)
    code = lambda v, k: v * s + k  # noqa: E731
    expected = [(code(v, k), code(v + 1, l)) for v in range(n - 1) for k in range(s) for l in (k, k + 1) if l < s]
    truth = assert_every_method_agrees(*seg, expected=expected)
    assert len(truth) == (n - 1) * (2 * s - 1)


def test_a_column_side_by_side_with_10_cm_gaps():
    assert_every_method_agrees(*_column(6, 20, WIDTH + 0.1, False, 0.0), expected=[])
    n, s = 6, 20
    seg = _column(n, s, WIDTH + 0.1, False, 0.5)   # grown 0.5 m a side: neighbours overlap by 0.9 m
    code = lambda v, k: v * s + k  # noqa: E731
    expected = [tuple(sorted((code(v, k), code(v + 1, l)))) for v in range(n - 1) for k in range(s)
                for l in (k - 1, k, k + 1) if 0 <= l < s]
    assert_every_method_agrees(*seg, expected=expected)


# --- time ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("spans, pair", [
    (((0.0, 1.0), (2.0, 3.0)), False),              # disjoint
    (((0.0, 1.0), (1.0, 2.0)), True),               # touching at one instant
    (((1.0, 2.0), (0.0, 1.0)), True),
    (((0.0, 3.0), (1.0, 2.0)), True),               # nested
    (((1.0, 1.0), (1.0, 1.0)), True),               # two equal instants
    (((1.0, 1.0), (0.0, 1.0)), True),               # an instant at a span's end
    (((1.0, 1.0), (np.nextafter(1.0, 2.0), 2.0)), False),
    (((5e8, 5e8 + 1), (5e8 + 1, 5e8 + 2)), True),
])
def test_time_spans(spans, pair):
    lo, hi = np.zeros((2, 3)), np.ones((2, 3))
    t0, t1 = np.array(spans).T
    assert_every_method_agrees(lo, hi, t0, t1, np.array([0, 1]), expected=[(0, 1)] if pair else [])


def test_a_train_of_segments_touching_in_time():
    # two vehicles at one place, one with rows at 10 Hz, the other at 3 Hz: a pair wherever spans meet
    t_a = np.arange(31) / 10.0
    t_b = np.arange(10) / 3.0
    t0 = np.r_[t_a[:-1], t_b[:-1]]
    t1 = np.r_[t_a[1:], t_b[1:]]
    m = len(t0)
    owner = np.r_[np.zeros(30, int), np.ones(9, int)]
    expected = [(i, j) for i in range(30) for j in range(30, m) if t0[i] <= t1[j] and t0[j] <= t1[i]]
    assert_every_method_agrees(np.zeros((m, 3)), np.ones((m, 3)), t0, t1, owner, expected=expected)


# --- owners -------------------------------------------------------------------------------------

def test_one_owner_with_many_segments_never_pairs_with_itself():
    rng = np.random.default_rng(5)
    m = 500
    lo = rng.uniform(0, 5, (m, 3))
    seg = (lo, lo + 3, np.zeros(m), np.ones(m), np.full(m, 7))
    assert_every_method_agrees(*seg, expected=[])
    # and a second owner pairs with each of its segments it overlaps
    lo2, hi2 = np.r_[lo, [[2.0, 2, 2]]], np.r_[lo + 3, [[3.0, 3, 3]]]
    owner = np.r_[np.full(m, 7), [8]]
    expected = [(i, m) for i in range(m) if (lo2[i] <= hi2[m]).all() and (lo2[m] <= hi2[i]).all()]
    assert_every_method_agrees(lo2, hi2, np.zeros(m + 1), np.ones(m + 1), owner, expected=expected)


def test_owner_codes_of_any_integer_type():
    lo, hi = np.zeros((3, 3)), np.ones((3, 3))
    for owner in (np.array([0, 1, 1], np.int8), np.array([2**40, 5, 5], np.int64), [True, False, False]):
        for fn in VARIANTS.values():
            assert_pairs(fn(lo, hi, np.zeros(3), np.ones(3), owner), [(0, 1), (0, 2)])


# --- coordinates and scale ----------------------------------------------------------------------

def test_utm_coordinates():
    rng = np.random.default_rng(8)
    seg = list(exercise(20, 30, rng, spread=80.0))
    offset = np.array([512_345.678, 4_512_345.678, 312.5])
    seg[0], seg[1] = seg[0] + offset, seg[1] + offset
    truth = assert_every_method_agrees(*seg)
    assert len(truth) > 0


def test_utm_touching_is_exact():
    # at x ~ 5e5, y ~ 4.5e6 the float spacing is 6e-11 and 9e-10 m: touching boxes, and boxes one
    # ulp apart, are told apart by every method
    x, y = 512_345.678, 4_512_345.678
    nx, ny = np.nextafter(x, np.inf), np.nextafter(y, np.inf)
    lo = np.array([[x - 7, y - 3.5, 0], [x, y - 3.5, 0], [nx, y - 3.5, 0], [x - 7, y, 0], [x - 7, ny, 0]])
    hi = np.array([[x, y, 2.2], [x + 7, y, 2.2], [nx + 7, y, 2.2], [x, y + 3.5, 2.2], [x, ny + 3.5, 2.2]])
    seg = (lo, hi, np.zeros(5), np.ones(5), np.arange(5))
    # 0 touches 1 (x face) and 3 (y face), 1 touches 3 at an edge; 2 (one ulp east of 0) overlaps
    # 1 alone, 4 (one ulp north of 0) overlaps 3 alone
    expected = [(0, 1), (0, 3), (1, 2), (1, 3), (3, 4)]
    assert_every_method_agrees(*seg, expected=expected)


def test_outliers_in_size_go_around_the_grid():
    # a few segments far larger than the rest (vehicles standing still for the whole window)
    rng = np.random.default_rng(9)
    seg = list(exercise(30, 40, rng, spread=150.0))
    still = rng.choice(len(seg[0]), 15, replace=False)
    seg[0][still] -= rng.uniform(5, 40, (15, 3))
    seg[2][still] = 0.0
    seg[3][still] = 4.0
    assert_every_method_agrees(*seg)


# --- memory and the rule ------------------------------------------------------------------------

def test_memory_stays_bounded_when_everything_overlaps_on_the_sweep_axis():
    # a line of 4000 vehicles side by side: on x every pair overlaps (8 million candidates), on y
    # only neighbours; swept on x anyway, the working memory is a few blocks, not the candidates
    m = 4000
    y = np.arange(m) * 4.0
    lo = np.column_stack([np.zeros(m), y, np.zeros(m)])
    hi = lo + [7.0, 3.5, 2.2]
    seg = (lo, hi, np.zeros(m), np.ones(m), np.arange(m))
    tracemalloc.start()
    try:
        got = sort_and_sweep(*seg, axis="x", block=1 << 16)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(got) == 0
    assert peak < 12e6, f"peak {peak / 1e6:.1f} MB for 8 million candidates in blocks of 65536"


def test_the_grids_memory_follows_the_segments_not_its_entries():
    # built a slab of columns at a time, the grid's working memory is a small multiple of the
    # inputs (88 bytes a segment) whatever the number of its entries
    rng = np.random.default_rng(1)
    seg = exercise(400, 50, rng, spread=300.0)
    m = len(seg[0])
    tracemalloc.start()
    try:
        got = uniform_grid(*seg, slab=1 << 12, block=1 << 12)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(got) > 1000
    assert peak < 250 * m, f"peak {peak / m:.0f} bytes a segment"


def test_projected_overlaps_counts_the_sweeps_candidates():
    rng = np.random.default_rng(4)
    lo, hi, t0, t1, _ = random_segments(rng, 200, snap=1.0)
    L = np.column_stack([lo, t0])
    H = np.column_stack([hi, t1])
    expected = [sum(1 for i in range(200) for j in range(i + 1, 200) if L[i, a] <= H[j, a] and L[j, a] <= H[i, a])
                for a in range(4)]
    assert projected_overlaps(lo, hi, t0, t1).tolist() == expected


def test_the_rule_picks_by_size_and_by_crowding():
    rng = np.random.default_rng(2)
    small = random_segments(rng, BRUTE_FORCE_BELOW - 1)
    assert chosen_method(*small[:4]) == "brute_force"
    # a long convoy: on x its segments overlap a few neighbours each: swept
    assert chosen_method(*_column(40, 10, LENGTH + 1.0, True, 0.5)[:4]) == "sort_and_sweep"
    # a platoon exercise: about 90 candidates a segment, still swept (compiled: 3.4 ns each)
    assert chosen_method(*exercise(60, 50, rng, spread=50.0)[:4]) == "sort_and_sweep"
    # a crowded one: every axis crowded (about 300 candidates a segment), the grid
    assert chosen_method(*exercise(200, 50, rng, spread=50.0)[:4]) == "uniform_grid"


def test_grid_cell_size():
    lo = np.zeros((3, 3))
    hi = np.array([[2.0, 1, 1], [4.0, 3, 1], [1.0, 6, 1]])
    side, length = grid_cell_size(lo, hi, [0, 0, 0], [0.1, 0.2, 0.3])
    assert side == pytest.approx(3.0 * 4.0) and length == pytest.approx(2.0 * 0.2)
    assert grid_cell_size(lo, hi) == (pytest.approx(12.0), np.inf)
    # all points at one place and instant: any positive size
    assert grid_cell_size(np.ones((4, 3)), np.ones((4, 3)), np.zeros(4), np.zeros(4)) == (1.0, 1.0)


# --- bad input and no input ---------------------------------------------------------------------

ALL = [brute_force, sort_and_sweep, uniform_grid, candidate_pairs]


@pytest.mark.parametrize("fn", ALL)
@pytest.mark.parametrize("field", ["lo", "hi", "t0", "t1"])
@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_non_finite_segments_are_rejected(fn, field, value):
    seg = {"lo": np.zeros((4, 3)), "hi": np.ones((4, 3)), "t0": np.zeros(4), "t1": np.ones(4),
           "owner": np.arange(4)}
    seg[field] = seg[field].copy()
    seg[field][2] = value
    with pytest.raises(ValueError, match="segment 2"):
        fn(**seg)


@pytest.mark.parametrize("fn", ALL)
def test_malformed_segments_are_rejected(fn):
    lo, hi, t0, t1, own = np.zeros((3, 3)), np.ones((3, 3)), np.zeros(3), np.ones(3), np.arange(3)
    with pytest.raises(ValueError, match="inverted"):
        fn(hi, lo, t0, t1, own)
    with pytest.raises(ValueError, match="inverted"):
        fn(lo, hi, t1, t0, own)
    with pytest.raises(ValueError, match=r"\(M, 3\)"):
        fn(lo[:, :2], hi[:, :2], t0, t1, own)
    with pytest.raises(ValueError, match="one value per segment"):
        fn(lo, hi, t0[:2], t1, own)
    with pytest.raises(ValueError, match="integer"):
        fn(lo, hi, t0, t1, own.astype(float))


def test_unknown_method_and_axis():
    seg = (np.zeros((2, 3)), np.ones((2, 3)), np.zeros(2), np.ones(2), [0, 1])
    with pytest.raises(ValueError, match="sort_and_sweep"):
        candidate_pairs(*seg, method="octree")
    with pytest.raises(ValueError, match="x, y, z, t"):
        sort_and_sweep(*seg, axis="w")
    with pytest.raises(ValueError, match="positive"):
        uniform_grid(*seg, cell=0.0)
    with pytest.raises(ValueError, match="too small"):
        uniform_grid(*seg, cell=1e-12)


@pytest.mark.parametrize("fn", list(VARIANTS.values()), ids=list(VARIANTS))
@pytest.mark.parametrize("m", [0, 1])
def test_no_segments_and_one_segment(fn, m):
    got = fn(np.zeros((m, 3)), np.ones((m, 3)), np.zeros(m), np.ones(m), np.zeros(m, dtype=np.int64))
    assert got.shape == (0, 2) and got.dtype == np.int64
    empty = fn([], [], [], [], [])
    assert empty.shape == (0, 2) and empty.dtype == np.int64
