#!/usr/bin/env python3
"""Saves a picture of the live view, for the README.

    /usr/bin/python3 tests/web/screenshot.py "http://127.0.0.1:8080/?mission=m-000001" docs/images/live-view.png

Opens the page in headless Chromium (the DevTools client of
live_view_test.py), waits until the mission is drawn and writes a PNG.
"""
import base64
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import websocket

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from live_view_test import TIMEOUT_S, DevTools, wait_for  # noqa: E402
from oaipp_server import stop  # noqa: E402 (live_view_test put it on the path)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    url, out = sys.argv[1], sys.argv[2]
    work = tempfile.mkdtemp(prefix="oaipp-screenshot-")
    log = open(os.path.join(work, "chromium.log"), "w+")
    browser = subprocess.Popen(
        ["chromium", "--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         "--remote-debugging-port=0", "--remote-debugging-address=127.0.0.1",
         f"--user-data-dir={work}/profile", "--window-size=1400,760", "about:blank"],
        stdout=subprocess.DEVNULL, stderr=log)
    try:
        endpoint = None
        deadline = time.time() + TIMEOUT_S
        while endpoint is None and time.time() < deadline:
            log.seek(0)
            found = re.search(r"DevTools listening on (ws://\S+)", log.read())
            endpoint = found.group(1) if found else None
            time.sleep(0.1)
        if endpoint is None:
            sys.exit("chromium did not start")
        port = int(re.search(r":(\d+)/", endpoint).group(1))
        root = DevTools(websocket, endpoint)
        target = root.send("Target.createTarget", url=url)["targetId"]
        root.close()
        page = DevTools(websocket, f"ws://127.0.0.1:{port}/devtools/page/{target}")
        wait_for(page, "Number(document.body.dataset.draws || 0) >= 1", "the mission drawn")
        time.sleep(1.0)
        shot = page.send("Page.captureScreenshot", format="png")
        with open(out, "wb") as f:
            f.write(base64.b64decode(shot["data"]))
        page.close()
        print(f"wrote {out}")
    finally:
        stop(browser)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
