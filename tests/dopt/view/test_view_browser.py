"""The acceptance test of ``dopt-view``: the console script serves a committed pick-and-place
trial and an MPC episode, a real headless Chromium (the distribution's ``chromium`` and
``chromium-driver``, driven by selenium) loads the page, and screenshots show that the scene is
drawn (the cloth's colour, or the shaded objects' red, covers a stated share of the scene's
part of the frame) and that clicking Next changes it; the page shows the legend (every marker
of the episode by name), the goal (the pick goal's ghost in the legend, the MPC goal object's
and target's tags in the scene), the floor's scale bar, and on every plot a dark vertical
cursor that moves right when Next is clicked. Skips, with the reason, where no
browser, driver, selenium or viser is installed (CI installs them: .ci/run, Makefile)."""

from __future__ import annotations

import io
import os
import queue
import re
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from tests.dopt.view.test_view import BIN, committed_trial, write_mpc_trial

#: the browser window (px); the viewer's panel covers the right of it
WINDOW = (1280, 800)
#: the scene's part of a screenshot: left of the panel
SCENE_COLUMNS = slice(0, 930)
#: share of the scene's pixels the cloth (its colour .8 .3 .2) must cover: measured 11.8 % at
#: frame 20 of the diagonal fold's CEM(Simple) seed 0 (in swiftshader's software WebGL)
CLOTH_SHARE = 0.05
#: share the shaded cylinders (baseline: every DoF in C, red) must cover: measured 0.9 %
OBJECT_SHARE = 0.004
#: share of the scene's pixels that must change when Next is clicked: measured 1.2 % (cloth,
#: 15 clicks) and 0.73 % (MPC, 39 clicks); the test prints its numbers (pytest -s)
CHANGED_SHARE = 0.002


def _need_browser() -> tuple[str, str]:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not (chromium and driver):
        pytest.skip("no headless browser: apt-get install chromium chromium-driver")
    pytest.importorskip("selenium", reason="selenium is not installed (the dev extra)")
    pytest.importorskip("viser", reason="viser is not installed (the viz extra)")
    if not (BIN / "dopt-view").exists():
        pytest.skip(f"dopt-view is not installed in {BIN} (pip install -e '.[viz]')")
    return chromium, driver


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Served:
    """``dopt-view PATH ARGS`` in a subprocess; ``url`` from the line it prints."""

    def __init__(self, path: Path, *args: str):
        env = {**os.environ, "MUJOCO_GL": "egl", "OMP_NUM_THREADS": "1"}
        self.proc = subprocess.Popen([str(BIN / "dopt-view"), str(path), "--port",
                                      str(_free_port()), *args], stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, env=env)
        lines: queue.Queue = queue.Queue()
        threading.Thread(target=lambda: [lines.put(x) for x in self.proc.stdout],
                         daemon=True).start()
        seen, deadline = [], time.monotonic() + 180
        while time.monotonic() < deadline:
            try:
                line = lines.get(timeout=1)
            except queue.Empty:
                if self.proc.poll() is not None:
                    break
                continue
            seen.append(line)
            m = re.search(r"^dopt-view: .* at (http://\S+)", line)
            if m:
                self.url = m.group(1)
                return
        self.close()
        raise AssertionError("dopt-view printed no URL:\n" + "".join(seen))

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def _browser(chromium: str, driver: str):
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                f"--window-size={WINDOW[0]},{WINDOW[1]}"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(driver), options=options)


def _shot(browser) -> np.ndarray:
    from PIL import Image

    png = browser.get_screenshot_as_png()
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)[:, SCENE_COLUMNS]


def _red_share(image: np.ndarray) -> float:
    """Share of pixels whose red stands well above green and blue (the cloth's .8 .3 .2, the
    shade's 200 30 30, lit or in shadow)."""
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return float(((r > g + 50) & (r > b + 50) & (r > 90)).mean())


def _wait_for(browser, share: float, timeout: float = 90) -> tuple[np.ndarray, float]:
    """Screenshots until the red share reaches ``share`` (the page loads, WebGL draws)."""
    deadline, best = time.monotonic() + timeout, (None, -1.0)
    while time.monotonic() < deadline:
        image = _shot(browser)
        s = _red_share(image)
        best = max(best, (image, s), key=lambda x: x[1])
        if s >= share:
            return image, s
        time.sleep(1)
    return best


def _click_next(browser, times: int) -> None:
    from selenium.webdriver.common.by import By

    button = browser.find_element(By.XPATH, "//button[normalize-space()='Next']")
    for _ in range(times):
        browser.execute_script("arguments[0].click();", button)
        time.sleep(0.2)


def _page_text(browser) -> str:
    return browser.find_element("tag name", "body").text


def _cursor_columns(browser) -> list[int]:
    """Per plot (uPlot canvas) the column of its cursor: the column holding the longest run
    of dark pixels (the cursor spans the curve's range; text and grid lines do not), -1
    where no column holds a run of a third of the canvas's height."""
    from PIL import Image
    from selenium.webdriver.common.by import By

    found = []
    for canvas in browser.find_elements(By.CSS_SELECTOR, ".uplot canvas"):
        browser.execute_script("arguments[0].scrollIntoView({block: 'center'});", canvas)
        time.sleep(0.5)
        box = browser.execute_script(
            "const r = arguments[0].getBoundingClientRect();"
            "return [r.left, r.top, r.right, r.bottom, window.devicePixelRatio];", canvas)
        shot = Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
        left, top, right, bottom = (int(round(v * box[4])) for v in box[:4])
        image = np.asarray(shot.crop((left, top, right, bottom)))
        dark = (image.astype(int).max(axis=-1) < 90)
        runs = np.zeros(dark.shape[1], dtype=int)
        for c in range(dark.shape[1]):
            col, best, cur = dark[:, c], 0, 0
            for v in col:
                cur = cur + 1 if v else 0
                best = max(best, cur)
            runs[c] = best
        c = int(np.argmax(runs))
        found.append(c if runs[c] >= dark.shape[0] / 3 else -1)
    return found


def _caption(browser) -> str:
    m = re.search(r"frame \d+/\d+", browser.find_element("tag name", "body").text)
    return m.group(0) if m else ""


def _check(path: Path, share: float, next_clicks: int, *args: str,
           words: tuple[str, ...] = ()) -> None:
    """Serve ``path``, check the drawing, the legend and ``words`` (the goal's names and
    tags, the scale bar's length) on the page, and that Next moves the frame, the scene and
    every plot's cursor."""
    chromium, driver = _need_browser()
    served = Served(path, *args)
    browser = _browser(chromium, driver)
    try:
        browser.get(served.url)
        before, s0 = _wait_for(browser, share)
        assert s0 >= share, f"the scene is not drawn: red share {s0:.4f} < {share}"
        text = _page_text(browser)
        missing = [w for w in ("legend", "scale bar", *words) if w not in text]
        assert not missing, f"the page does not show {missing}:\n{text}"
        assert re.search(r"\b\d+ (cm|mm|m)\b", text), "no scale bar length on the page"
        cursors = _cursor_columns(browser)
        assert cursors and min(cursors) >= 0, f"a plot without its cursor: {cursors}"
        browser.execute_script("window.scrollTo(0, 0);")
        caption = _caption(browser)
        _click_next(browser, next_clicks)
        deadline = time.monotonic() + 30
        while _caption(browser) == caption and time.monotonic() < deadline:
            time.sleep(0.5)
        time.sleep(2)                               # the new frame reaches the canvas
        after = _shot(browser)
        changed = float((np.abs(after - before).sum(axis=-1) > 30).mean())
        print(f"{path.name}: red share {s0:.4f}, after {next_clicks} x Next "
              f"({caption} -> {_caption(browser)}) {changed:.4f} of the scene changed",
              file=sys.stderr)
        assert _caption(browser) != caption, "Next did not move the frame"
        assert changed >= CHANGED_SHARE, f"stepping changed only {changed:.4f} of the scene"
        moved = _cursor_columns(browser)
        print(f"cursor columns {cursors} -> {moved}", file=sys.stderr)
        assert moved[0] > cursors[0], f"the time plot's cursor did not move right: " \
                                      f"{cursors} -> {moved}"
    finally:
        browser.quit()
        served.close()


@pytest.mark.slow
def test_browser_draws_and_steps_a_committed_cloth_trial():
    path = committed_trial("fig7-ours-cloth-diagonal", "simple-seed0-*.json")
    _check(path, CLOTH_SHARE, 15, "--frame", "20",
           words=("key particles", "key particles on the goal", "picked particle",
                  "place target", "goal shape", "cloth, top face", "cloth, underside"))


@pytest.mark.slow
def test_browser_draws_and_steps_an_mpc_episode(tmp_path):
    _need_browser()
    trial = write_mpc_trial(tmp_path / "clutter-baseline-seed0.json")
    # from the first optimisation (frame 0 comes before it, unshaded) to the end
    _check(trial["path"], OBJECT_SHARE, 39, "--frame", "1",
           words=("goal region", "goal object (its centre)", "goal target", "object shade",
                  "goal object", "target"))
