"""Benchmark: ``tankcd report`` on an exercise's outputs: time, peak memory, the outputs' sizes, and
the page's load time in headless Chromium.

    python benchmarks/bench_report.py [--vehicles 1000] [--minutes 5] [--hz 2]
                                      [--outputs .html,.geojson,.czml]
                                      [--out benchmarks/results/report.md] [--keep DIR]

The exercise is ``bench_exercise.py``'s (platoons of T-72s wandering over a rolling 4 km DEM, every
vehicle at HZ with its own phase), replayed once (not timed here: ``bench_exercise.py`` times it).
Then, each a fresh ``tankcd`` process (start-up included), ``tankcd report`` writes the page
(``.html``), the GIS layer (``.geojson``) and the Cesium document (``.czml``) of the same poses and
events; beside each, for scale, ``python -c "import numpy, h5py"`` in the same run (the ratio is the
report's time over it). The page is then opened in headless Chromium (Debian's ``chromium`` and
``chromium-driver``, through selenium) from a local file, with no network: the load time is from the
navigation's start to the page's ``window.tankcdReview.ready`` (its data parsed, its first frame
drawn), and the play time how long 100 frames of playback take (``setTime`` over the exercise).
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from _report import save_report
from bench_exercise import POST, X0, Y0, run, write_exercise, write_terrain

HERE = os.path.dirname(os.path.abspath(__file__))


def _load_uptime() -> str:
    with open("/proc/loadavg") as fh:
        return " ".join(fh.read().split()[:3])


def write_utm_terrain(folder: str, path: str) -> None:
    """bench_exercise's terrain as a GeoTIFF in UTM zone 33N (GeoJSON and CZML need a CRS)."""
    import rasterio
    from rasterio.transform import from_origin

    asc = os.path.join(folder, "terrain.asc")
    write_terrain(asc)
    z = np.loadtxt(asc, skiprows=5).astype("float32")
    north = Y0 + (z.shape[0] - 1) * POST  # the asc's lower-left post is (X0, Y0)
    with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype="float32",
                       crs="EPSG:32633", transform=from_origin(X0 - POST / 2, north + POST / 2, POST, POST)) as dst:
        dst.write(z, 1)


def page_timings(page: str, span: tuple[float, float]) -> tuple[float, float] | None:
    """(load s, 100 frames s) of the page in headless Chromium, or None without a browser."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        return None
    if not (shutil.which("chromium") and shutil.which("chromedriver")):
        return None
    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium")
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,800",
                "--proxy-server=127.0.0.1:9", "--proxy-bypass-list=<-loopback>"):
        opts.add_argument(arg)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)
    try:
        start = time.perf_counter()
        driver.get("file://" + os.path.abspath(page))
        while not driver.execute_script("return !!(window.tankcdReview && window.tankcdReview.ready)"):
            time.sleep(0.01)
        load = time.perf_counter() - start
        play = driver.execute_script("""
            const r = window.tankcdReview, a = arguments[0], b = arguments[1], s = performance.now();
            for (let k = 0; k < 100; k++) r.setTime(a + (b - a) * k / 99);
            return (performance.now() - s) / 1000;""", span[0], span[1])
        return load, float(play)
    finally:
        driver.quit()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vehicles", type=int, default=1000)
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--hz", type=float, default=2.0)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "report.md"))
    ap.add_argument("--keep", default=None, help="keep the inputs and outputs in this folder")
    ap.add_argument("--outputs", default=".html,.geojson,.czml", help="the reports to time (comma-separated suffixes)")
    a = ap.parse_args()
    tmp = a.keep or tempfile.mkdtemp(prefix="tankcd-report-")
    os.makedirs(tmp, exist_ok=True)
    try:
        terrain, store = os.path.join(tmp, "terrain.tif"), os.path.join(tmp, "terrain.h5")
        if not os.path.exists(store):
            write_utm_terrain(tmp, terrain)
            subprocess.run([sys.executable, "-m", "tankcd_cli", "-q", "classify", terrain, "-o", store], check=True)
        poses, events = os.path.join(tmp, "ex.poses.csv"), os.path.join(tmp, "ex.events.jsonl")
        if not os.path.exists(events):
            path, _ = write_exercise(tmp, a.vehicles, a.minutes, a.hz, separate=False)
            run(["-q", "replay", path, "--terrain", store, "--poses", poses, "--events", events])
        with open(poses) as fh:
            rows = sum(1 for _ in fh) - 1
        with open(events) as fh:
            n_events = sum(1 for _ in fh)
        lines = [
            "# Benchmark: `tankcd report` on an exercise",
            "",
            f"Machine: {platform.machine()}, {os.cpu_count()} cores (shared), Python {platform.python_version()}, "
            f"numpy {np.__version__}; load average before the runs: {_load_uptime()}. Command: "
            f"`python benchmarks/bench_report.py --vehicles {a.vehicles} --minutes {a.minutes:g} --hz {a.hz:g}"
            + (f" --outputs {a.outputs}" if a.outputs != ".html,.geojson,.czml" else "") + "`.",
            "",
            f"{a.vehicles:,} vehicles for {a.minutes:g} min at {a.hz:g} Hz: {rows:,} pose rows "
            f"({os.path.getsize(poses) / 2**20:,.1f} MiB of CSV), {n_events:,} events.",
            "",
            "| output | seconds | x `import numpy, h5py` | peak memory | size |",
            "| --- | --- | --- | --- | --- |",
        ]
        base = min(run_python(["-c", "import numpy, h5py"]) for _ in range(2))
        for suffix in a.outputs.split(","):
            out = os.path.join(tmp, "report" + suffix)
            wall, rss, _ = run(["-q", "report", poses, events, "--terrain", store, "-o", out])
            lines.append(f"| `{suffix}` | {wall:.2f} | {wall / base:.1f}x | {rss:,.0f} MiB | "
                         f"{os.path.getsize(out) / 2**20:,.1f} MiB |")
        span = (0.0, a.minutes * 60.0)  # the exercise's clock (bench_exercise's rows start at t = 0)
        timings = page_timings(os.path.join(tmp, "report.html"), span) if ".html" in a.outputs else None
        lines.append("")
        if timings is None:
            lines.append("The page's load time was not measured: no Chromium and chromedriver, or no selenium.")
        else:
            lines.append(f"The page in headless Chromium: loaded and drawn in {timings[0]:.2f} s; 100 frames of "
                         f"playback over the exercise in {timings[1]:.2f} s ({100 / max(timings[1], 1e-9):.0f} "
                         "frames a second).")
        lines.append(f"`python -c \"import numpy, h5py\"` took {base:.2f} s in the same run.")
        save_report("\n".join(lines), a.out)
    finally:
        if not a.keep:
            shutil.rmtree(tmp, ignore_errors=True)


def run_python(args: list) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, *args], check=True)
    return time.perf_counter() - start


if __name__ == "__main__":
    main()
