"""Every hard terrain through the public commands: classify, info, replay."""

import json

import h5py
import numpy as np
import pytest

from tests.hard_cases.terrains import CASES


def _trajectory(path, lo, hi, rows=60):
    """A drive across the terrain's box and a little beyond it (the last rows are off the terrain)."""
    t = np.arange(rows) * 0.1
    x = np.linspace(lo[0] - 2, hi[0] + 6, rows)
    y = np.linspace(lo[1] + 0.3 * (hi[1] - lo[1]), lo[1] + 0.6 * (hi[1] - lo[1]), rows)
    yaw = np.linspace(-180.0, 180.0, rows)  # every heading, both ends of the wrap included
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        for row in zip(t, x, y, yaw):
            fh.write(",".join(repr(float(v)) for v in row) + "\n")
    return path


def _store_arrays(store):
    """H and classes at every vertex or valid post, and the x, y extent, for either layout."""
    with h5py.File(store) as h5:
        if h5.attrs["layout"] == "grid":
            h = h5["grid/height"]
            valid = np.isfinite(h[:])
            rows, cols = h.shape
            dx, dy = h.attrs["spacing"]
            lo = np.array([h.attrs["origin_x"], h.attrs["origin_y"] - (rows - 1) * dy])
            hi = lo + [(cols - 1) * dx, (rows - 1) * dy]
            assert not np.isfinite(h5["curvature/mean"][:][~valid]).any()
            assert (h5["classes/grid"][:][~valid] == 255).all()
            return h5["curvature/mean"][:][valid], h5["classes/grid"][:][valid], lo, hi
        V = h5["mesh/vertices"][:]
        return h5["curvature/mean"][:], h5["classes/vertex"][:], V[:, :2].min(axis=0), V[:, :2].max(axis=0)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_hard_terrain(case, run, tmp_path):
    src = case.write(tmp_path)
    up = ["--up", "y"] if case.name == "y_up" else []
    store = tmp_path / f"{case.name}.h5"
    res = run("classify", src, "-o", store, *up)
    if case.expect == "rejected":
        assert res.exit_code == 3, (case.why, res.output)
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and str(src) in lines[0], res.stderr
        assert not store.exists()
        return
    assert res.exit_code == 0, (case.why, res.stderr)
    H, classes, lo, hi = _store_arrays(store)
    assert np.isfinite(H).all(), case.why
    assert set(np.unique(classes)) <= {0, 1, 2}
    if case.name in ("exactly_flat",):
        assert np.abs(H).max() == 0.0 and (classes == 0).all()
    if case.name == "flipped":  # winding does not flip the sign: the ridge-free bumps keep H of both signs
        assert (H > 0).any() and (H < 0).any()
    info = run("info", store, "--json")
    assert info.exit_code == 0 and json.loads(info.stdout)

    traj = _trajectory(tmp_path / "t.csv", lo, hi)
    res = run("replay", traj, "--terrain", store, "--events", tmp_path / "e.jsonl")
    assert res.exit_code == 0, res.stderr
    lines = res.stdout.strip().splitlines()
    assert len(lines) == 61  # header + one pose row for every trajectory row
    header = lines[0].split(",")
    for line in lines[1:]:
        cells = dict(zip(header, line.split(",")))
        assert cells["status"] in ("ok", "partly_off", "off")
        for name, text in cells.items():
            if name in ("region", "matcher", "status") or text == "":
                continue
            assert np.isfinite(float(text)), (name, line)
        if cells["status"] != "off":
            assert cells["z"] != "" and cells["qw"] != ""
    assert lines[-1].endswith(",off")  # the drive ends beyond the terrain
