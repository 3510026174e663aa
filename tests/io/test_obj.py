"""OBJ files as the programs that wrote them open them: what a surface cannot use (two-index faces,
line and point elements, as in pybullet's meshes) skipped and counted, objects and groups as
parts, what is truly broken an InputError; the fast and the full readers agree. Every file is
written here, in the test; trimesh's own loading is the independent truth."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.errors import InputError
from tankcd_cli.io.obj import parse_obj, read_simple_obj, simple_obj
from tankcd_cli.io.terrain_readers import read_terrain


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
    data = (GRID_V + "\n".join(statements) + "\n").encode()
    fast = simple_obj(data)
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


@pytest.mark.parametrize("content,fragment", [
    (b"", "empty"),
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no triangle faces"),
    (b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "non-finite coordinate"),
    (b"\x00\x01\x02garbage\xff\xfe" * 50, "OBJ"),
])
def test_obj_malformed(tmp_path, content, fragment):
    path = tmp_path / "bad.obj"
    path.write_bytes(content)
    with pytest.raises(InputError) as err:
        read_terrain(str(path))
    assert fragment in str(err.value) or "no vertices" in str(err.value) or "no triangle" in str(err.value)


@pytest.mark.parametrize("body", [
    "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nf 1 2 3\nf 2 4 3\n",
    "# comment\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nvt 0 0\nvn 0 0 1\ns off\nf 1/1/1 2/1/1 3/1/1\nf 2//1 4//1 3//1\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nf 1 2 4 3\n",  # a quad: the full reader
    "v 0 0 0\nv 1 0 0\nv 0 1 0.5\nv 1 1 0.25\nf -4 -3 -2\nf -3 -1 -2\n",  # relative indices: the full reader
])
def test_simple_obj_reader_agrees_with_trimesh(tmp_path, body):
    import trimesh

    path = tmp_path / "m.obj"
    path.write_text(body)
    raw = read_terrain(str(path))
    ref = trimesh.load(str(path), force="mesh", process=False)
    ours = np.sort(raw.vertices[raw.faces].reshape(-1, 3), axis=0)
    theirs = np.sort(np.asarray(ref.vertices)[np.asarray(ref.faces)].reshape(-1, 3), axis=0)
    np.testing.assert_allclose(ours, theirs)
    simple = read_simple_obj(body.encode())
    assert (simple is None) == ("f 1 2 4 3" in body or "f -4" in body)
