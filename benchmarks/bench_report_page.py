"""Benchmark: the review page of a large exercise: its size, the time to write it, and how it opens
and plays in headless Chromium.

    python benchmarks/bench_report_page.py [--vehicles 1000] [--minutes 60] [--hz 10]
                                           [--events-per-vehicle 34] [--no-browser]
                                           [--out benchmarks/results/report_page.md]

The exercise is made here, not replayed (the page's cost is in its rows and events, not in how
they were found): VEHICLES vehicles on a 4 km x 4 km terrain, each driving at 3-8 m/s with a
turn rate that wanders smoothly (a driver steering), stopping now and then, its heading with
0.2 degrees of white noise a row (a sensor's), rows at HZ; EVENTS-PER-VEHICLE events each, of
every kind, at points on its track (a vehicle contact names two vehicles). The terrain picture
is a class raster of 1024 x 1024.

Measured: the rows and the vertices kept (0.5 m, 1 degree), the seconds to build and write the
page, its size; in Chromium (``--headless=new``, 1280 x 800, software rendering): from navigation
to the map's first frame, to the load event and to the hook seen ready by WebDriver, a frame of playback (every footprint at a new time, averaged over 60), a redraw of the
whole map (tracks and event markers, after a selection moves it).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import save_report  # noqa: E402
from tankcd_cli.report.background import class_picture  # noqa: E402
from tankcd_cli.report.page import write_page  # noqa: E402
from tankcd_cli.report.review import Review, Source, Track  # noqa: E402

SIDE = 4000.0
X0, Y0 = 500000.0, 4500000.0


def vehicle_track(rng, name: str, n: int, hz: float) -> Track:
    """One vehicle's rows (see the module's docstring)."""
    dt = 1.0 / hz
    # turn rate, deg/s: a slow random process (a driver's steering), bounded to 15 deg/s
    knots = rng.normal(0.0, 6.0, n // int(20 * hz) + 2)
    rate = np.clip(np.interp(np.arange(n), np.arange(len(knots)) * 20 * hz, knots), -15, 15)
    heading = rng.uniform(0, 360) + np.cumsum(rate) * dt
    speed = np.interp(np.arange(n), np.arange(len(knots)) * 20 * hz, rng.uniform(3, 8, len(knots)))
    speed[(np.arange(n) // int(60 * hz)) % 7 == 3] = 0.0  # a minute's stop now and then
    x = np.cumsum(speed * dt * np.cos(np.radians(heading)))
    y = np.cumsum(speed * dt * np.sin(np.radians(heading)))
    # fold into the terrain (a mirror at its edges keeps the motion continuous)
    x = SIDE - np.abs(np.mod(x + rng.uniform(0, SIDE), 2 * SIDE) - SIDE)
    y = SIDE - np.abs(np.mod(y + rng.uniform(0, SIDE), 2 * SIDE) - SIDE)
    yaw = np.mod(heading + rng.normal(0.0, 0.2, n) + 180.0, 360.0) - 180.0
    t = np.arange(n) * dt + rng.uniform(0, dt)
    q = np.broadcast_to(np.array([1.0, 0.0, 0.0, 0.0]), (n, 4))  # not drawn: one row shared
    return Track(name, np.arange(n, dtype=np.int64), t, X0 + x, Y0 + y, np.full(n, 100.0), yaw, q,
                 np.zeros(n, dtype=np.uint8))


def exercise(vehicles: int, minutes: float, hz: float, per_vehicle: int, seed: int = 0) -> Review:
    rng = np.random.default_rng(seed)
    n = int(minutes * 60 * hz)
    names = [f"v{k:04d}" for k in range(vehicles)]
    tracks = tuple(vehicle_track(rng, name, n, hz) for name in names)
    kinds = ["obstacle", "terrain", "internal", "off_terrain", "vehicle"]
    events = []
    for k, tr in enumerate(tracks):
        rows = np.sort(rng.integers(0, n, per_vehicle))
        for j, r in enumerate(rows):
            kind = kinds[j % len(kinds)]
            ev = {"step": int(r), "t": round(float(tr.t[r]), 6), "kind": kind}
            point = [round(float(tr.x[r]), 4), round(float(tr.y[r]), 4), 101.0]
            if kind == "vehicle":
                other = names[(k + 1 + j) % vehicles]
                a, b = sorted((tr.entity, other))
                ev.update(a=a, b=b, a_part="hull", b_part="track_left", point=point,
                          closing_speed=round(float(rng.uniform(0, 10)), 4), a_step=int(r), b_step=int(r),
                          between=True, entity=a)
            elif kind == "obstacle":
                ev.update(a="hull", b=f"building_{j}", point=point, contacts=1, entity=tr.entity)
            elif kind == "terrain":
                ev.update(a="hull", b="terrain", depth=0.0213, entity=tr.entity)
            elif kind == "internal":
                ev.update(a="gun", b="drum_left", turret_deg=170.0, gun_deg=-4.0, entity=tr.entity)
            else:
                ev.update(a="vehicle", b="terrain", status="partly_off", entity=tr.entity)
            events.append(ev)
    return Review(tracks, events, "", (Source("poses", "exercise.parquet", "0" * 64),
                                      Source("events", "exercise.events.jsonl", "1" * 64)),
                  {"mode": "continuous"}, "0.1.0")


def background():
    rng = np.random.default_rng(1)
    classes = np.repeat(np.repeat(rng.choice(3, size=(64, 64), p=[0.6, 0.3, 0.1]), 16, 0), 16, 1).astype(np.uint8)
    return class_picture(classes, X0, X0 + SIDE, Y0, Y0 + SIDE)


def in_browser(path: str) -> dict:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.support.ui import WebDriverWait

    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1280,800"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    try:
        driver.set_page_load_timeout(600)
        start = time.perf_counter()
        driver.get("file://" + os.path.abspath(path))
        WebDriverWait(driver, 600).until(lambda d: d.execute_script("return !!(window.tankcdReview && window.tankcdReview.ready)"))
        opened = time.perf_counter() - start
        timings = driver.execute_script("return window.tankcdReview.timings")
        nav = driver.execute_script("var n = performance.getEntriesByType('navigation')[0]; "
                                    "return [n.responseEnd, n.domInteractive, n.loadEventEnd].map(Math.round)")
        timings.update(zip(("response_end", "dom_interactive", "load_end"), nav))
        print("page timings, ms after its script began:", timings, file=sys.stderr)
        frame = driver.execute_script("""
            var r = window.tankcdReview, s = performance.now(), t0 = r.time();
            for (var k = 0; k < 60; k++) { r.setTime(t0 + 1.7 * k); }
            return (performance.now() - s) / 60;""")
        redraw = driver.execute_script("""
            var s = performance.now(); window.tankcdReview.selectEvent(window.tankcdReview.events - 1);
            return performance.now() - s;""")
        severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        heap = driver.execute_script("return performance.memory ? performance.memory.usedJSHeapSize / 1e6 : null")
    finally:
        driver.quit()
    return {"opened_s": opened, "first_frame_s": (timings.get("first_frame") or float("nan")) / 1000,
            "load_s": timings["load_end"] / 1000, "frame_ms": frame, "redraw_ms": redraw, "severe": severe, "heap_mb": heap}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vehicles", type=int, default=1000)
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--hz", type=float, default=10.0)
    ap.add_argument("--events-per-vehicle", type=int, default=34)
    ap.add_argument("--no-browser", action="store_true")
    ap.add_argument("--page", help="open this page instead of making one (the browser's measures only)")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results", "report_page.md"))
    a = ap.parse_args()
    if a.page:
        print(in_browser(a.page))
        return
    start = time.perf_counter()
    review = exercise(a.vehicles, a.minutes, a.hz, a.events_per_vehicle)
    made = time.perf_counter() - start
    rows = sum(len(tr) for tr in review.tracks)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "exercise.html")
        start = time.perf_counter()
        write_page(review, background(), path)
        written = time.perf_counter() - start
        if os.environ.get("TANKCD_KEEP_PAGE"):
            import shutil

            shutil.copy(path, os.environ["TANKCD_KEEP_PAGE"])
        size = os.path.getsize(path)
        with open(path, encoding="utf-8") as fh:
            html = fh.read()
        import json
        import re

        data = json.loads(re.search(r'id="tankcd-data">(.*?)</script>', html, re.S).group(1))
        vertices = data["tolerance"]["vertices"]
        events_bytes = len(json.dumps(data["events"], separators=(",", ":")))
        del html, data
        browser = None if a.no_browser else in_browser(path)
    lines = [f"# The review page of a large exercise ({platform.node()}, {platform.processor() or platform.machine()})",
             "",
             f"`python benchmarks/bench_report_page.py --vehicles {a.vehicles} --minutes {a.minutes:g} --hz {a.hz:g} "
             f"--events-per-vehicle {a.events_per_vehicle}`",
             "",
             "| measure | value |", "| --- | --- |",
             f"| vehicles | {a.vehicles:,} |",
             f"| pose rows | {rows:,} |",
             f"| events | {len(review.events):,} |",
             f"| vertices kept (0.5 m, 1 degree) | {vertices:,} ({vertices / rows:.2%} of the rows) |",
             f"| the exercise made in memory, s | {made:.1f} |",
             f"| page built and written, s | {written:.1f} |",
             f"| page size | {size / 1e6:.1f} MB (events {events_bytes / 1e6:.1f} MB) |"]
    if browser:
        lines += [f"| Chromium: navigation to the map drawn (first frame), s | {browser['first_frame_s']:.1f} |",
                  f"| Chromium: navigation to the load event, s | {browser['load_s']:.1f} |",
                  f"| Chromium: navigation to the hook ready as WebDriver sees it, s | {browser['opened_s']:.1f} |",
                  f"| Chromium: a frame of playback (every footprint), ms | {browser['frame_ms']:.1f} |",
                  f"| Chromium: the whole map redrawn (tracks, markers), ms | {browser['redraw_ms']:.0f} |",
                  f"| Chromium: JS heap after, MB | {browser['heap_mb'] or float('nan'):.0f} |",
                  f"| console errors | {len(browser['severe'])} |"]
    save_report("\n".join(lines) + "\n", a.out)


if __name__ == "__main__":
    main()
