#!/usr/bin/env python3
"""The live mission view in a real headless Chromium.

Starts the real oaipp-server (memory store, tokens, the view on a free
loopback port) and Chromium, opens the page as a ground station's operator
would (/?mission=...#token=...), drives it over the DevTools protocol and
checks on the page itself, without reloading it:
  0. the page logs in with the token from the fragment, removes it from the
     address bar, and no request it makes carries the token in its URL
     (every URL Chromium requests is recorded), the event stream included;
  1. the mission created over gRPC appears in the list and is drawn;
  2. after AddMeasurement the page shows one measurement and the picture
     (a hash of the canvas pixels) changes;
  3. after PlanPath the event number goes up and the picture changes again;
  4. no script on the page threw.
With --screenshot, the page is saved as a PNG at the end.

Usage: live_view_test.py --server-binary PATH --python-stubs DIR
                         [--chromium PATH] [--screenshot OUT.png]
Exit 0: pass; 1: fail; 77: skipped (no chromium or websocket module).
"""
import argparse
import base64
import hashlib
import itertools
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from oaipp_server import OaippServer, free_port, stop  # noqa: E402

SKIP = 77
TIMEOUT_S = 20.0


class DevTools:
    """A minimal Chrome DevTools Protocol client on one target.

    Calls are answered in order on one connection; events that arrive while
    waiting for an answer are dropped, except uncaught exceptions (after
    Runtime.enable), which are kept in `exceptions`.
    """

    def __init__(self, websocket_module, url):
        # Chromium refuses DevTools connections that carry an Origin header.
        self._ws = websocket_module.create_connection(url, timeout=TIMEOUT_S,
                                                      suppress_origin=True)
        self._ids = itertools.count(1)
        self.exceptions = []
        self.requested_urls = []  # after Network.enable

    def send(self, method, **params):
        call_id = next(self._ids)
        self._ws.send(json.dumps({"id": call_id, "method": method, "params": params}))
        deadline = time.time() + TIMEOUT_S
        while time.time() < deadline:
            message = json.loads(self._ws.recv())
            if message.get("method") == "Network.requestWillBeSent":
                self.requested_urls.append(message["params"]["request"]["url"])
            if message.get("method") == "Runtime.exceptionThrown":
                details = message["params"]["exceptionDetails"]
                self.exceptions.append(
                    details.get("exception", {}).get("description") or details.get("text"))
            if message.get("id") == call_id:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
        raise TimeoutError(method)

    def evaluate(self, expression):
        result = self.send("Runtime.evaluate", expression=expression, returnByValue=True)
        return result.get("result", {}).get("value")

    def close(self):
        self._ws.close()


def wait_for(page, expression, what):
    """Polls `expression` on the page until it is truthy (bounded)."""
    deadline = time.time() + TIMEOUT_S
    value = None
    while time.time() < deadline:
        value = page.evaluate(expression)
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what} (last value {value!r})")


def page_state(page):
    return page.evaluate(
        "JSON.stringify({mission: document.body.dataset.mission || '',"
        " sequence: document.body.dataset.sequence || '',"
        " measurements: document.body.dataset.measurements || '',"
        " hash: document.body.dataset.canvasHash || '',"
        " title: (document.getElementById('title') || {}).textContent || '',"
        " status: (document.getElementById('status') || {}).textContent || ''})")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-binary", required=True)
    parser.add_argument("--python-stubs", required=True)
    parser.add_argument("--chromium", default=shutil.which("chromium") or "")
    parser.add_argument("--screenshot", default="")
    args = parser.parse_args()
    if not args.chromium or not os.path.exists(args.chromium):
        print("SKIP: chromium not found (deploy/install-deps.sh installs it)")
        return SKIP
    try:
        import websocket  # python3-websocket
        import grpc
    except ImportError as e:
        print(f"SKIP: {e.name} is not installed (deploy/install-deps.sh installs it)")
        return SKIP
    sys.path.insert(0, args.python_stubs)
    from oaipp.v1 import mission_service_pb2 as pb
    from oaipp.v1 import mission_service_pb2_grpc as rpc

    work = tempfile.mkdtemp(prefix="oaipp-live-view-")
    web_port = free_port()
    token = "live-view-" + os.urandom(8).hex()
    with open(os.path.join(work, "tokens"), "w") as f:
        f.write(f"alpha {hashlib.sha256(token.encode()).hexdigest()}\n")
    auth = [("authorization", "Bearer " + token)]
    server = OaippServer(args.server_binary, [f"--web_port={web_port}",
                                              f"--token_file={os.path.join(work, 'tokens')}"])
    browser = None
    browser_log = None
    page = None
    try:
        server.__enter__()
        stub = rpc.MissionServiceStub(grpc.insecure_channel(server.address))
        stub.CreateMission(pb.CreateMissionRequest(
            mission_id="view-test",
            spec=pb.MissionSpec(obstacles=[pb.Obstacle(
                id="house", box=pb.Box(centre_m=pb.Vector3(x=5, y=5, z=4),
                                       size_m=pb.Vector3(x=4, y=6, z=8)))])), timeout=30,
            metadata=auth)
        print("PASS created mission view-test over gRPC")

        browser_log = open(os.path.join(work, "chromium.log"), "w+")
        browser = subprocess.Popen(
            [args.chromium, "--headless=new", "--no-sandbox", "--disable-gpu",
             "--no-first-run", "--disable-extensions", "--remote-debugging-port=0",
             "--remote-debugging-address=127.0.0.1", f"--user-data-dir={work}/profile",
             "--window-size=1400,800", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=browser_log)
        deadline = time.time() + TIMEOUT_S
        endpoint = None
        while time.time() < deadline and endpoint is None:
            browser_log.seek(0)
            found = re.search(r"DevTools listening on (ws://\S+)", browser_log.read())
            if found:
                endpoint = found.group(1)
            elif browser.poll() is not None:
                break
            else:
                time.sleep(0.1)
        if endpoint is None:
            browser_log.seek(0)
            raise AssertionError("chromium did not start: " + browser_log.read()[-2000:])
        # A page target of its own, then its websocket.
        devtools_port = int(re.search(r":(\d+)/", endpoint).group(1))
        browser_ws = DevTools(websocket, endpoint)
        target = browser_ws.send("Target.createTarget", url="about:blank")["targetId"]
        browser_ws.close()
        page = DevTools(websocket,
                        f"ws://127.0.0.1:{devtools_port}/devtools/page/{target}")
        page.send("Runtime.enable")
        page.send("Network.enable")
        url = f"http://127.0.0.1:{web_port}/?mission=view-test#token={token}"
        page.send("Page.navigate", url=url)

        # 1. The mission is listed and drawn.
        wait_for(page, "document.querySelector('li[data-mission=\"view-test\"]') !== null",
                 "the mission in the list")
        wait_for(page, "document.body.dataset.mission === 'view-test' && "
                       "!!document.body.dataset.canvasHash", "the mission drawn")
        first = json.loads(page_state(page))
        assert first["measurements"] == "0", f"expected 0 measurements on the page: {first}"
        assert "view-test" in first["title"], f"the title does not name the mission: {first}"
        print(f"PASS the page lists and draws view-test (canvas {first['hash']})")

        # 2. A measurement: a person seen below (-5, -5), 10 m up.
        col, row = int((-5 + 15) / 0.75), int((-5 + 15) / 0.75)
        cells, labels = [], []
        for dr in range(-2, 3):
            for dc in range(-2, 3):
                cells.append((row + dr) * 40 + col + dc)
                labels.append(1.0 if dr == 0 and dc == 0 else 0.0)
        stub.AddMeasurement(pb.AddMeasurementRequest(
            name="missions/view-test", mission_time_s=1.0,
            camera_position_m=pb.Vector3(x=-5, y=-5, z=10),
            labels=pb.CellLabels(cells=cells, labels=labels), request_id="m-1"), timeout=30,
            metadata=auth)
        wait_for(page, "document.body.dataset.measurements === '1' && "
                       f"document.body.dataset.canvasHash !== '{first['hash']}'",
                 "the measurement on the page")
        second = json.loads(page_state(page))
        assert second["status"].strip(), "the status line is empty"
        assert "1 measurement," in second["title"], f"the title misses the measurement: {second}"
        print(f"PASS after AddMeasurement the page shows 1 measurement and a new picture "
              f"(canvas {second['hash']}), without a reload")

        # 3. A plan: the planned path appears.
        stub.PlanPath(pb.PlanPathRequest(
            name="missions/view-test",
            state=pb.UavState(position_m=pb.Vector3(x=0, y=0, z=10), mission_time_s=2.0),
            planning_budget_s=2.0), timeout=60, metadata=auth)
        wait_for(page, f"Number(document.body.dataset.sequence) > {int(second['sequence'])} && "
                       f"document.body.dataset.canvasHash !== '{second['hash']}'",
                 "the plan on the page")
        third = json.loads(page_state(page))
        print(f"PASS after PlanPath the event number went from {second['sequence']} to "
              f"{third['sequence']} and the picture changed (canvas {third['hash']})")
        # Same page, never reloaded: the draw counter only grew.
        draws = int(page.evaluate("document.body.dataset.draws"))
        assert draws >= 3, f"expected at least 3 redraws of the same page, got {draws}"
        print(f"PASS title: {third['title']!r}; status: {third['status']!r}")

        # 0. The token never reached a URL the page requested, and the
        # fragment that carried it is gone from the address bar.
        page.evaluate("0")
        urls = [u for u in page.requested_urls if u.startswith("http")]
        assert any(u.endswith("/events") for u in urls), f"no event stream requested: {urls}"
        assert any("/api/session" in u for u in urls), f"no login: {urls}"
        for u in urls:
            assert token not in u.split("#")[0] and "token=" not in u.split("#")[0], \
                f"a request carried the token in its URL: {u}"
        href = page.evaluate("location.href")
        assert token not in href, f"the token stayed in the address bar: {href}"
        print(f"PASS {len(urls)} requests (login, data, event stream), none with the token "
              "in its URL; the address bar no longer holds it")

        # 4. Uncaught exceptions would leave a stale picture behind.
        page.evaluate("0")
        assert not page.exceptions, f"the page threw: {page.exceptions}"
        print("PASS no uncaught exception on the page")

        if args.screenshot:
            shot = page.send("Page.captureScreenshot", format="png")
            with open(args.screenshot, "wb") as f:
                f.write(base64.b64decode(shot["data"]))
            print(f"wrote {args.screenshot}")
        return 0
    except Exception as e:  # report, with the server's last words
        print(f"FAIL: {e}")
        print("server log (tail):\n" + server.log_tail())
        return 1
    finally:
        if page is not None:
            page.close()
        stop(browser)
        if browser_log is not None:
            browser_log.close()
        server.__exit__(None, None, None)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
