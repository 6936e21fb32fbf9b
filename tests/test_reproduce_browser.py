"""The report of a real (small) ``bipedlab reproduce --quick`` run, opened in headless Chromium:
no console errors, every image and the animation load, every paper's section and table with its
rows, and a screenshot. The run is two cheap experiments (ATRIAS on flat ground, which also
draws the gait animation, and the seven-link free swing); the other experiments are reported as
not run, so every section and table is still there.

Needs Debian's ``chromium`` and ``chromium-driver`` and the ``selenium`` package (test extra);
skipped without them. ``BIPEDLAB_SCREENSHOT=path.png`` also copies the screenshot there."""
from __future__ import annotations

import contextlib
import io
import json
import os
import shutil

import pytest

from bipedlab.cli import main

PAPERS = ("identification", "hzd", "running", "seven-link")
ONLY = ("running/flat", "seven-link/free-swing")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    root = tmp_path_factory.mktemp("reproduce")
    old = os.environ.get("BIPEDLAB_CACHE_DIR")
    os.environ["BIPEDLAB_CACHE_DIR"] = str(root / "cache")
    argv = ["reproduce", "--quick", "--json", "--out", str(root / "report")]
    for o in ONLY:
        argv += ["--only", o]
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    finally:
        if old is None:
            os.environ.pop("BIPEDLAB_CACHE_DIR", None)
        else:
            os.environ["BIPEDLAB_CACHE_DIR"] = old
    assert code == 0, err.getvalue()
    return root / "report", out.getvalue(), err.getvalue()


def test_json_on_stdout_is_the_report(report):
    folder, stdout, stderr = report
    rec = json.loads(stdout)
    assert rec == json.loads((folder / "report.json").read_text()) | {k: rec[k] for k in ("index_html", "report_json")}
    for key in ("papers", "version", "device", "quick", "wall_s"):
        assert key in rec
    assert rec["quick"] is True and tuple(rec["papers"]) == PAPERS
    for key, p in rec["papers"].items():
        assert p["rows"] and p["experiments"]
        for r in p["rows"]:
            assert {"quantity", "paper", "source", "bipedlab", "tolerance", "agrees", "why"} <= set(r)
        for e in p["experiments"]:
            assert {"wall_s", "compile_s"} <= set(e)
    ran = {f"{k}/{e['name']}" for k, p in rec["papers"].items() for e in p["experiments"] if not e["skipped"]}
    assert ran == set(ONLY)
    assert "expected duration" in stderr and "[1/2]" in stderr and "[2/2]" in stderr
    rows = {r["id"]: r for r in rec["papers"]["running"]["rows"]}
    # "stabilises the gait" holds only with both steady errors within their rows' bands
    steady = rows["flat_apex_error_m"]["agrees"] and rows["flat_speed_error_mps"]["agrees"]
    assert rows["flat_success"]["bipedlab"] == float(steady) and rows["flat_success"]["agrees"] is steady


def _browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    chrome = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    driver_path = shutil.which("chromedriver")
    if not chrome or not driver_path:
        pytest.skip("Chromium and chromedriver are not installed (apt-get install chromium chromium-driver)")
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = chrome
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1280,1000"):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver_path), options=opts)


def test_report_opens_in_headless_chromium(report):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    folder, stdout, _ = report
    rec = json.loads(stdout)
    driver = _browser()
    try:
        driver.get((folder / "index.html").resolve().as_uri())
        WebDriverWait(driver, 30).until(lambda d: d.execute_script(
            "return document.readyState === 'complete' && Array.from(document.images).every(i => i.complete)"))
        severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        assert not severe, severe
        images = driver.find_elements(By.TAG_NAME, "img")
        assert len(images) >= 3
        for img in images:
            assert driver.execute_script("return arguments[0].naturalWidth", img) > 0, img.get_attribute("src")
        for key in PAPERS:
            section = driver.find_element(By.ID, key)
            body = section.find_elements(By.CSS_SELECTOR, "table.rows tbody tr")
            assert len(body) == len(rec["papers"][key]["rows"]) > 0, key
            assert section.find_element(By.TAG_NAME, "h2").text
        frames = driver.find_elements(By.CSS_SELECTOR, "iframe.animation")
        assert len(frames) == 1
        # every file the experiments wrote is linked from its experiment's row, and exists
        from pathlib import Path
        from urllib.parse import unquote, urlparse

        from bipedlab.report import check

        assert check.unlinked(folder) == []
        links = driver.find_elements(By.CSS_SELECTOR, "table.experiments details a")
        assert len(links) >= 3
        for a in links:
            assert Path(unquote(urlparse(a.get_attribute("href")).path)).is_file(), a.get_attribute("href")
        height = driver.execute_script("return document.documentElement.scrollHeight")
        driver.set_window_size(1280, min(int(height) + 100, 16000))
        shot = folder / "screenshot.png"
        assert driver.save_screenshot(str(shot)) and shot.stat().st_size > 10_000
        if os.environ.get("BIPEDLAB_SCREENSHOT"):
            shutil.copy(shot, os.environ["BIPEDLAB_SCREENSHOT"])
        driver.switch_to.frame(frames[0])
        WebDriverWait(driver, 20).until(lambda d: d.execute_script("return document.readyState") == "complete")
        canvas = driver.find_element(By.TAG_NAME, "canvas")
        assert int(canvas.get_attribute("width")) > 0
        assert driver.execute_script("return !!document.getElementById('bipedlab-animation')")
        severe = [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        assert not severe, severe
    finally:
        driver.quit()
