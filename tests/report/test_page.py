"""The review page: the simplification's bound against dense sampling, the page's data against the
review it was written from, and the page itself in a real headless Chromium (no network: a file://
URL, and no reference to one in the file), driven through ``window.tankcdReview``.

``TANKCD_REPORT_SCREENSHOTS=1`` also saves docs/report_sample.png and docs/report_exercise.png."""

from __future__ import annotations

import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tankcd_cli import api
from tankcd_cli.report import page
from tankcd_cli.report.background import class_picture, terrain_background
from tankcd_cli.report.page import page_data, played_pose, simplify_track, write_page

from tests.report.page_reviews import read_replay, small_review

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "sample_data"
CHROMIUM, CHROMEDRIVER = "/usr/bin/chromium", "/usr/bin/chromedriver"
SCREENSHOTS = bool(os.environ.get("TANKCD_REPORT_SCREENSHOTS"))
# the page's data are rounded (0.01 m, 1 ms at a few m/s) before they are simplified
ROUNDING_M = 0.02


def _dense_errors(t, x, y, h, kept, samples=20):
    """Largest position (m) and heading (deg) error of playback over ``samples`` times in every
    interval between rows, against the rows' own linear interpolation (np.interp)."""
    u = np.linspace(0.0, 1.0, samples)
    at = (t[:-1, None] + u[None, :] * np.diff(t)[:, None]).ravel()
    px, py, ph = played_pose(t[kept], x[kept], y[kept], h[kept], at)
    return np.hypot(px - np.interp(at, t, x), py - np.interp(at, t, y)).max(), np.abs(ph - np.interp(at, t, h)).max()


@st.composite
def _tracks(draw):
    n = draw(st.integers(2, 400))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    dt = rng.choice([0.0, 0.05, 0.1, 0.1, 0.1, 2.0], size=n - 1)  # equal times and gaps too
    t = np.r_[0.0, np.cumsum(dt)]
    turn = draw(st.sampled_from([0.0, 0.3, 3.0, 30.0]))
    h = np.cumsum(rng.normal(0.0, turn, n)) + rng.uniform(-180, 180)
    speed = np.abs(rng.normal(draw(st.sampled_from([0.0, 3.0, 15.0])), 1.0, n))
    step = speed * np.r_[0.0, dt]
    x = 500000 + np.cumsum(step * np.cos(np.radians(h)))
    y = 4500000 + np.cumsum(step * np.sin(np.radians(h)))
    return t, x, y, h, draw(st.sampled_from([0.05, 0.5, 3.0])), draw(st.sampled_from([0.2, 1.0, 10.0]))


@settings(max_examples=120, deadline=None)
@given(_tracks())
def test_playback_stays_within_the_stated_bound_at_every_time(track):
    t, x, y, h, tol_m, tol_deg = track
    kept = simplify_track(t, x, y, h, tol_m, tol_deg)
    assert kept[0] == 0 and kept[-1] == len(t) - 1 and np.all(np.diff(kept) > 0)
    err_m, err_deg = _dense_errors(t, x, y, h, kept)
    assert err_m <= tol_m * (1 + 1e-9) + 1e-6
    assert err_deg <= tol_deg * (1 + 1e-9) + 1e-6


def test_the_bound_holds_when_segments_are_split_at_their_middle(monkeypatch):
    monkeypatch.setattr(page, "_WORST_ROW_PASSES", 0)
    rng = np.random.default_rng(3)
    t = np.arange(3000) * 0.1
    h = np.cumsum(rng.normal(0, 1.0, 3000))
    x, y = np.cumsum(np.cos(np.radians(h))), np.cumsum(np.sin(np.radians(h)))
    kept = simplify_track(t, x, y, h, 0.5, 1.0)
    err_m, err_deg = _dense_errors(t, x, y, h, kept)
    assert err_m <= 0.5 + 1e-9 and err_deg <= 1.0 + 1e-9


def test_a_straight_steady_drive_is_two_vertices_and_a_turn_keeps_more():
    t = np.arange(1000) * 0.1
    x, y, h = 3.0 * t, 1.0 * t, np.full(1000, 18.43)
    assert simplify_track(t, x, y, h).tolist() == [0, 999]
    # a circle of radius 50 m: chords within 0.5 m (sagitta) span at most 2 acos(1 - 0.5/50) = 16.2 degrees
    a = np.radians(np.arange(1000) * 0.36)
    kept = simplify_track(t, 50 * np.cos(a), 50 * np.sin(a), np.degrees(a) + 90, 0.5, 100.0)
    assert 360 / 16.22 <= len(kept) - 1 <= 2 * 360 / 16.22


def _data_of(html: str) -> dict:
    m = re.search(r'<script type="application/json" id="tankcd-data">(.*?)</script>', html, re.S)
    return json.loads(m.group(1))


def _small_background():
    classes = np.zeros((80, 120), np.uint8)
    classes[20:40, 30:60] = 1
    classes[50:, 90:] = 2
    return class_picture(classes, 500000, 500240, 4500000, 4500160)


def test_the_page_holds_everything_and_refers_to_nothing_outside(tmp_path):
    review = small_review()
    out = tmp_path / "review.html"
    write_page(review, _small_background(), str(out))
    html = out.read_text(encoding="utf-8")
    assert not re.search(r"<script[^>]*\bsrc=|<link\b|<iframe|<img\b|url\(\s*['\"]?(https?:)?//|https?://", html, re.I)
    assert "</script" not in _data_of_text(html)
    data = _data_of(html)
    assert data["events"] == review.events and len(data["event_at"]) == len(review.events)
    assert [v["name"] for v in data["vehicles"]] == ["alpha", "bravo", "charlie"]
    for v, tr in zip(data["vehicles"], review.tracks):
        t, x, y = (np.cumsum(v[k]) for k in ("t", "x", "y"))
        h = np.cumsum(v["h"])
        # every kept vertex is a row of the track, rounded to 1 ms and 0.01 m from the origin
        rows = np.searchsorted(np.round(tr.t * 1000), t)
        assert np.array_equal(np.round(tr.t[rows] * 1000), t)
        assert np.array_equal(np.round((tr.x[rows] - data["origin"][0]) * 100), x)
        assert np.array_equal(np.round((tr.y[rows] - data["origin"][1]) * 100), y)
        assert np.allclose(((h / 100 - tr.yaw_deg[rows]) + 180) % 360 - 180, 0, atol=0.006)
        assert v["stats"]["distance"] == pytest.approx(np.hypot(np.diff(tr.x), np.diff(tr.y)).sum(), abs=0.01)
    alpha = data["vehicles"][0]["stats"]
    assert alpha["contacts"] == {"obstacle": 1, "vehicle": 1} and alpha["first"] == 0 and alpha["closing"] == [3.5]
    assert data["vehicles"][1]["stats"]["contacts"] == {"vehicle": 1, "terrain": 1}
    assert data["vehicles"][1]["stats"]["from"] == pytest.approx(5.0)
    # the terrain event has no point: it is marked where bravo is at 45 s (x = 150 - 1.5 * 40)
    assert data["event_at"][2] == [9000, 6000]
    assert data["tolerance"]["vertices"] < data["tolerance"]["rows"]


def _data_of_text(html: str) -> str:
    return re.search(r'id="tankcd-data">(.*?)</script>', html, re.S).group(1)


def test_rows_without_a_position_are_left_out_of_the_drawing():
    review = small_review()
    tr = review.tracks[0]
    x = tr.x.copy()
    x[10:20] = np.nan
    holed = type(tr)(tr.entity, tr.step, tr.t, x, tr.y, tr.z, tr.yaw_deg, tr.quaternion, tr.status)
    data = page_data(type(review)((holed,), review.events[:1]), _small_background())
    t = np.cumsum(data["vehicles"][0]["t"])
    assert not np.isin(np.round(tr.t[10:20] * 1000), t).any() and json.dumps(data, allow_nan=False)


def test_a_review_without_times_plays_by_step():
    review = small_review()
    tr = review.tracks[0]
    no_t = type(tr)(tr.entity, tr.step, np.full(len(tr), np.nan), tr.x, tr.y, tr.z, tr.yaw_deg, tr.quaternion, tr.status)
    data = page_data(type(review)((no_t,), [dict(review.events[0], t=None)]), _small_background())
    assert data["clock"] == "step" and np.cumsum(data["vehicles"][0]["t"])[-1] == len(tr) - 1


# ---------------------------------------------------------------- in the browser

@pytest.fixture(scope="module")
def browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    if not (shutil.which(CHROMIUM) and shutil.which(CHROMEDRIVER)):
        pytest.skip("Chromium and its driver are not installed (apt-get install chromium chromium-driver)")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1280,800",
                "--hide-scrollbars", "--proxy-server=127.0.0.1:9", "--proxy-bypass-list=<-loopback>"):
        options.add_argument(arg)  # a proxy that refuses: nothing reaches a network
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    # the page's viewport itself 1280 x 800 (the window's size includes what a window has around it)
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": 1280, "height": 800, "deviceScaleFactor": 1, "mobile": False})
    yield driver
    driver.quit()


def _open(driver, path: Path):
    """Load the page and wait for its hook; no console error on the way."""
    driver.get(path.resolve().as_uri())
    _wait(driver, 20).until(lambda d: d.execute_script("return !!(window.tankcdReview && window.tankcdReview.ready)"))
    severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe


def _wait(driver, seconds: float):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(driver, seconds)


def _check_playback(driver, review, times):
    """setTime(t) puts every vehicle where its rows say at t (np.interp of the Track), within the bound."""
    tol = page.POSITION_TOLERANCE_M + ROUNDING_M
    for t in times:
        driver.execute_script("window.tankcdReview.setTime(arguments[0])", float(t))
        assert driver.execute_script("return window.tankcdReview.time()") == pytest.approx(t, abs=1e-9)
        for tr in review.tracks:
            got = driver.execute_script("return window.tankcdReview.positionOf(arguments[0])", tr.entity)
            if not tr.t[0] <= t <= tr.t[-1]:
                assert got is None
                continue
            want = np.interp(t, tr.t, tr.x), np.interp(t, tr.t, tr.y)
            assert np.hypot(got[0] - want[0], got[1] - want[1]) <= tol, (tr.entity, t, got, want)
            heading = driver.execute_script("return window.tankcdReview.headingOf(arguments[0])", tr.entity)
            want_h = np.interp(t, tr.t, np.degrees(np.unwrap(np.radians(tr.yaw_deg))))
            assert abs((heading - want_h + 180) % 360 - 180) <= page.HEADING_TOLERANCE_DEG + 0.02


def _click_event(driver, i: int, want_t: float):
    row = driver.find_element("css selector", f'#events .ev[data-i="{i}"]')
    driver.execute_script("arguments[0].scrollIntoView({block: 'center', inline: 'nearest'})", row)
    row.click()
    assert driver.execute_script("return window.tankcdReview.time()") == pytest.approx(want_t, abs=1e-9)
    assert "selected" in row.get_attribute("class")


def test_the_page_in_a_browser(browser, tmp_path):
    review = small_review()
    out = tmp_path / "review.html"
    write_page(review, _small_background(), str(out))
    _open(browser, out)
    hook = browser.execute_script("return [window.tankcdReview.vehicles, window.tankcdReview.events]")
    assert hook == [["alpha", "bravo", "charlie"], 4]
    text = browser.find_element("tag name", "body").text
    for name in ("alpha", "bravo", "charlie"):
        assert name in text
    assert "ab" * 32 in text and "0.1.0" in text  # provenance: a source's SHA-256, the version
    assert len(browser.find_elements("css selector", "#events .ev")) == len(review.events)
    _check_playback(browser, review, np.r_[0.0, 0.05, 4.99, 5.0, 12.345, 33.3, np.linspace(0, 64.9, 23), 64.9])
    bravo = review.tracks[1]
    for c in np.r_[bravo.t[[0, 99, 100, 120, 149, 150, 155, 159, 160]], bravo.t[99] + 0.05, bravo.t[159] + 0.05, 30.0]:
        browser.execute_script("window.tankcdReview.setTime(arguments[0])", float(c))
        want = ("ok", "partly_off", "off")[bravo.status[np.searchsorted(bravo.t, c, side="right") - 1]]
        assert browser.execute_script("return window.tankcdReview.statusOf('bravo')") == want, c
    for i in (1, 3, 0):
        _click_event(browser, i, review.events[i]["t"])
    # the kind filter hides rows of that kind only
    browser.find_element("css selector", 'input.kindfilter[value="vehicle"]').click()
    shown = [r for r in browser.find_elements("css selector", "#events .ev") if r.is_displayed()]
    assert len(shown) == 3
    browser.find_element("css selector", 'input.kindfilter[value="vehicle"]').click()
    # the vehicle filter: bravo's events only (the contact with alpha, the terrain)
    browser.find_element("id", "vehiclefilter").send_keys("bra")
    shown = [r.get_attribute("data-i") for r in browser.find_elements("css selector", "#events .ev") if r.is_displayed()]
    assert sorted(shown) == ["1", "2"]
    browser.find_element("id", "vehiclefilter").clear()
    browser.find_element("id", "vehiclefilter").send_keys(",")
    # playback pauses at the next event shown, at its time, and selects it
    browser.execute_script("window.tankcdReview.setTime(9.0)")
    browser.find_element("css selector", '#speed option[value="120"]').click()
    browser.find_element("id", "play").click()
    _wait(browser, 10).until(lambda d: d.find_element("id", "play").text == "play")
    assert browser.execute_script("return window.tankcdReview.time()") == pytest.approx(10.0, abs=1e-9)
    assert "selected" in browser.find_element("css selector", '#events .ev[data-i="0"]').get_attribute("class")
    severe = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe


def test_an_empty_review_in_a_browser(browser, tmp_path):
    out = tmp_path / "empty.html"
    write_page(type(small_review())((), []), _small_background(), str(out))
    _open(browser, out)
    assert browser.execute_script("return [window.tankcdReview.vehicles, window.tankcdReview.events]") == [[], 0]
    browser.execute_script("window.tankcdReview.setTime(3)")
    assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]


def _screenshot(driver, name: str):
    driver.execute_script("window.scrollTo(0, 0); document.getElementById('eventbox').scrollLeft = 0")
    driver.save_screenshot(str(ROOT / "docs" / name))


def _sample_replay(folder: Path):
    poses, events = folder / "poses.csv", folder / "events.jsonl"
    scene = str(SAMPLE / "scene.toml")
    api.replay_to_files(str(SAMPLE / "patrol.csv"), poses=str(poses), events=str(events), scene=scene)
    return read_replay(str(poses), str(events), settings={"scene": "scene.toml", "mode": "continuous"}), scene


def test_a_replay_of_the_sample_scene_in_a_browser(browser, tmp_path):
    review, scene = _sample_replay(tmp_path)
    out = tmp_path / "sample.html"
    write_page(review, terrain_background(api.load_world(scene=scene)), str(out))
    _open(browser, out)
    assert len(browser.find_elements("css selector", "#events .ev")) == len(review.events) > 50
    tr = review.tracks[0]
    rng = np.random.default_rng(1)
    _check_playback(browser, review, np.r_[tr.t[0], rng.uniform(tr.t[0], tr.t[-1], 25), tr.t[-1]])
    first = min(range(len(review.events)), key=lambda i: (review.events[i]["t"], i))
    _click_event(browser, first, review.events[first]["t"])
    if SCREENSHOTS:
        _screenshot(browser, "report_sample.png")


def test_an_exercise_in_a_browser(browser, tmp_path):
    """The exercise of three vehicles the golden outputs pin (tests/replay/test_golden_outputs.py)."""
    golden = ROOT / "tests" / "golden" / "outputs" / "exercise"
    review = read_replay(str(golden / "poses.csv"), str(golden / "events.jsonl"))
    out = tmp_path / "exercise.html"
    write_page(review, terrain_background(api.load_world(scene=str(SAMPLE / "scene.toml"))), str(out))
    _open(browser, out)
    assert browser.execute_script("return window.tankcdReview.vehicles") == ["lead", "close", "back"]
    assert len(browser.find_elements("css selector", "#events .ev")) == len(review.events)
    _check_playback(browser, review, np.linspace(0.0, 52.9, 17))
    contact = next(i for i, e in enumerate(review.events) if e["kind"] == "vehicle")
    _click_event(browser, contact, review.events[contact]["t"])
    if SCREENSHOTS:
        _screenshot(browser, "report_exercise.png")
