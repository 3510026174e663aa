"""The compiled OBJ reader (obj.scan_obj through obj.compiled_obj, used first by obj.read_obj):
against the Python fast path (simple_obj) and the full reader (parse_obj), bit for bit, and the
files it must decline."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli.errors import InputError
from tankcd_cli.io._obj import scan_obj
from tankcd_cli.io.obj import POW10, compiled_obj, parse_obj, read_obj, simple_obj
from tankcd_cli.io.terrain_readers import read_terrain

GRID_V = "".join(f"v {x} {y} {(x + y) / 4}\n" for y in range(3) for x in range(3))  # 9 vertices


def _old_read_obj(data: bytes):
    """read_obj as it was before the compiled reader: the Python fast path, else the full reader."""
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    simple = simple_obj(data)
    return simple if simple is not None else parse_obj(data, "m.obj")


def _outcome(read, data):
    try:
        return read(data)
    except InputError as exc:
        return str(exc)


def assert_same_mesh(a, b):
    assert a.vertices.dtype == b.vertices.dtype == np.float64 and a.faces.dtype == b.faces.dtype == np.int64
    assert a.vertices.shape == b.vertices.shape and a.faces.shape == b.faces.shape
    assert a.vertices.view(np.uint64).tolist() == b.vertices.view(np.uint64).tolist()  # bits, -0.0 too
    assert a.faces.tolist() == b.faces.tolist()
    assert a.skipped == b.skipped
    assert a.part_names == b.part_names
    if a.face_part is None:
        assert b.face_part is None
    else:
        assert b.face_part is not None and a.face_part.dtype == b.face_part.dtype
        assert a.face_part.tolist() == b.face_part.tolist()


def assert_compiled_is_both(data: bytes):
    """The compiled reader takes the file and gives what both Python readers give."""
    fast = compiled_obj(data)
    assert fast is not None
    simple = simple_obj(data)
    assert simple is not None
    assert_same_mesh(fast, simple)
    assert_same_mesh(fast, parse_obj(data, "m.obj"))
    assert_same_mesh(read_obj(data, "m.obj"), fast)
    return fast


def assert_declined_unchanged(data: bytes):
    """The compiled reader declines; read_obj gives what it gave before (a mesh or the same error)."""
    body = data[3:] if data.startswith(b"\xef\xbb\xbf") else data
    assert scan_obj(body, POW10) is None
    new, old = _outcome(lambda d: read_obj(d, "m.obj"), data), _outcome(_old_read_obj, data)
    if isinstance(old, str):
        assert new == old
    else:
        assert_same_mesh(new, old)
    return new


def random_mesh(rng, n=200, m=300, offset=0.0, scale=100.0):
    vertices = offset + rng.uniform(-scale, scale, (n, 3))
    faces = rng.integers(0, n, (m, 3))
    return vertices, faces


def obj_text(vertices, faces, fmt="%.6f", face="{}", eol="\n"):
    lines = ["v " + " ".join(fmt % c if isinstance(fmt, str) else fmt(c) for c in v.tolist()) for v in vertices]
    lines += ["f " + " ".join(face.format(int(i) + 1) for i in f) for f in faces]
    return eol.join(lines) + eol


# --- what it takes: the same as both Python readers ----------------------------------------


@pytest.mark.parametrize("seed", range(4))
def test_random_meshes_six_decimals(seed):
    rng = np.random.default_rng(seed)
    vertices, faces = random_mesh(rng)
    data = obj_text(vertices, faces).encode()
    fast = assert_compiled_is_both(data)
    np.testing.assert_allclose(fast.vertices, vertices, atol=5e-7)
    np.testing.assert_array_equal(fast.faces, faces)
    assert fast.skipped == {} and fast.face_part is None and fast.part_names == ()


def test_utm_like_coordinates_and_exponents():
    rng = np.random.default_rng(7)
    vertices, faces = random_mesh(rng, offset=500000.123456, scale=5000.0)
    vertices[:, 1] += 4000000.0
    assert_compiled_is_both(obj_text(vertices, faces).encode())
    for fmt in ("%.15g", "%.12e", "%.3E", "%+.9f", "%.0f", "%g"):
        assert_compiled_is_both(obj_text(vertices * 1e-3, faces, fmt=fmt).encode())


def test_seventeen_digit_floats_are_declined_and_still_read_exactly():
    rng = np.random.default_rng(3)
    vertices, faces = random_mesh(rng)
    data = obj_text(vertices, faces, fmt=repr).encode()
    assert scan_obj(data, POW10) is None
    mesh = assert_declined_unchanged(data)
    assert mesh.vertices.view(np.uint64).tolist() == vertices.view(np.uint64).tolist()  # repr round-trips
    assert_same_mesh(mesh, parse_obj(data, "m.obj"))


@pytest.mark.parametrize("face", ["{0}/{0}", "{0}//{0}", "{0}/{0}/{0}", "{0}/7/-1", "{0}//"])
def test_faces_with_texture_and_normal_indices(face):
    rng = np.random.default_rng(1)
    vertices, faces = random_mesh(rng, n=20, m=30)
    data = ("vt 0.5 0.5\nvn 0 0 1\n" + obj_text(vertices, faces, face=face)).encode()
    fast = assert_compiled_is_both(data)
    np.testing.assert_array_equal(fast.faces, faces)


def test_crlf_comments_blank_lines_and_ignored_statements():
    body = ("# exported by something\r\nmtllib scene.mtl\r\n" + GRID_V.replace("\n", "\r\n")
            + "\r\n   \r\n\t\r\nvt 0 0\r\nvn 0 0 1\r\nvp 0.5\r\nusemtl grass\r\ns 1\r\ns off\r\n"
            + "f 1 2 5   \r\nf 1\t5  4\r\n#\r\n# end\r\n")
    fast = assert_compiled_is_both(body.encode())
    assert fast.faces.tolist() == [[0, 1, 4], [0, 4, 3]]
    # and without a final line end
    assert_compiled_is_both(body.rstrip("\r\n").encode())


def test_line_and_point_elements_are_counted():
    body = GRID_V + "f 1 2 5\nl 1 2\nl 2 3 4\nf 1 5 4\np 7\n"
    fast = assert_compiled_is_both(body.encode())
    assert fast.skipped == {"line elements": 2, "point elements": 1}


@pytest.mark.parametrize("marks", [
    ["o hull", "f", "f", "o turret", "f"],
    ["f", "o hull", "f", "f", "o turret", "f"],  # faces before the first object: "default"
    ["f", "g a", "f", "g b", "f", "g a", "f"],  # groups, a repeated one
    ["g a", "f", "o hull", "f", "g b", "f"],  # objects win over groups
    ["f", "f", "o late"],  # an object after the last face: none has a part
    ["f", "o late", "g x"],  # ... then the groups (also after it)
    ["g a", "f", "o late"],  # ... the groups then
    ["o ", "f", "o   spaced name  ", "f", "o default", "f"],  # empty name, blanks, explicit default
    ["f", "o default", "f", "o other", "f"],  # the unnamed faces join an explicit default
    ["o hull", "o turret", "f", "o hull", "f"],  # an object without faces
    ["o кузов", "f", "g ärmel ", "f", "o 車体", "f"],  # UTF-8 names
])
def test_objects_and_groups_as_parts(marks):
    faces = iter(["f 1 2 5", "f 1 5 4", "f 2 3 6", "f 2 6 5", "f 4 5 8", "f 4 8 7"] * 3)
    body = GRID_V + "\n".join(next(faces) if m == "f" else m for m in marks) + "\n"
    assert_compiled_is_both(body.encode())


def test_many_parts_labels_from_the_marks():
    rng = np.random.default_rng(5)
    vertices, faces = random_mesh(rng, n=50, m=2000)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices]
    for k, (a, b, c) in enumerate(faces):
        if rng.random() < 0.05:
            lines.append(f"{'og'[int(rng.integers(2))]} part{int(rng.integers(8))}")
        lines.append(f"f {a + 1} {b + 1} {c + 1}")
    assert_compiled_is_both(("\n".join(lines) + "\n").encode())


def test_non_ascii_in_comments_and_names_only():
    body = "# créé par Blender — ünïcode 😀\n" + GRID_V + "o corps\u00a0\nf 1 2 5\nusemtl herbe_été\n"
    fast = assert_compiled_is_both(body.encode())
    assert fast.part_names == ("corps",)  # str.strip() of the name: the no-break space goes too


def test_bom_and_the_inputs_it_takes():
    data = obj_text(*random_mesh(np.random.default_rng(2), n=10, m=10)).encode()
    base = scan_obj(data, POW10)
    assert base is not None
    for buf in (bytearray(data), memoryview(data), np.frombuffer(data, np.uint8), list(data)):
        other = scan_obj(buf, list(POW10))
        assert other is not None and np.array_equal(other[0], base[0]) and np.array_equal(other[1], base[1])
    assert scan_obj(b"", POW10) is None
    assert_same_mesh(read_obj(b"\xef\xbb\xbf" + data, "m.obj"), compiled_obj(data))


def test_number_forms_are_float_bits():
    cells = ["0", "-0", "-0.0", "+0e5", "0e999", "1e22", "1e-22", "123456789012345", "0.123456789012345",
             "123456789012345e-22", "500123.4567", "-4500987.123456", ".5", "5.", "1E+05", "2e-0", "007.25",
             "0" * 40 + "1.5", "0.000000000000000000001", "-.75e+3"]
    for cell in cells:
        data = f"v {cell} {cell} 1\nf 1 1 1\n".encode()
        scanned = scan_obj(data, POW10)
        if cell == "0e999":  # an exponent past 400 even on a zero (as the CSV parser)
            assert scanned is None
            continue
        assert scanned is not None, cell
        assert scanned[0][0].view(np.uint64).tolist() == np.array([float(cell)] * 2 + [1.0]).view(np.uint64).tolist()
        assert_compiled_is_both(data)


@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-1e9, max_value=1e9),
       st.sampled_from(["%.6f", "%.3f", "%.15g", "%.14e", "%.10g", "%r", "%.16g", "%.17g"]))
def test_fast_path_numbers_are_float_bits_or_declined(value, fmt):
    cell = repr(value) if fmt == "%r" else fmt % value
    data = f"v {cell} 1 2\nf 1 1 1\n".encode()
    scanned = scan_obj(data, POW10)
    if scanned is None:
        digits = cell.lower().split("e")[0].lstrip("+-").replace(".", "").lstrip("0")
        assert len(digits) > 15 or "e" in cell.lower()
        return
    assert scanned[0][0, 0].view(np.uint64) == np.float64(float(cell)).view(np.uint64)


# --- what it declines: read_obj as before ------------------------------------------------

DECLINED = [
    "f 1 2 5 4",  # a quad
    "f 1 2",  # a short face
    "f -1 -2 -3",  # relative indices
    "f 0 1 2",
    "f 1 x 3",
    "f +1 2 3",
    "f 1.0 2 3",
    "f 1 2 3/3",  # slashes after a first face line without them (as simple_obj)
    "v 1 2 3 1",  # a weight
    "v 1 2 3 0.5 0.5 0.5",  # colours
    "v 1 2",
    "v 1 2 inf",
    "v 1 2 nan",
    "v 1 two 3",
    "v 1,5 2 3",
    "v 1 2 3.000000000000001",  # 16 digits
    "v 1 2 1e23",
    "v 1 2 1_0",
    "v\t1 2 3",  # a tab after the keyword
    "f\t1 2 3",
    "  f 1 2 3",  # leading blanks
    " # comment",
    "g",  # a bare g
    "o",
    "vx 1",  # unknown keywords
    "curv 0 1 1 2",
    "cstype bezier",
    "S 1",
    "v 1 2 \\\n3",  # a continuation line
    "# a comment \\",
    "l 1 2 \\\n3",
    "f 1 2 5\rf 1 5 4",  # a lone CR
    "# one\x0bline",  # a vertical tab: a line break to splitlines
    "# form\x0cfeed",
    "# sep\x1ehere",
    "# next\u0085line",
    "# para\u2029graph",
    "o line\u2028sep",
    "v 1 2 3\u00a0",  # non-ASCII in a vertex line
    "f 1 2 3\x1f",
    "\u00a0",  # a no-break space alone
]


@pytest.mark.parametrize("line", DECLINED)
def test_declined_lines_read_as_before(line):
    body = GRID_V + "f 1 2 5\n" + line + "\nf 1 5 4\n"
    assert_declined_unchanged(body.encode())
    # with CRLF ends, and as the first face line too
    assert_declined_unchanged(body.replace("\n", "\r\n").encode())
    first = (GRID_V + line + "\nf 1 5 4\n").encode()
    if line == "f 1 2 3/3":  # slashes in the first face line: slashes are read in all of them
        assert_compiled_is_both(first)
    else:
        assert_declined_unchanged(first)


@pytest.mark.parametrize("data", [
    GRID_V.encode() + b"f 1 2 5\n# \xff\xfe broken\n",  # not UTF-8
    GRID_V.encode() + b"f 1 2 5\no \xc0\xaf\n",  # an overlong form
    GRID_V.encode() + b"f 1 2 5\n# \xed\xa0\x80 surrogate\n",
    GRID_V.encode() + b"f 1 2 5\n# \xf4\x90\x80\x80 past U+10FFFF\n",
    GRID_V.encode() + b"f 1 2 5\n# cut \xe2\x82\n",
    GRID_V.encode() + b"f 1 2 5\nv 1 2 3\xc3\xa9\n",
    b"\xef\xbb\xbf\xef\xbb\xbf" + GRID_V.encode() + b"f 1 2 5\n",  # a second byte-order mark
    GRID_V.encode(),  # no faces
    b"f 1 2 3\n",  # no vertices
    b"# nothing\n",
    GRID_V.encode() + b"f 1 2 5\r",  # a final lone CR
    GRID_V.encode() + b"f 1 2 5\r\r\n",
    GRID_V.encode() + b"f 1 2 5\n\x00\n",
])
def test_declined_files_read_as_before(data):
    assert_declined_unchanged(data)


def test_index_past_the_last_vertex_is_declined(tmp_path):
    body = GRID_V + "f 1 2 5\nf 1 2 10\n"
    assert_declined_unchanged(body.encode())
    path = tmp_path / "bad.obj"
    path.write_text(body)
    with pytest.raises(InputError, match="out of range"):
        read_terrain(str(path))
    # the last vertex itself is fine, also when it comes after the face
    assert_compiled_is_both((GRID_V + "f 1 2 10\nv 5 5 5\n").encode())


def test_digits_of_huge_indices_do_not_overflow():
    assert scan_obj((GRID_V + "f 1 2 " + "9" * 30 + "\n").encode(), POW10) is None
    assert scan_obj((GRID_V + "f 1 2 18446744073709551617\n").encode(), POW10) is None


# --- random files: taken means the same as both readers, declined means as before --------

STATEMENT = st.one_of(
    st.tuples(st.integers(1, 9), st.integers(1, 9), st.integers(1, 9),
              st.sampled_from(["{}", "{}/1", "{}//2", "{}/3/4"])).map(
        lambda t: "f " + " ".join(t[3].format(i) for i in t[:3])),
    st.tuples(st.floats(-1e6, 1e6, allow_nan=False), st.floats(-1e3, 1e3, allow_nan=False),
              st.sampled_from(["%.6f", "%.2f", "%r", "%.15g"])).map(
        lambda t: "v " + " ".join(repr(x) if t[2] == "%r" else t[2] % x for x in (t[0], t[1], t[0] - t[1]))),
    st.sampled_from(["o hull", "o turret", "o", "o ", "g wheels", "g hull", "g", "l 1 2", "p 3", "# comment",
                     "usemtl a", "mtllib a.mtl", "s 1", "vt 0 0", "vn 0 0 1", "", "  ", "\t", "f 1 2", "f 1 2 3 4",
                     "f -1 -2 -3", "v 1 2 3 4", "v\t1 2 3", " f 1 2 3", "x 1", "# é", "o é", "# tail \\"]),
)


@settings(max_examples=400, deadline=None)
@given(st.lists(STATEMENT, max_size=30), st.sampled_from(["\n", "\r\n"]), st.booleans())
def test_random_files_taken_alike_or_declined_alike(statements, eol, final_eol):
    data = (eol.join(GRID_V.splitlines() + statements) + (eol if final_eol else "")).encode()
    fast = compiled_obj(data)
    if fast is None:
        assert_declined_unchanged(data)
    else:
        assert_compiled_is_both(data)
