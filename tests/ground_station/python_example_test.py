#!/usr/bin/env python3
"""Runs examples/python/ground_station.py against the real server binary.

Starts oaipp-server on a free loopback port (memory store), runs the example
(a mission created by latitude/longitude, simulated detections, replans, a
.plan written), then checks from outside the example: the server holds the
mission with the measurements the example reported, and the .plan file is
QGroundControl JSON whose waypoints lie inside the geofence's inclusion
polygon.

Usage: python_example_test.py --server-binary PATH --stubs DIR --example PATH
Exit 0: pass; 1: fail; 77: skipped (grpc module missing).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from oaipp_server import OaippServer  # noqa: E402


def inside(polygon, lat, lon):
    hit = False
    for i in range(len(polygon)):
        (y1, x1), (y2, x2) = polygon[i - 1], polygon[i]
        if (y1 > lat) != (y2 > lat) and lon < (x2 - x1) * (lat - y1) / (y2 - y1) + x1:
            hit = not hit
    return hit


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server-binary", required=True)
    parser.add_argument("--stubs", required=True)
    parser.add_argument("--example", required=True)
    args = parser.parse_args()
    try:
        import grpc
    except ImportError:
        print("SKIP: python3-grpcio is not installed (deploy/install-deps.sh installs it)")
        return 77
    sys.path.insert(0, args.stubs)
    from oaipp.v1 import mission_service_pb2 as pb
    from oaipp.v1 import mission_service_pb2_grpc as rpc

    with tempfile.TemporaryDirectory(prefix="oaipp-python-example-") as work, \
            OaippServer(args.server_binary) as server:
        plan_path = os.path.join(work, "mission.plan")
        run = subprocess.run(
            ["/usr/bin/python3", args.example, "--server", server.address,
             "--stubs", args.stubs, "--out", plan_path, "--mission-id", "gs-test",
             "--steps", "3"],
            capture_output=True, text=True, timeout=240)
        print(run.stdout)
        if run.returncode != 0:
            print(run.stderr)
            print(f"FAIL: the example exited {run.returncode}\n{server.log_tail()}")
            return 1
        match = re.search(r"^RESULT mission=(\S+) measurements=(\d+) trace=(\S+) items=(\d+)",
                          run.stdout, re.M)
        if not match:
            print("FAIL: no RESULT line")
            return 1
        mission_id, measurements, items = match.group(1), int(match.group(2)), int(match.group(4))

        # The server's own view of the mission.
        stub = rpc.MissionServiceStub(grpc.insecure_channel(server.address))
        mission = stub.GetMission(pb.GetMissionRequest(name=f"missions/{mission_id}"), timeout=10)
        checks = [
            ("the mission has a geo_origin", mission.spec.HasField("geo_origin")),
            ("measurements were fused", mission.measurements_fused > 0),
            ("the example reported the server's count",
             mission.measurements_fused == measurements),
            ("it replanned", mission.paths_planned >= 2),
            ("obstacles given by latitude/longitude arrived", len(mission.obstacles) >= 2),
        ]
        with open(plan_path) as f:
            plan = json.load(f)
        fence = [p for p in plan["geoFence"]["polygons"] if p["inclusion"]]
        waypoints = [i for i in plan["mission"]["items"] if i["command"] == 16]
        checks += [
            ("the .plan is a QGroundControl plan",
             plan["fileType"] == "Plan" and plan["version"] == 1
             and plan["mission"]["version"] == 2),
            ("the .plan has as many items as the example reported",
             len(plan["mission"]["items"]) == items),
            ("waypoints use frame 3", all(w["frame"] == 3 for w in waypoints)),
            ("every waypoint lies inside the inclusion fence",
             len(fence) == 1 and waypoints
             and all(inside(fence[0]["polygon"], w["params"][4], w["params"][5])
                     for w in waypoints)),
        ]
        for name, ok in checks:
            print(("PASS " if ok else "FAIL ") + name)
        return 0 if all(ok for _, ok in checks) else 1


if __name__ == "__main__":
    sys.exit(main())
