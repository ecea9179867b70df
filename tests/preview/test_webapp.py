"""The preview page and its API, served for real (uvicorn), and driven in a headless browser."""

import base64
import json
import shlex
import shutil
import socket
import threading
import time
import urllib.error
import urllib.request

import cv2
import numpy as np
import pytest
import uvicorn

from unjello.io.frames import read_image, write_image
from unjello.preview import PreviewClip, PreviewSettings, create_app
from unjello.simulate import Motion, simulate
from unjello.timing import SensorTiming

from ..runner import clean_failure, run

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def clip_dir(tmp_path_factory, scene):
    folder = tmp_path_factory.mktemp("preview") / "in"
    folder.mkdir()
    for i, s in enumerate(simulate(scene, Motion("shake"), SensorTiming(0.7), 9,
                                   size=(240, 180))):
        write_image(folder / f"f{i:03d}.png", s.rolling)
    return folder


@pytest.fixture(scope="module")
def server(clip_dir):
    """The app on a free port of 127.0.0.1, in a thread; yields its base URL."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    clip = PreviewClip(clip_dir)
    srv = uvicorn.Server(uvicorn.Config(create_app(clip), host="127.0.0.1", port=port,
                                        log_level="warning"))
    thread = threading.Thread(target=srv.run, daemon=True)
    thread.start()
    for _ in range(200):
        if srv.started:
            break
        time.sleep(0.05)
    yield f"http://127.0.0.1:{port}"
    srv.should_exit = True
    thread.join(timeout=10)
    clip.close()


def _get(url):
    try:
        with urllib.request.urlopen(url, timeout=60) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def _png(data):
    return cv2.cvtColor(cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR),
                        cv2.COLOR_BGR2RGB)


def _correct_with(command, tmp_path, n):
    """Run the page's command line (its output redirected) and return frame n."""
    args = shlex.split(command)
    assert args[:2] == ["unjello", "correct"]
    args[args.index("-o") + 1] = str(tmp_path / "out")
    res = run(*args[1:])
    assert res.returncode == 0, res.stderr
    return read_image(tmp_path / "out" / f"f{n:03d}.png")


def test_api(server, clip_dir, tmp_path):
    status, _, body = _get(server + "/api/info")
    info = json.loads(body)
    assert status == 200 and info["frames"] == 9 and info["width"] == 240
    assert info["settings"]["readout"] == 1.0 and info["readout_source"] == "default"
    # What the footage says of the readout, marked on the slider: the clip's (hand shake,
    # readout 0.7) motion tells it.
    est = info["readout_estimate"]
    assert est["reliable"] and est["cue"] == "motion"
    assert est["readout"] == pytest.approx(0.7, abs=0.05) and est["uncertainty"] > 0
    status, headers, body = _get(server + "/api/frame/4.png?view=corrected&readout=0.7")
    assert status == 200 and headers["content-type"] == "image/png"
    assert float(headers["x-render-seconds"]) > 0
    corrected = _png(body)
    _, _, body = _get(server + "/api/command?readout=0.7")
    command = json.loads(body)["command"]
    assert "--readout 0.7" in command
    # The page's command gives the frame the page shows, to the last level.
    assert np.array_equal(corrected, _correct_with(command, tmp_path, 4))
    _, _, raw = _get(server + "/api/frame/4.png?view=input")
    assert np.array_equal(_png(raw), read_image(clip_dir / "f004.png"))
    status, headers, body = _get(server + "/api/preset.json?readout=0.65&method=paper")
    assert status == 200 and json.loads(body)["readout"] == 0.65
    assert json.loads(body)["method"] == "paper"
    status, _, body = _get(server + "/api/motion.png?frame=4&readout=0.7")
    assert status == 200 and body[:4] == b"\x89PNG"


@pytest.mark.parametrize("query, said", [
    ("/api/frame/99.png", "no frame 99"),
    ("/api/frame/x.png", "whole number"),
    ("/api/frame/1.png?readout=abc", "readout must be a number"),
    ("/api/frame/1.png?readout=1.5", "readout must be a fraction"),
    ("/api/frame/1.png?method=gyro", "the preview shows the methods"),
    ("/api/frame/1.png?view=other", "view must be"),
    ("/api/frame/..%2F..%2Fetc%2Fpasswd.png", "no such page"),
    ("/etc/passwd", "no such page"),
])
def test_bad_requests_get_one_line_and_the_server_goes_on(server, query, said):
    status, _, body = _get(server + query)
    assert status == (404 if "page" in said else 400)
    error = json.loads(body)["error"]
    assert said in error and "\n" not in error
    assert _get(server + "/api/info")[0] == 200


def test_settings_read_from_a_query():
    base = PreviewSettings(readout=0.9)
    s = PreviewSettings.from_query({"readout": "0.5", "camera_only": "1"}, base)
    assert s.readout == 0.5 and s.camera_only and s.method == "dense"
    assert "--camera-only" in s.command("in.mp4", "out.mp4")
    assert PreviewSettings.from_query({}, base) == base
    # The readout is kept as the command line says it (a database value: 21.69 ms at 29.97).
    assert PreviewSettings(readout=0.649999).readout == 0.65


def test_preview_command_refuses_bad_input(tmp_path):
    line = clean_failure(run("preview", tmp_path / "nope.mp4", "--no-browser"))
    assert "no such file" in line
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        line = clean_failure(run("preview", tmp_path, "--no-browser", "--port", port))
    assert "in use" in line


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if not (CHROMIUM and DRIVER):
        pytest.skip("no headless browser here: install Debian's chromium and chromium-driver")
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                "--disable-background-networking", "--disable-component-update",
                "--disable-sync", "--no-first-run", "--window-size=1400,1000",
                f"--user-data-dir={tmp_path_factory.mktemp('chromium')}"):
        opts.add_argument(arg)
    from selenium.common.exceptions import WebDriverException

    try:
        driver = webdriver.Chrome(service=Service(DRIVER), options=opts)
    except WebDriverException as exc:  # installed but cannot start here (no sandbox, ...)
        pytest.skip(f"chromium is installed but did not start: {exc.msg}")
    yield driver
    driver.quit()


def _wait(driver, condition, timeout=60):
    end = time.time() + timeout
    while time.time() < end:
        if condition():
            return
        time.sleep(0.1)
    raise AssertionError("the page did not get there: "
                         + driver.execute_script("return document.getElementById('status')"
                                                 ".textContent"))


def _shown(driver, img_id):
    """The pixels an <img> shows, read back through a canvas."""
    url = driver.execute_script(
        "const i = document.getElementById(arguments[0]);"
        "const c = document.createElement('canvas');"
        "c.width = i.naturalWidth; c.height = i.naturalHeight;"
        "c.getContext('2d').drawImage(i, 0, 0); return c.toDataURL('image/png');", img_id)
    return _png(base64.b64decode(url.split(",", 1)[1]))


def test_page_in_a_browser(server, browser, tmp_path):
    browser.get(server + "/")
    _wait(browser, lambda: browser.execute_script("return document.body.dataset.rendered")
          is not None and browser.execute_script("return document.body.dataset.state")
          == "idle")
    before = _shown(browser, "corrected")
    # Move the readout control (its number box, as a user types) and wait for the frame.
    box = browser.find_element("id", "readout_num")
    box.clear()
    box.send_keys("0.7\n")
    browser.execute_script("document.getElementById('readout_num')"
                           ".dispatchEvent(new Event('change'))")
    _wait(browser, lambda: "readout=0.7" in (browser.execute_script(
        "return document.body.dataset.rendered") or "") and browser.execute_script(
        "return document.body.dataset.state") == "idle")
    after = _shown(browser, "corrected")
    assert np.abs(after.astype(int) - before.astype(int)).mean() > 0.5
    command = browser.find_element("id", "command").text
    assert "--readout 0.7" in command
    # What the page shows is what `unjello correct` writes with the page's command.
    expected = _correct_with(command, tmp_path, 0)
    assert np.abs(after.astype(int) - expected.astype(int)).max() <= 1
    assert "corrected in" in browser.find_element("id", "status").text


@pytest.mark.slow
def test_preview_undistorts_with_the_camera_databases_lens(shared_data):
    """`correct --undistort` finds the Karma's lens in the camera database; the preview
    must too (it answered every frame with "undistort needs the lens")."""
    from unjello.config import CorrectionConfig

    src = shared_data / "sequences" / "gopro_gpmf" / "karma.mp4"
    with PreviewClip(src, CorrectionConfig(undistort=True), max_frames=8) as clip:
        assert clip.base.gyro.focal is not None and clip.base.gyro.distortion is not None
        assert clip.initial.readout == pytest.approx(0.5, abs=1e-3)  # the database's (16.68 ms)
        out, _ = clip.corrected(3, clip.initial)
        plain = PreviewClip(src, CorrectionConfig(), max_frames=8)
        with plain:
            kept, _ = plain.corrected(3, plain.initial)
    assert out.shape == kept.shape
    assert float(np.abs(out.astype(float) - kept).mean()) > 1.0  # the curvature taken out
