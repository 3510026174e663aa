"""Every malformed-file shape for every format the tool reads: exit 3, one line naming the file,
nothing left at the output path; or, for shapes that are still valid (BOM, CRLF), a normal run."""

import os

import numpy as np
import pytest

from tests.hard_cases import inputs

GARBAGE = np.random.default_rng(7).integers(0, 256, 700, dtype=np.uint8).tobytes()


def _break(text: str, shape: str, fmt: str) -> bytes | None:
    lines = text.splitlines(keepends=True)
    if shape == "empty":
        return b""
    if shape == "blank":
        return b"\n\n  \n"
    if shape == "truncated":  # cut in the middle of a line
        cut = len(text) // 2
        while text[cut - 1] in "\n,":
            cut += 1
        return text[:cut].encode()
    if shape == "wrong_header":
        first = {"asc": ("ncols", "ncolz"), "obj": ("v ", "vx "), "trajectory": ("yaw_deg", "heading"),
                 "poses": (",z,", ",zz,"), "scene": ("[terrain]", "[terain]")}[fmt]
        return text.replace(*first, 1).encode()
    if shape == "wrong_column_count":
        k = len(lines) // 2
        if fmt == "scene":
            return text.replace('preset = "t72"', 'preset = "t72", "m1"').encode()
        sep = " " if fmt in ("asc", "obj") else ","
        if fmt == "obj":  # a vertex line: a face of two indices is valid OBJ (skipped and counted)
            k = max(i for i, line in enumerate(lines) if line.startswith("v "))
        cells = lines[k].rstrip("\n").split(sep)
        lines[k] = sep.join(cells[:-1]) + "\n"
        return "".join(lines).encode()
    if shape in ("nan", "inf", "-inf"):
        if fmt == "scene":
            return text.replace('preset = "t72"', f'preset = "t72"\ntrack_length = {shape}').encode()
        k = len(lines) // 2
        sep = " " if fmt in ("asc", "obj") else ","
        if fmt == "obj":  # a vertex line: a face of two indices is valid OBJ (skipped and counted)
            k = max(i for i, line in enumerate(lines) if line.startswith("v "))
        cells = lines[k].rstrip("\n").split(sep)
        cells[-2] = shape
        lines[k] = sep.join(cells) + "\n"
        return "".join(lines).encode()
    if shape == "bom":
        return "\ufeff".encode() + text.encode()
    if shape == "crlf":
        return text.replace("\n", "\r\n").encode()
    if shape == "binary":
        return GARBAGE
    if shape == "not_utf8":
        return b"\xff\xfe\xfa" + text.encode("utf-16")
    if shape == "nul_bytes":
        return text[:40].encode() + b"\x00" * 64 + text[40:].encode()
    return None


TEXT_FORMATS = ["asc", "obj", "trajectory", "poses", "scene"]
SHAPES = {"empty": {3}, "blank": {3}, "truncated": {0, 3}, "wrong_header": {3}, "wrong_column_count": {3},
          "nan": {3}, "inf": {3}, "-inf": {3}, "bom": {0}, "crlf": {0}, "binary": {3}, "not_utf8": {3},
          "nul_bytes": {3}}


@pytest.fixture
def files(tmp_path, run):
    return inputs.setup(tmp_path, run)


def _text_of(fmt, paths):
    if fmt == "scene":
        return paths["scene"].read_text()
    return inputs.VALID[fmt][1]


def _check(run, fmt, bad, paths, out, allowed):
    res = run(*inputs.command(fmt, bad, paths, out))
    assert res.exit_code in allowed, (fmt, res.exit_code, res.stderr)
    assert "internal error" not in res.stderr and "Traceback" not in res.stderr
    if res.exit_code == 3:
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1, res.stderr
        assert os.path.basename(str(bad)) in lines[0], lines[0]
        assert not os.path.exists(out)
    return res


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("fmt", TEXT_FORMATS)
def test_malformed_text_file(fmt, shape, files, run, tmp_path):
    data = _break(_text_of(fmt, files), shape, fmt)
    suffix = {"asc": ".asc", "obj": ".obj", "trajectory": ".csv", "poses": ".csv", "scene": ".toml"}[fmt]
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(data)
    _check(run, fmt, bad, files, tmp_path / "out.part-test", SHAPES[shape])


@pytest.mark.parametrize("fmt", TEXT_FORMATS + ["store", "tree"])
def test_a_directory_instead_of_a_file(fmt, files, run, tmp_path):
    d = tmp_path / f"dir.{ {'asc': 'asc', 'obj': 'obj', 'scene': 'toml', 'store': 'h5', 'tree': 'h5'}.get(fmt, 'csv')}"
    d.mkdir()
    _check(run, fmt, d, files, tmp_path / "out.x", {3})


@pytest.mark.parametrize("fmt", TEXT_FORMATS + ["store", "tree"])
def test_a_missing_file(fmt, files, run, tmp_path):
    _check(run, fmt, tmp_path / "nope.h5", files, tmp_path / "out.x", {3})


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads files whatever their permissions")
@pytest.mark.parametrize("fmt", TEXT_FORMATS)
def test_no_permission(fmt, files, run, tmp_path):
    bad = tmp_path / f"locked.{fmt}"
    bad.write_text(_text_of(fmt, files))
    bad.chmod(0)
    _check(run, fmt, bad, files, tmp_path / "out.x", {3})


@pytest.mark.parametrize("shape", ["empty", "truncated", "binary", "text", "other_kind"])
@pytest.mark.parametrize("fmt", ["store", "tree"])
def test_malformed_hdf5(fmt, shape, files, run, tmp_path):
    good = files[fmt].read_bytes()
    data = {"empty": b"", "truncated": good[: len(good) // 2], "binary": GARBAGE, "text": b"hello\n",
            "other_kind": None}[shape]
    bad = tmp_path / "bad.h5"
    if data is None:
        import h5py

        with h5py.File(bad, "w") as h5:
            h5["something"] = np.arange(3)
    else:
        bad.write_bytes(data)
    _check(run, fmt, bad, files, tmp_path / "out.x", {3})
    # the same file where a terrain is expected
    res = run("replay", files["trajectory"], "--terrain", bad, "--poses", tmp_path / "p.csv")
    assert res.exit_code == 3 and len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert not (tmp_path / "p.csv").exists()


# --- regressions: crashes the fuzzer found (each was an internal error, exit 4) ----------------

@pytest.mark.parametrize("fmt, text", [
    ("obj", inputs.OBJ.replace("f 1 2 8", "f 1 2 " + "9" * 40)),  # an index beyond int64
    ("obj", inputs.OBJ.replace("v 4.0 0.0", "v 4.0 -0.1e309", 1)),  # finite, but beyond any terrain
    ("asc", inputs.ASC.replace("100.000", "1e300", 1)),
    ("trajectory", inputs.TRAJECTORY.replace("t,x", "t\x0bx", 1)),  # a control character in the message
])
def test_fuzzer_regressions_text(fmt, text, files, run, tmp_path):
    bad = tmp_path / ("bad." + {"trajectory": "csv"}.get(fmt, fmt))
    bad.write_text(text)
    _check(run, fmt, bad, files, tmp_path / "out.x", {3})


def test_store_with_undecodable_attribute_text(files, run, tmp_path):
    import shutil

    import h5py

    bad = tmp_path / "odd.h5"
    shutil.copy(files["store"], bad)
    with h5py.File(bad, "a") as h5:
        h5.attrs["source"] = np.bytes_(b"\xff\xfe/terrain\x0b.asc")
    res = run("info", bad)
    # the store is whole: it is described, the odd text shown with its control characters escaped
    assert res.exit_code == 0, res.stderr
    source = [line for line in res.stdout.splitlines() if line.startswith("source:")]
    assert len(source) == 1 and "/terrain\\x0b.asc" in source[0] and "\x0b" not in source[0]
    assert len(res.stdout.splitlines()) > 5


@pytest.mark.parametrize("fmt", ["store", "tree"])
def test_hdf5_truncated_anywhere(fmt, files, run, tmp_path):
    good = files[fmt].read_bytes()
    for k in range(1, 16):
        bad = tmp_path / f"cut{k}.h5"
        bad.write_bytes(good[: len(good) * k // 16])
        _check(run, fmt, bad, files, tmp_path / "out.x", {3})
