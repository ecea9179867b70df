"""Take the README's screenshot of `unjello preview` in headless Chromium.

Usage::

    python scripts/preview_screenshot.py CLIP shot.png [--frame 5] [--readout 0.7]

Needs Debian's chromium and chromium-driver and the selenium package (the test extra).
"""

from __future__ import annotations

import argparse
import shutil
import socket
import tempfile
import threading
import time
from pathlib import Path

import uvicorn
from selenium import webdriver
from selenium.webdriver.chrome.service import Service

from unjello.preview import PreviewClip
from unjello.preview.webapp import create_app


def main() -> None:
    """Serve the clip, open the page, show the frame, save the screenshot."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("clip", type=Path)
    ap.add_argument("output", type=Path)
    ap.add_argument("--frame", type=int, default=5)
    ap.add_argument("--readout", type=float, default=None)
    args = ap.parse_args()
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with PreviewClip(args.clip) as clip, tempfile.TemporaryDirectory() as profile:
        server = uvicorn.Server(uvicorn.Config(create_app(clip), host="127.0.0.1", port=port,
                                               log_level="warning"))
        threading.Thread(target=server.run, daemon=True).start()
        while not server.started:
            time.sleep(0.05)
        opts = webdriver.ChromeOptions()
        opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
                    "--disable-background-networking", "--disable-component-update",
                    "--window-size=1400,1050", f"--user-data-dir={profile}"):
            opts.add_argument(arg)
        driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)
        try:
            driver.get(f"http://127.0.0.1:{port}/")
            script = ("const f = document.getElementById('frame_num'); f.value = arguments[0];"
                      "f.dispatchEvent(new Event('change'));")
            if args.readout is not None:
                script += ("const r = document.getElementById('readout_num');"
                           "r.value = arguments[1]; r.dispatchEvent(new Event('change'));")
            time.sleep(1.0)
            driver.execute_script(script, args.frame, args.readout)
            end = time.time() + 120
            while time.time() < end:
                done = driver.execute_script("return document.body.dataset.rendered || ''")
                idle = driver.execute_script("return document.body.dataset.state") == "idle"
                if f"frame={args.frame}" in done and idle:
                    break
                time.sleep(0.2)
            time.sleep(0.5)
            driver.save_screenshot(str(args.output))
        finally:
            driver.quit()
            server.should_exit = True
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
