"""Benchmark: `tankcd classify` and `tankcd replay` on large DEMs (grid layout), time and peak memory.

    python benchmarks/bench_grid.py [--work /tmp/gridbench] [--repeats 3] [--quick] [--size 6000]
                                    [--big 10000] [--with-numpy-100m] [--out benchmarks/results/grid.md]

Smoke run: `python benchmarks/bench_grid.py --quick --size 2000` (one DEM, one repeat).

Every measurement is a whole process (start-up, reading, computing, writing),
run through a small wrapper process that times it and reads its peak resident
memory (`getrusage(RUSAGE_CHILDREN).ru_maxrss`), so each run's peak is its own.
Times are medians of `--repeats` runs with the range (min-max); compared cases
run alternately (A B A B ...) and their ratio is taken per pair.

1. DEMs, generated once and cached in `--work`: tiled (256 x 256) float32
   GeoTIFFs in EPSG:32633 at 1 m posts, SIZE x SIZE (default 6000: 36M posts)
   and, unless `--quick`, BIG x BIG (default 10000: 100M posts), written by row
   blocks (never whole in memory): smooth rolling ground (tens of metres over
   km), mid-scale waves (0.3-0.6 m over 23-61 m), 2 cm Gaussian noise and a
   few circular NODATA holes (nodata -9999) away from the crop. The crop is a
   CROP x CROP (default 1000: 1M posts) window of the middle of the SIZE DEM:
   the same posts, written with the window's transform.
2. Classify the SIZE DEM: `tankcd classify` (default threads, then `--jobs 1`)
   against a whole-raster numpy peer (written into the work dir as
   `numpy_classify.py` and run as `python numpy_classify.py in.tif out.h5`):
   rasterio reads the whole band, mean curvature of the height field from
   np.gradient, classes by thresholds on |H| (no footprint average), h5py
   writes height, curvature and classes (chunked 256 x 256 as the store). The
   peer does less than tankcd (no footprint average, no one-sided fits at edges
   and holes, no overviews): its time is a floor for the same reading and
   writing, not the same result. The BIG DEM: tankcd only (the peer holds
   about 70 bytes a post in memory: 2.5 GB for 36M, 7 GB for 100M);
   `--with-numpy-100m` runs the peer there too.
3. Replay ROWS (default 1,000) rows of a wandering ~1 km path inside the crop
   (at least 100 m from its edges, so the same rows lie on both stores) on the
   SIZE store and on the crop's store, alternately; the ratio SIZE/crop and the
   peak memory show whether replay reads only the tiles it touches (targets:
   ratio <= 1.2, peak <= 300 MiB). The two pose files are compared.
4. Store sizes, bytes per post.
"""

from __future__ import annotations

import argparse
import datetime
import filecmp
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TANKCD = [sys.executable, "-m", "tankcd_cli", "-q"]
NODATA = -9999.0
WEST, NORTH = 400_000.0, 5_110_000.0  # north-west corner of every generated DEM (EPSG:32633, m)
GENERATOR = "gridbench-dem-v1"  # stored as a tag; a cached DEM with another tag is generated again
BLOCK = 256  # rows written at a time, and the GeoTIFF tile side
MARGIN = 100  # m: the replay path keeps this far from the crop's edges
MIB = 1024 * 1024

# Runs COMMAND... and prints one JSON line: exit code, wall seconds, CPU seconds and peak RSS
# (KiB on Linux) of that one command, the wrapper's own start-up and memory excluded.
WRAPPER = r"""
import json, resource, subprocess, sys, time
t = time.perf_counter()
p = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
wall = time.perf_counter() - t
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"rc": p.returncode, "seconds": wall, "cpu": ru.ru_utime + ru.ru_stime,
                  "maxrss_kib": ru.ru_maxrss, "stderr": p.stderr[-4000:]}))
"""

NUMPY_PEER = r'''"""Whole-raster peer of `tankcd classify` (grid method): python numpy_classify.py in.tif out.h5

Reads the whole band into memory, mean curvature of the height field by
np.gradient, classes by thresholds on |H| (no footprint average), then writes
height (float32), curvature (float32) and classes (uint8) with h5py.
"""
import sys

import h5py
import numpy as np
import rasterio

FLAT, UNEVEN = 0.0044, 0.022  # 1/m

src, dst = sys.argv[1], sys.argv[2]
with rasterio.Env(GDAL_CACHEMAX=64), rasterio.open(src) as ds:  # the cache tankcd uses
    z32 = ds.read(1)  # the whole band, float32
    nodata = ds.nodata
    dx, dy = ds.res
missing = np.isnan(z32)
if nodata is not None:
    missing |= z32 == nodata
z32[missing] = np.nan
z = z32.astype(np.float64)
# row 0 north: x = col dx (east), y = -row dy (north)
g_row, g_col = np.gradient(z, dy, dx)
fx, fy = g_col, -g_row
fxx = np.gradient(g_col, dx, axis=1)
fyy = np.gradient(g_row, dy, axis=0)
fxy = -np.gradient(g_row, dx, axis=1)
del z, g_row, g_col
H = -((1 + fy * fy) * fxx - 2 * fx * fy * fxy + (1 + fx * fx) * fyy) / (2 * (1 + fx * fx + fy * fy) ** 1.5)
del fx, fy, fxx, fxy, fyy
a = np.abs(H)
classes = np.ones(H.shape, np.uint8)  # general (also where H is NaN beside a hole)
classes[a < FLAT] = 0
classes[a >= UNEVEN] = 2
classes[missing] = 255
del a
chunks = (min(256, H.shape[0]), min(256, H.shape[1]))
with h5py.File(dst, "w") as f:
    f.create_dataset("grid/height", data=z32, chunks=chunks)
    f.create_dataset("curvature/mean", data=H.astype(np.float32), chunks=chunks)
    f.create_dataset("classes/grid", data=classes, chunks=chunks)
'''


# --- DEMs ----------------------------------------------------------------------

def heights(rows: np.ndarray, cols: np.ndarray, rng) -> np.ndarray:
    """Heights (m) at posts (rows x cols) of a DEM whose north-west post is (0, 0), 1 m posts."""
    y = -rows.astype(np.float64)[:, None]
    x = cols.astype(np.float64)[None, :]
    tau = 2 * np.pi
    ground = (200.0 + 30.0 * np.sin(tau * x / 2300 + 0.4) * np.cos(tau * y / 1900)
              + 12.0 * np.sin(tau * (x + y) / 1300))
    waves = (0.6 * np.sin(tau * x / 47) * np.cos(tau * y / 61)
             + 0.3 * np.sin(tau * (0.8 * x - 0.6 * y) / 23 + 1.0))
    return ground + waves + rng.normal(0.0, 0.02, ground.shape)


def crop_window(size: int, crop: int) -> tuple[int, int]:
    """(row0, col0) of the crop: the middle of the DEM."""
    r0 = (size - crop) // 2
    return r0, r0


def holes(size: int, crop: int, seed: int, count: int = 6):
    """NODATA disks (row, col, radius in posts), none within MARGIN of the crop window."""
    rng = np.random.default_rng(seed)
    r0, c0 = crop_window(size, crop)
    out = []
    while len(out) < count:
        rad = float(rng.uniform(3, 25))
        r, c = (int(v) for v in rng.integers(0, size, 2))
        if r0 - MARGIN - rad <= r <= r0 + crop + MARGIN + rad and c0 - MARGIN - rad <= c <= c0 + crop + MARGIN + rad:
            continue
        out.append((r, c, rad))
    return out


def cached(path: str, tag: str) -> bool:
    import rasterio

    if not os.path.exists(path):
        return False
    try:
        with rasterio.open(path) as ds:
            return ds.tags().get("GENERATOR") == tag
    except Exception:
        return False


def profile(rows: int, cols: int, transform) -> dict:
    from rasterio.crs import CRS

    return dict(driver="GTiff", width=cols, height=rows, count=1, dtype="float32", nodata=NODATA,
                crs=CRS.from_epsg(32633), transform=transform, tiled=True, blockxsize=BLOCK, blockysize=BLOCK,
                BIGTIFF="IF_SAFER")


def generate_dem(path: str, size: int, crop: int, seed: int) -> bool:
    """Write a SIZE x SIZE DEM block by block (BLOCK rows at a time); False if the cached one fits."""
    import rasterio
    from rasterio.transform import from_origin
    from rasterio.windows import Window

    tag = f"{GENERATOR} size={size} crop={crop} seed={seed}"
    if cached(path, tag):
        return False
    tmp = path + ".part"
    cols = np.arange(size)
    hole_list = holes(size, crop, seed)
    with rasterio.open(tmp, "w", **profile(size, size, from_origin(WEST, NORTH, 1.0, 1.0))) as ds:
        for b, r0 in enumerate(range(0, size, BLOCK)):
            rows = np.arange(r0, min(size, r0 + BLOCK))
            z = heights(rows, cols, np.random.default_rng([seed, b])).astype(np.float32)
            for hr, hc, rad in hole_list:
                lo, hi = max(rows[0], math.floor(hr - rad)), min(rows[-1], math.ceil(hr + rad))
                if lo > hi:
                    continue
                c_lo, c_hi = max(0, math.floor(hc - rad)), min(size - 1, math.ceil(hc + rad))
                rr, cc = np.mgrid[lo:hi + 1, c_lo:c_hi + 1]
                inside = (rr - hr) ** 2 + (cc - hc) ** 2 <= rad * rad
                z[rr[inside] - r0, cc[inside]] = NODATA
            ds.write(z, 1, window=Window(0, r0, size, len(rows)))
        ds.update_tags(GENERATOR=tag)
    os.replace(tmp, path)
    return True


def generate_crop(src_path: str, path: str, size: int, crop: int) -> bool:
    """The CROP x CROP middle window of ``src_path``, the same posts (the window's transform)."""
    import rasterio
    from rasterio.windows import Window

    with rasterio.open(src_path) as src:
        tag = f"{src.tags()['GENERATOR']} crop-of={os.path.basename(src_path)}"
        if cached(path, tag):
            return False
        r0, c0 = crop_window(size, crop)
        win = Window(c0, r0, crop, crop)
        z = src.read(1, window=win)
        transform = src.window_transform(win)
    tmp = path + ".part"
    with rasterio.open(tmp, "w", **profile(crop, crop, transform)) as ds:
        ds.write(z, 1)
        ds.update_tags(GENERATOR=tag)
    os.replace(tmp, path)
    return True


def crop_bounds(size: int, crop: int):
    """World (x_min, x_max, y_min, y_max) of the crop's post centres."""
    r0, c0 = crop_window(size, crop)
    x0 = WEST + 0.5 + c0
    y0 = NORTH - 0.5 - r0
    return x0, x0 + crop - 1, y0 - (crop - 1), y0


def trajectory(path: str, rows: int, bounds, seed: int = 5) -> float:
    """A wandering path of ROWS rows, 1 m apart, kept MARGIN m inside ``bounds``; returns its length."""
    x_min, x_max, y_min, y_max = bounds
    cx, cy = (x_min + x_max) / 2, (y_min + y_max) / 2
    reach = min(x_max - x_min, y_max - y_min) / 2 - MARGIN  # from the middle
    rng = np.random.default_rng(seed)
    x, y, heading = np.empty(rows), np.empty(rows), np.empty(rows)
    px, py, h = cx - 0.3 * reach, cy - 0.2 * reach, 0.3
    for i in range(rows):
        x[i], y[i], heading[i] = px, py, h
        h += rng.normal(0.0, 0.05)
        if max(abs(px - cx), abs(py - cy)) > 0.8 * reach:  # turn back towards the middle
            home = math.atan2(cy - py, cx - px)
            h += 0.2 * math.remainder(home - h, 2 * math.pi)
        px, py = px + math.cos(h), py + math.sin(h)
    if np.max(np.maximum(np.abs(x - cx), np.abs(y - cy))) > reach:
        raise SystemExit("trajectory left the crop's interior")
    t = np.arange(rows) * 0.1
    with open(path, "w") as fh:
        fh.write("t,x,y,yaw_deg\n")
        np.savetxt(fh, np.column_stack([t, x, y, np.degrees(heading) % 360]), fmt="%.3f", delimiter=",")
    return float(np.sum(np.hypot(np.diff(x), np.diff(y))))


# --- measuring -------------------------------------------------------------------

def measure(cmd: list[str], ok=(0,), remove: str | None = None) -> dict:
    """Run ``cmd`` once as its own process: seconds, CPU seconds, peak RSS (MiB)."""
    if remove and os.path.exists(remove):
        os.remove(remove)
    proc = subprocess.run([sys.executable, "-c", WRAPPER, *cmd], capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"the measuring wrapper failed: {proc.stderr}")
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    if r["rc"] not in ok:
        raise SystemExit(f"exit code {r['rc']} from {' '.join(cmd)}:\n{r['stderr']}")
    kib = r["maxrss_kib"] if sys.platform != "darwin" else r["maxrss_kib"] / 1024  # bytes on macOS
    return {"seconds": r["seconds"], "cpu": r["cpu"], "mib": kib / 1024}


def spread(values) -> str:
    v = list(values)
    if len(v) == 1:
        return f"{v[0]:.2f}"
    return f"{np.median(v):.2f} ({min(v):.2f}-{max(v):.2f})"


def spread_mib(values) -> str:
    v = list(values)
    if len(v) == 1:
        return f"{v[0]:,.0f}"
    return f"{np.median(v):,.0f} ({min(v):,.0f}-{max(v):,.0f})"


def label(posts: int) -> str:
    return f"{posts / 1e6:g}M"


def machine() -> str:
    import h5py
    import rasterio

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), cpu)
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    try:
        ram = f", {os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES') / 2**30:.0f} GiB RAM"
    except (ValueError, OSError, AttributeError):
        ram = ""
    from tankcd_cli import __version__

    rev = ""
    try:
        head = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no", "tankcd_cli"],
                               capture_output=True, text=True)
        if head.returncode == 0:
            rev = f" (commit {head.stdout.strip()}{' + uncommitted changes' if dirty.stdout.strip() else ''})"
    except OSError:
        pass
    return (f"{datetime.date.today().isoformat()}; {cpu}, {cores} cores{ram}; Python {platform.python_version()}, "
            f"numpy {np.__version__}, rasterio {rasterio.__version__} (GDAL {rasterio.__gdal_version__}), "
            f"h5py {h5py.__version__}; tankcd {__version__}{rev}")


# --- main -------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--work", help="cache for the DEMs and stores (default: a temporary dir, removed)")
    ap.add_argument("--repeats", type=int, help="runs of every case (default 3; 1 with --quick)")
    ap.add_argument("--quick", action="store_true", help="the SIZE DEM only, 1 repeat: a smoke run")
    ap.add_argument("--size", type=int, default=6000, help="side of the main DEM, posts (default 6000: 36M)")
    ap.add_argument("--big", type=int, default=10000, help="side of the large DEM, posts (default 10000: 100M)")
    ap.add_argument("--crop", type=int, default=1000, help="side of the crop, posts (default 1000: 1M)")
    ap.add_argument("--rows", type=int, default=1000, help="replay trajectory rows (default 1,000)")
    ap.add_argument("--with-numpy-100m", action="store_true", help="also run the numpy peer on the large DEM")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "grid.md"))
    a = ap.parse_args()
    repeats = a.repeats or (1 if a.quick else 3)
    crop = min(a.crop, a.size // 2)
    if crop < 2 * MARGIN + 50:
        ap.error(f"the crop ({crop} posts) leaves no room for the path {MARGIN} m inside its edges")
    if a.work:
        os.makedirs(a.work, exist_ok=True)
        run_all(a, a.work, repeats, crop)
    else:
        with tempfile.TemporaryDirectory(prefix="gridbench-") as work:
            run_all(a, work, repeats, crop)


def run_all(a, work: str, repeats: int, crop: int):
    header = machine()
    print(header, flush=True)
    main_posts, crop_posts = a.size * a.size, crop * crop
    L, LC = label(main_posts), label(crop_posts)
    dem = os.path.join(work, f"dem{a.size}.tif")
    crop_tif = os.path.join(work, f"dem{a.size}_crop{crop}.tif")
    notes = []

    s = time.perf_counter()
    made = generate_dem(dem, a.size, crop, a.seed)
    made |= generate_crop(dem, crop_tif, a.size, crop)
    big = None
    if not a.quick:
        big = os.path.join(work, f"dem{a.big}.tif")
        made |= generate_dem(big, a.big, min(a.crop, a.big // 2), a.seed + 1)
    notes.append(f"DEMs {'generated' if made else 'reused from the cache'} in {time.perf_counter() - s:.0f} s "
                 f"({work}).")
    print(notes[-1], flush=True)
    peer = os.path.join(work, "numpy_classify.py")
    with open(peer, "w") as fh:
        fh.write(NUMPY_PEER)

    # the crop's store, once (untimed for the ratios; its numbers are shown for reference)
    crop_store = os.path.join(work, "crop.tankcd.h5")
    crop_run = measure([*TANKCD, "classify", crop_tif, "-o", crop_store], remove=crop_store)

    # 2. classify the main DEM: tankcd, numpy, tankcd --jobs 1, alternately
    store = os.path.join(work, "main.tankcd.h5")
    store_j1 = os.path.join(work, "main.tankcd-jobs1.h5")
    numpy_out = os.path.join(work, "main.numpy.h5")
    cases = {
        "tankcd": [*TANKCD, "classify", dem, "-o", store],
        "numpy": [sys.executable, peer, dem, numpy_out],
        "tankcd --jobs 1": [*TANKCD, "classify", dem, "-o", store_j1, "--jobs", "1"],
    }
    outputs = {"tankcd": store, "numpy": numpy_out, "tankcd --jobs 1": store_j1}
    runs = {k: [] for k in cases}
    for i in range(repeats):
        for name, cmd in cases.items():
            runs[name].append(measure(cmd, remove=outputs[name]))
            r = runs[name][-1]
            print(f"classify {L} {name} #{i + 1}: {r['seconds']:.2f} s, {r['mib']:,.0f} MiB", flush=True)
    os.remove(store_j1)  # the same store again; keep the disk for the large DEM

    # 3. replay on the main store and on the crop's store, alternately
    traj = os.path.join(work, "traj.csv")
    length = trajectory(traj, a.rows, crop_bounds(a.size, crop))
    poses = {"main": os.path.join(work, "poses.main.csv"), "crop": os.path.join(work, "poses.crop.csv")}
    replay_cmd = {"main": [*TANKCD, "replay", traj, "--terrain", store, "--poses", poses["main"]],
                  "crop": [*TANKCD, "replay", traj, "--terrain", crop_store, "--poses", poses["crop"]]}
    replays = {"main": [], "crop": []}
    for i in range(repeats):
        for name in ("main", "crop"):
            replays[name].append(measure(replay_cmd[name], remove=poses[name]))
            r = replays[name][-1]
            print(f"replay on {name} #{i + 1}: {r['seconds']:.2f} s, {r['mib']:,.0f} MiB", flush=True)
    same_poses = filecmp.cmp(poses["main"], poses["crop"], shallow=False)

    # 2b. the large DEM
    big_runs, big_numpy, big_store = [], [], None
    if big:
        big_store = os.path.join(work, "big.tankcd.h5")
        big_numpy_out = os.path.join(work, "big.numpy.h5")
        for i in range(repeats):
            big_runs.append(measure([*TANKCD, "classify", big, "-o", big_store], remove=big_store))
            print(f"classify {label(a.big ** 2)} tankcd #{i + 1}: {big_runs[-1]['seconds']:.2f} s, "
                  f"{big_runs[-1]['mib']:,.0f} MiB", flush=True)
            if a.with_numpy_100m:
                big_numpy.append(measure([sys.executable, peer, big, big_numpy_out], remove=big_numpy_out))
                print(f"classify {label(a.big ** 2)} numpy #{i + 1}: {big_numpy[-1]['seconds']:.2f} s, "
                      f"{big_numpy[-1]['mib']:,.0f} MiB", flush=True)

    # --- report ---------------------------------------------------------------
    jobs = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    lines = ["# Benchmark: classify and replay on large DEMs (grid layout)", "",
             f"Machine: {header}.", "",
             f"Every run is a whole process (start-up, reading, computing, writing), timed and its peak "
             f"resident memory (RSS) read by a wrapper process; "
             f"{f'medians of {repeats} (min-max)' if repeats > 1 else 'one run each'}, compared cases "
             f"run alternately. DEMs: tiled float32 GeoTIFFs, EPSG:32633, 1 m posts, rolling ground + "
             f"mid-scale waves + 2 cm noise, a few NODATA holes. {notes[0]}", "",
             "## Classify", "",
             "| DEM | case | seconds | CPU seconds | Mposts/s | peak RSS (MiB) |",
             "| --- | --- | --- | --- | --- | --- |"]

    def row(dem_label, posts, name, rs):
        sec = [r["seconds"] for r in rs]
        lines.append(f"| {dem_label} | {name} | {spread(sec)} | {spread(r['cpu'] for r in rs)} | "
                     f"{posts / 1e6 / np.median(sec):.2f} | {spread_mib(r['mib'] for r in rs)} |")

    main_label = f"{L} ({a.size:,} x {a.size:,})"
    row(main_label, main_posts, f"`tankcd classify` ({jobs} threads)", runs["tankcd"])
    row(main_label, main_posts, "numpy whole raster (peer)", runs["numpy"])
    row(main_label, main_posts, "`tankcd classify --jobs 1`", runs["tankcd --jobs 1"])
    if big:
        big_label = f"{label(a.big ** 2)} ({a.big:,} x {a.big:,})"
        row(big_label, a.big ** 2, f"`tankcd classify` ({jobs} threads)", big_runs)
        if big_numpy:
            row(big_label, a.big ** 2, "numpy whole raster (peer)", big_numpy)
    row(f"{LC} crop ({crop:,} x {crop:,})", crop_posts, f"`tankcd classify` ({jobs} threads), once", [crop_run])
    t_ratio = [t["seconds"] / n["seconds"] for t, n in zip(runs["tankcd"], runs["numpy"])]
    m_ratio = [t["mib"] / n["mib"] for t, n in zip(runs["tankcd"], runs["numpy"])]
    lines += ["", f"tankcd / numpy on {L}, per pair: time {spread(t_ratio)}, peak RSS {spread(m_ratio)}."]
    if big_numpy:
        bt = [t["seconds"] / n["seconds"] for t, n in zip(big_runs, big_numpy)]
        lines.append(f"tankcd / numpy on {label(a.big ** 2)}, per pair: time {spread(bt)}.")
    elif big:
        lines.append(f"The numpy peer is not run on {label(a.big ** 2)} (it holds about 70 bytes a post in memory; "
                     "`--with-numpy-100m` runs it).")
    lines += ["", "The peer reads the whole band, takes H from np.gradient (float64) in the height-field formula "
              "and thresholds |H| (0.0044, 0.022 1/m) post by post (GDAL cache at 64 MB, as in tankcd); "
              "it does not average |H| over the footprint, fit the edges and hole borders or write overviews, "
              "so it does less than tankcd: its time is a floor for the same reading and writing."]

    r_ratio = [m["seconds"] / c["seconds"] for m, c in zip(replays["main"], replays["crop"])]
    peak = max(r["mib"] for r in replays["main"] + replays["crop"])
    ratio_med = float(np.median(r_ratio))
    lines += ["", "## Replay", "",
              f"{a.rows:,} rows (a wandering path of {length:,.0f} m, at least {MARGIN} m inside the crop), "
              f"`tankcd replay TRAJ --terrain STORE --poses P.csv`, alternately on the two stores.", "",
              "| store | seconds | CPU seconds | peak RSS (MiB) |", "| --- | --- | --- | --- |"]
    for name, lab in (("main", f"{L} ({a.size:,} x {a.size:,})"), ("crop", f"{LC} crop ({crop:,} x {crop:,})")):
        rs = replays[name]
        lines.append(f"| {lab} | {spread(r['seconds'] for r in rs)} | {spread(r['cpu'] for r in rs)} | "
                     f"{spread_mib(r['mib'] for r in rs)} |")
    lines += ["", f"Ratio {L} / {LC}, per pair: {spread(r_ratio)} (target <= 1.2: "
              f"{'met' if ratio_med <= 1.2 else 'NOT met'}); highest peak RSS {peak:,.0f} MiB (target <= 300: "
              f"{'met' if peak <= 300 else 'NOT met'}). Poses on the two stores "
              f"{'identical' if same_poses else 'DIFFER'}."]

    lines += ["", "## Store size", "", "| store | posts | bytes | bytes / post |", "| --- | --- | --- | --- |"]
    sizes = [(f"tankcd, {L}", store, main_posts), (f"numpy peer, {L}", numpy_out, main_posts),
             (f"tankcd, {LC} crop", crop_store, crop_posts)]
    if big:
        sizes.append((f"tankcd, {label(a.big ** 2)}", big_store, a.big ** 2))
        if big_numpy:
            sizes.append((f"numpy peer, {label(a.big ** 2)}", big_numpy_out, a.big ** 2))
    for name, path, posts in sizes:
        n = os.path.getsize(path)
        lines.append(f"| {name} | {posts:,} | {n:,} | {n / posts:.2f} |")
    save_report("\n".join(lines + [""]), a.out)


if __name__ == "__main__":
    main()
