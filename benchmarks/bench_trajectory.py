"""Benchmark: reading trajectories, the reader before entities (``numeric_chunks`` over text lines) against
``read_trajectory`` (bytes in blocks through the compiled row pass), on the same files.

    python benchmarks/bench_trajectory.py [--rows 1000000] [--entities 1000] [--rounds 5]
                                          [--out benchmarks/results/trajectory.md]

Writes, in a temporary directory, CSVs of ROWS rows:

- ``plain``: ``t,x,y,yaw_deg`` (one vehicle), the shape replay read before;
- ``entity``: ``t,entity,x,y,yaw_deg``, ENTITIES vehicles interleaved (the former reader reads it too:
  the entity column is an extra column to it, ignored);
- ``iso``: ``plain`` with ISO 8601 times (``2026-05-04T10:00:00.25Z``) in ``t``;
- ``geographic``: ``t,entity,lon,lat,heading_deg``, converted to UTM zone 32N (pyproj);

and a DIS capture of the same rows (``bench_dis.write_capture``), then reads each in a fresh process,
rounds alternating the readers; a run reads the whole file once (every chunk of 65,536 rows). The
ratio of two readers is taken round by round (the same moment of the machine) and its median
reported with its spread; peak memory is the process's peak resident set (VmHWM).

"Before" is the reader as it was (``tankcd_cli.io.csv_columns.numeric_chunks``, unchanged, over the
file's text lines, then the time check and the chunk): the same code path, kept here.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)

from _report import save_report  # noqa: E402


def write_files(folder: str, rows: int, entities: int) -> dict:
    rng = np.random.default_rng(7)
    k = np.arange(rows)
    tank = k % entities
    t = (k // entities) * 0.5 + tank * (0.4 / entities)
    x = 500_000 + rng.uniform(0, 2000, rows)
    y = 5_540_000 + rng.uniform(0, 2000, rows)
    yaw = rng.uniform(-180, 180, rows)
    names = np.array([f"tank{j:04d}" for j in range(entities)])
    paths = {}

    def write(name, header, columns, fmts):
        path = os.path.join(folder, f"{name}.csv")
        with open(path, "w") as fh:
            fh.write(header + "\n")
            step = 100_000
            for a in range(0, rows, step):
                sl = slice(a, a + step)
                cols = [np.char.mod(f, c[sl]) if f else c[sl] for c, f in zip(columns, fmts)]
                fh.write("\n".join(",".join(r) for r in zip(*cols)) + "\n")
        paths[name] = path

    tp = np.arange(rows) * 0.1
    write("plain", "t,x,y,yaw_deg", [tp, x, y, yaw], ["%.1f", "%.3f", "%.3f", "%.2f"])
    write("entity", "t,entity,x,y,yaw_deg", [t, names[tank], x, y, yaw], ["%.4f", None, "%.3f", "%.3f", "%.2f"])
    base = np.datetime64("2026-05-04T10:00:00", "ms")
    iso = np.char.add(np.datetime_as_string(base + (tp * 1000).astype("timedelta64[ms]"), unit="ms"), "Z")
    write("iso", "t,x,y,yaw_deg", [iso, x, y, yaw], [None, "%.3f", "%.3f", "%.2f"])
    lon = 9 + rng.uniform(-0.01, 0.01, rows)
    lat = 50 + rng.uniform(-0.01, 0.01, rows)
    write("geographic", "t,entity,lon,lat,heading_deg", [t, names[tank], lon, lat, np.mod(yaw, 360)],
          ["%.4f", None, "%.7f", "%.7f", "%.2f"])
    from bench_dis import write_capture

    cap = os.path.join(folder, "capture.pcap")
    write_capture(cap, entities, 2.0, rows / entities / 2.0)
    paths["capture"] = cap
    return paths


def before(path: str):
    """The reader before entities, as it was: numeric_chunks over text lines, the time check, the chunk."""
    from tankcd_cli.errors import InputError
    from tankcd_cli.io.csv_columns import numeric_chunks
    from tankcd_cli.io.files import open_input
    from tankcd_cli.io.trajectory import OPTIONAL, REQUIRED, TrajectoryChunk

    name, fh = open_input(path, text=True)
    step, last_t = 0, -np.inf
    with fh:
        for rows, wanted, values in numeric_chunks(fh, name, REQUIRED, OPTIONAL, 65536):
            t = values[:, 0]
            if (np.diff(np.concatenate([[last_t], t])) < 0).any():
                raise InputError(name, "time goes back")
            last_t = t[-1]
            n = len(t)
            yield TrajectoryChunk(np.arange(step, step + n), rows[0], t, values[:, 1], values[:, 2], values[:, 3],
                                  np.zeros(n), np.zeros(n), False, np.asarray(rows))
            step += n


def peak_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def child(reader: str, path: str) -> dict:
    import pyproj

    from tankcd_cli.io.trajectory import read_trajectory

    crs = pyproj.CRS.from_epsg(32632).to_wkt()
    if reader == "new":  # pyproj's start-up (and the first chunk's page faults) outside the time
        next(iter(read_trajectory(path, chunk_rows=16, crs=crs)), None)
    t0 = time.perf_counter()
    chunks = before(path) if reader == "before" else read_trajectory(path, crs=crs)
    rows = sum(len(c) for c in chunks)
    return {"rows": rows, "seconds": time.perf_counter() - t0, "peak_mb": peak_mb()}


def run_child(reader: str, path: str) -> dict:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.dirname(HERE), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", reader, path], env=env,
                          capture_output=True, text=True)
    if proc.returncode:
        raise SystemExit(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


CASES = [  # (label, file, reader)
    ("before, `t,x,y,yaw_deg`", "plain", "before"),
    ("now, `t,x,y,yaw_deg`", "plain", "new"),
    ("before, `t,entity,x,y,yaw_deg` (entity ignored)", "entity", "before"),
    ("now, `t,entity,x,y,yaw_deg` (the entities coded, each one's time checked)", "entity", "new"),
    ("now, `t,x,y,yaw_deg` with ISO 8601 times", "iso", "new"),
    ("now, `t,entity,lon,lat,heading_deg` to UTM 32N", "geographic", "new"),
    ("now, the same rows as a DIS capture (ECEF to UTM 32N)", "capture", "new"),
]


def entity_codes_compared(rows: int, entities: int, rounds: int = 3) -> dict:
    """Codes of ROWS entity ids (spans in a text) two ways: the compiled interner (the reader's), and numpy byte
    operations (the ids gathered into a fixed-width byte matrix, ``np.unique(..., return_inverse=True)``),
    in chunks of 65,536 rows. Best of ``rounds``, seconds."""
    from tankcd_cli.io._csv_kernels import Interner

    names = [f"tank{j:04d}".encode() for j in range(entities)]
    pick = np.arange(rows) % entities
    text = b",".join(names[k] for k in pick.tolist())
    buf = np.frombuffer(text, np.uint8)
    lens = np.array([len(n) for n in names])[pick]
    ends = np.cumsum(lens + 1) - 1
    span = np.column_stack([ends - lens, ends]).astype(np.int64)
    best = {"interner": np.inf, "numpy": np.inf}
    for _ in range(rounds):
        t0 = time.perf_counter()
        interner = Interner()
        for a in range(0, rows, 65536):
            interner.codes(buf, np.ascontiguousarray(span[a:a + 65536]), min(65536, rows - a))
        best["interner"] = min(best["interner"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        table: dict = {}
        for a in range(0, rows, 65536):
            sp = span[a:a + 65536]
            width = int((sp[:, 1] - sp[:, 0]).max())
            idx = sp[:, :1] + np.arange(width)
            cells = np.where(idx < sp[:, 1:], buf[np.minimum(idx, len(buf) - 1)], 0).astype(np.uint8)
            keys = cells.view(f"S{width}").reshape(-1)
            unique, inverse = np.unique(keys, return_inverse=True)
            codes = np.array([table.setdefault(u, len(table)) for u in unique.tolist()])[inverse]
        best["numpy"] = min(best["numpy"], time.perf_counter() - t0)
        del codes
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--entities", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "trajectory.md"))
    ap.add_argument("--child", nargs=2)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(*args.child)))
        return
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        paths = write_files(folder, args.rows, args.entities)
        written = time.perf_counter() - t0
        sizes = {k: os.path.getsize(p) / 1e6 for k, p in paths.items()}
        runs = {label: [] for label, _, _ in CASES}
        for _ in range(args.rounds):
            for label, key, reader in CASES:
                runs[label].append(run_child(reader, paths[key]))
    best = {label: min(r["seconds"] for r in rs) for label, rs in runs.items()}
    secs = {label: [r["seconds"] for r in rs] for label, rs in runs.items()}
    base = secs[CASES[0][0]]

    def ratio(label, against=CASES[0][0]):
        r = np.array(secs[label]) / np.array(secs[against])
        return float(np.median(r)), float(r.min()), float(r.max())

    cmd = (f"python benchmarks/bench_trajectory.py --rows {args.rows} --entities {args.entities} "
           f"--rounds {args.rounds}")
    lines = [
        "# Benchmark: reading trajectories", "", f"`{cmd}`", "",
        f"{args.rows:,} rows per file ({args.entities:,} entities interleaved where there are entities; files "
        f"written in {written:.1f} s: " + ", ".join(f"{k} {v:.0f} MB" for k, v in sizes.items()) + "). "
        f"{os.cpu_count()} cores shared with other work; Python {platform.python_version()}, numpy {np.__version__}.",
        "Each run a fresh process reading the whole file once in chunks of 65,536 rows; rounds alternate the "
        f"readers ({args.rounds} rounds). Ratios against the first row, round by round: median (min-max).", "",
        "| reader, file | rows | best s | runs s | x before (4 columns) | peak memory |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for label, _, _ in CASES:
        rs = runs[label]
        med, lo, hi = ratio(label)
        lines.append(f"| {label} | {rs[0]['rows']:,} | {best[label]:.3f} | "
                     + ", ".join(f"{s:.3f}" for s in secs[label])
                     + f" | {med:.2f} ({lo:.2f}-{hi:.2f}) | {max(r['peak_mb'] for r in rs):.0f} MB |")
    ent_med, ent_lo, ent_hi = ratio(CASES[3][0])
    lines += ["", f"The 5-column file with entities against today's 4-column reading: {ent_med:.2f}x "
                  f"({ent_lo:.2f}-{ent_hi:.2f}; target at most 1.5x). "
                  f"Against the former reader on the same 5-column file: "
              f"{ratio(CASES[3][0], CASES[2][0])[0]:.2f}x.", ""]
    del base
    codes = entity_codes_compared(args.rows, args.entities)
    lines += [f"Why the entity ids are coded in the compiled pass: codes for the same {args.rows:,} ids "
              f"({args.entities:,} names) in chunks of 65,536 take {codes['interner']:.3f} s through the compiled "
              f"interner (a hash table in C) and {codes['numpy']:.3f} s with numpy byte operations (the ids "
              "gathered into a fixed-width byte matrix, `np.unique(..., return_inverse=True)`); best of 3, "
              "in this process.", ""]
    save_report("\n".join(lines), args.out)


if __name__ == "__main__":
    main()
