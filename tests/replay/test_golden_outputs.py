"""Replay outputs pinned byte for byte: the sample scene (continuous and discrete, CSV, JSON Lines and
Parquet), an exercise of three vehicles in the order a logger wrote them (one piece and by windows), a
DIS capture, and a fleet. The summaries are pinned too, less their timings.

These pin what the outputs are, not that they are right (the other tests do that): a change of the code
that is not meant to change the outputs (a refactor) must leave these files as they are. A change that is
meant to change them regenerates them with ``TANKCD_UPDATE_GOLDEN=1 python -m pytest
tests/replay/test_golden_outputs.py`` and says why in its commit."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

SAMPLE = Path(__file__).resolve().parents[2] / "sample_data"
GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "outputs"
UPDATE = bool(os.environ.get("TANKCD_UPDATE_GOLDEN"))


def _without_timings(value):
    """A summary less what the clock and the machine decide (seconds, rates, memory, processes)."""
    if isinstance(value, dict):
        return {k: _without_timings(v) for k, v in value.items()
                if not ("seconds" in k or k in ("peak_rss_mb", "rows_per_second", "pid", "worker", "jobs", "workers", "ran_on"))}
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


def _check(case: str, files: dict[str, bytes]):
    """Each output's bytes against tests/golden/outputs/CASE/NAME (written there under UPDATE)."""
    folder = GOLDEN / case
    if UPDATE:
        folder.mkdir(parents=True, exist_ok=True)
        for old in folder.iterdir():
            old.unlink()
        for name, data in files.items():
            (folder / name).write_bytes(data)
    pinned = sorted(p.name for p in folder.iterdir())
    assert sorted(files) == pinned, f"{case}: outputs {sorted(files)} against pinned {pinned}"
    for name, data in files.items():
        want = (folder / name).read_bytes()
        if name.endswith(".parquet") and data != want:
            _same_table(f"{case}/{name}", data, want)
            continue
        assert data == want, f"{case}/{name}: {len(data)} bytes differ from the pinned {len(want)}"


def _same_table(label: str, data: bytes, want: bytes):
    """A Parquet file against its pinned copy: the same schema, metadata, exact columns and floats to
    1e-9 relative. A Parquet file keeps every double's last bit, which another build of the kernels
    (another compiler or libm) may move; the CSV, written to fixed decimals, stays byte for byte."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    got, pinned = pq.read_table(pa.BufferReader(data)), pq.read_table(pa.BufferReader(want))
    assert got.schema.equals(pinned.schema, check_metadata=True), f"{label}: schema or metadata differ"
    assert got.num_rows == pinned.num_rows, f"{label}: {got.num_rows} rows against {pinned.num_rows}"
    for name in got.column_names:
        a, b = got.column(name).to_numpy(zero_copy_only=False), pinned.column(name).to_numpy(zero_copy_only=False)
        if a.dtype.kind == "f":
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12, equal_nan=True, err_msg=f"{label}: {name}")
        else:
            assert np.array_equal(a, b), f"{label}: column {name} differs"


def _summary_bytes(path: Path) -> bytes:
    summary = _without_timings(json.loads(path.read_text()))
    return (json.dumps(summary, indent=1, sort_keys=True) + "\n").encode()


def _exercise_csv(path: Path):
    """Three tanks on the sample patrol, the rows grouped by vehicle as a logger writes them: 'lead' drives
    the patrol, 'close' follows 3 s later 2.5 m to its left (the two touch), 'back' drives it backwards."""
    rows = np.genfromtxt(SAMPLE / "patrol.csv", delimiter=",", names=True)[:500]
    lines = ["t,entity,x,y,yaw_deg,turret_deg,gun_deg"]
    t, x, y, yaw = rows["t"], rows["x"], rows["y"], rows["yaw_deg"]
    left = np.radians(yaw + 90.0)
    tracks = {"lead": (t, x, y, yaw),
              "close": (t + 3.0, x + 2.5 * np.cos(left), y + 2.5 * np.sin(left), yaw),
              "back": (t, x[::-1], y[::-1], yaw[::-1] + 180.0)}
    for name, (tt, xx, yy, hh) in tracks.items():
        for k in range(len(tt)):
            lines.append(f"{tt[k]:.2f},{name},{xx[k]:.3f},{yy[k]:.3f},{hh[k]:.3f},"
                         f"{rows['turret_deg'][k]:.2f},{rows['gun_deg'][k]:.2f}")
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def scene_dir():
    """The sample scene and the golden inputs in one folder, at the same path on every run: Parquet's
    metadata and fleet.json name their sources by absolute path."""
    folder = Path(tempfile.gettempdir()) / "tankcd-golden-outputs"
    # one run at a time holds the folder (two checkouts tested at once would share it)
    with open(str(folder) + ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir()
        for p in SAMPLE.iterdir():
            if p.suffix in (".asc", ".obj", ".toml", ".csv"):
                (folder / p.name).write_bytes(p.read_bytes())
        _exercise_csv(folder / "exercise.csv")
        yield folder
        shutil.rmtree(folder, ignore_errors=True)


def _replay(run, *args):
    done = run("-q", "replay", *args)
    assert done.exit_code == 0, done.stderr
    return done


@pytest.mark.parametrize("mode", ["continuous", "discrete"])
def test_the_sample_scene(run, scene_dir, mode, monkeypatch):
    monkeypatch.chdir(scene_dir)
    out = scene_dir / f"sample-{mode}"
    out.mkdir(exist_ok=True)
    flags = ["--discrete"] if mode == "discrete" else []
    _replay(run, "patrol.csv", "--scene", "scene.toml", "--poses", out / "poses.csv", "--events",
            out / "events.jsonl", "--summary", out / "summary.json", *flags)
    files = {"poses.csv": (out / "poses.csv").read_bytes(), "events.jsonl": (out / "events.jsonl").read_bytes(),
             "summary.json": _summary_bytes(out / "summary.json")}
    if mode == "continuous":
        pytest.importorskip("pyarrow")
        _replay(run, "patrol.csv", "--scene", "scene.toml", "--poses", out / "poses.parquet", "--events",
                out / "events.parquet")
        files["poses.parquet"] = (out / "poses.parquet").read_bytes()
        files["events.parquet"] = (out / "events.parquet").read_bytes()
    _check(f"sample-{mode}", files)


@pytest.mark.parametrize("mode", ["continuous", "discrete"])
def test_the_gates_change_no_pose_and_no_event(run, scene_dir, mode, monkeypatch):
    """With the gates off (--no-gates: the exact work everywhere) the sample scene and the
    exercise give the pinned poses and events (pinned before the gates), byte for byte."""
    monkeypatch.chdir(scene_dir)
    flags = ["--discrete"] if mode == "discrete" else []
    case = "sample-continuous" if mode == "continuous" else "sample-discrete"
    for name, inputs, pinned in (("sample", ["patrol.csv"], case), ("exercise", ["exercise.csv"], "exercise")):
        if name == "exercise" and mode == "discrete":
            continue
        out = scene_dir / f"no-gates-{name}-{mode}"
        out.mkdir(exist_ok=True)
        _replay(run, *inputs, "--scene", "scene.toml", "--poses", out / "poses.csv", "--events", out / "events.jsonl",
                "--no-gates", *flags)
        for f in ("poses.csv", "events.jsonl"):
            assert (out / f).read_bytes() == (GOLDEN / pinned / f).read_bytes(), f"{name} {mode} {f}"


def test_an_exercise_in_logger_order_in_one_piece_and_by_windows(run, scene_dir, monkeypatch):
    monkeypatch.chdir(scene_dir)
    files = {}
    for label, flags in (("", []), ("windows.", ["--window-seconds", "4"])):
        _replay(run, "exercise.csv", "--scene", "scene.toml", "--poses", f"{label}poses.csv", "--events",
                f"{label}events.jsonl", "--summary", f"{label}summary.json", *flags)
        files[f"{label}poses.csv"] = (scene_dir / f"{label}poses.csv").read_bytes()
        files[f"{label}events.jsonl"] = (scene_dir / f"{label}events.jsonl").read_bytes()
        files[f"{label}summary.json"] = _summary_bytes(scene_dir / f"{label}summary.json")
    assert files.pop("windows.poses.csv") == files["poses.csv"]
    assert files.pop("windows.events.jsonl") == files["events.jsonl"]
    assert b'"vehicle"' in files["events.jsonl"]
    _check("exercise", files)


def test_a_dis_capture(run, scene_dir, monkeypatch):
    pytest.importorskip("rasterio")
    from tests.cli.test_export import capture as capture_fixture

    tmp_path = scene_dir / "capture"
    tmp_path.mkdir()
    monkeypatch.chdir(tmp_path)
    path, _, tif = capture_fixture.__wrapped__(tmp_path)
    assert run("-q", "classify", tif, "-o", "ground.h5").exit_code == 0
    _replay(run, Path(path).name, "--terrain", "ground.h5", "--poses", "poses.csv", "--events", "events.jsonl",
            "--summary", "summary.json")
    _check("capture", {"poses.csv": (tmp_path / "poses.csv").read_bytes(),
                       "events.jsonl": (tmp_path / "events.jsonl").read_bytes(),
                       "summary.json": _summary_bytes(tmp_path / "summary.json")})


def test_a_fleet(run, scene_dir, monkeypatch):
    monkeypatch.chdir(scene_dir)
    lines = (scene_dir / "patrol.csv").read_text().splitlines()
    (scene_dir / "short.csv").write_text("\n".join(lines[:301]) + "\n")
    _replay(run, "patrol.csv", "short.csv", "exercise.csv", "--scene", "scene.toml", "--out-dir", "fleet",
            "--jobs", "2")
    out = scene_dir / "fleet"
    files = {p.name: p.read_bytes() for p in sorted(out.iterdir())
             if p.name != "fleet.json" and not p.name.startswith(".")}  # not the fleet's classified terrain
    files["fleet.json"] = _summary_bytes(out / "fleet.json")
    _check("fleet", files)
