#!/usr/bin/env python3
"""POST /api/v1/measurements/import timed over HTTP on loopback (issue 15; BENCHMARKS.md,
"Measurement import"): the 480 x 5 x 2 .mka file of measurement_import_benchmark, sent as the JSON
body a client sends, one request at a time on one keep-alive connection to a fresh server.

    build/bench/measurement_import_benchmark --write-mka /tmp/topography480.mka
    python3 bench/http_import_benchmark.py --server-bin build/server/gearloop-server \\
        --file /tmp/topography480.mka --requests 200

Prints the body size and the round-trip time per request (mean, median, 95th percentile, max),
which includes JSON encoding on the client, the transfer, the server's JSON parse and the
import (decode, parse, header check, Gordon interpolation, ISO 1328-1 figures) and the answer.
The request count is bounded and the server listens on 127.0.0.1 only.
"""
import argparse
import http.client
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time

SAMPLE_GEAR = {"teeth": 31, "normal_module_mm": 4.5, "normal_pressure_angle_deg": 20, "helix_angle_deg": 20,
               "hand": "right", "face_width_mm": 40, "tip_radius_mm": 78.726, "root_radius_mm": 68.601}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--server-bin", required=True)
    parser.add_argument("--file", required=True, help="a .mka file of the sample gear")
    parser.add_argument("--requests", type=int, default=200)
    args = parser.parse_args()
    if not 1 <= args.requests <= 10000:
        parser.error("--requests must be 1..10000")
    with open(args.file, "rb") as f:
        content = f.read().decode("utf-8")
    body = json.dumps({"gear": SAMPLE_GEAR, "flank": "right", "format": "mka", "content": content}).encode()
    with tempfile.TemporaryDirectory(prefix="gearloop-http-import-") as tmp:
        port = free_port()
        server = subprocess.Popen([args.server_bin, "--host", "127.0.0.1", "--port", str(port), "--quiet",
                                   "--db", os.path.join(tmp, "jobs.sqlite")],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(100):
                try:
                    with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                        break
                except OSError:
                    time.sleep(0.05)
            connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
            headers = {"Content-Type": "application/json"}
            times_ms = []
            for i in range(args.requests + 5):
                start = time.perf_counter()
                connection.request("POST", "/api/v1/measurements/import", body, headers)
                response = connection.getresponse()
                answer = response.read()
                elapsed = (time.perf_counter() - start) * 1e3
                if response.status != 200:
                    print(f"request {i}: {response.status} {answer[:300]!r}", file=sys.stderr)
                    return 1
                if i >= 5:  # the first few warm the connection and the server's threads
                    times_ms.append(elapsed)
            overall = json.loads(answer)["classes"]["overall"]
        finally:
            server.terminate()
            server.wait(timeout=30)
    times_ms.sort()
    p95 = times_ms[min(len(times_ms) - 1, int(0.95 * len(times_ms)))]
    print(f"file {len(content) / 1024:.1f} kB, request body {len(body) / 1024:.1f} kB, "
          f"{len(times_ms)} requests, overall class {overall}")
    print(f"round trip: mean {statistics.mean(times_ms):.2f} ms, median {statistics.median(times_ms):.2f} ms, "
          f"p95 {p95:.2f} ms, max {times_ms[-1]:.2f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
